"""The model a run writes, chosen as the user receives it: the start and every state of the
fit are scored on the validation views as they would be written (alpha-tested at the chosen
cutoff, dithered, or blended: ``jobs.alpha_export``), so that the best state is the best
*written* state, and a fit that ends below its start returns its start. The score is the mean
PSNR, or where FLIP weighs in (``optim.validation_flip_share``) a blend of PSNR and FLIP in dB
(``lookalike.report.metrics.perceptual_score``); a model scored in several forms (a displaced
model at each tessellation level) scores the mean over them, or, where every form must gain, the
least gain of a form over the start's same form. Without validation views, the fit's best state
is written as it is chosen by the loop (nothing to compare on)."""

from __future__ import annotations

from collections.abc import Callable

from ..asset import Asset
from ..fit.latent import Latent
from ..report.heldout import AssetRenderer, HeldoutViews
from .alpha_export import AlphaChoice, alpha_label, chosen_alpha, written_alpha


class WrittenModel:
    """Scores and chooses models as written for ``latent.alpha_mode`` ``mode`` on
    ``validation`` (``None``: no validation views), drawn by ``draw``; ``annealed``: the fit
    trains its alpha test in (``latent.mask_anneal``), at the start's cutoff; ``forms``: the
    forms a model is scored in, by the mean of their scores (e.g. a displaced model at each of
    its tessellation levels; by default the model alone); ``flip_share``: FLIP's weight in the
    score (``HeldoutViews.validation_score``; 0: PSNR alone); ``every_form_gains``: score a
    model by ``min_k (s_k - s_k(start))``, its least gain over the start among its forms, so
    that the state chosen lifts each form rather than their mean at one form's cost.

    Attributes:
        choice: the alpha choice of the start, with which every state of the fit is scored.
        scores: ``{"start": score, "ours": score}`` of the written models on the validation
            views (``score``), once ``kept`` has compared them.
        alpha: ``{"start": label, "ours": label}``, how each writes its alpha
            (``alpha_export.alpha_label``), once chosen; ``"written"`` is added by ``kept``
            (the one of the model it returns).
        start_forms: each form's score of the start as written, once ``start`` has scored it
            (with ``every_form_gains``).
    """

    def __init__(self, mode: str, validation: HeldoutViews | None, draw: AssetRenderer, annealed: bool = False,
                 forms: Callable[[Asset], list[Asset]] = lambda model: [model], flip_share: float = 0.0,
                 every_form_gains: bool = False):
        self.mode, self.validation, self.draw, self.annealed, self.forms = mode, validation, draw, annealed, forms
        self.flip_share, self.every_form_gains = flip_share, every_form_gains
        self.start_forms: list[float] | None = None
        self.choice = AlphaChoice()
        self.scores: dict[str, float] = {}
        self.alpha: dict[str, str | None] = {}

    @property
    def metric(self) -> str:
        """What ``score`` is, for the report's lines."""
        metric = "PSNR" if self.flip_share == 0 else f"score (PSNR and FLIP, FLIP's share {self.flip_share:g})"
        return f"least gain over the start among its forms in {metric}" if self.every_form_gains else metric

    def form_scores(self, asset: Asset) -> list[float]:
        """The validation score (dB, higher is better) of each of ``asset``'s ``forms``: its mean
        PSNR, FLIP weighing in by ``flip_share``."""
        return [self.validation.validation_score(form, self.draw, self.flip_share) for form in self.forms(asset)]

    def score(self, asset: Asset) -> float:
        """The validation score of ``asset`` (as it is): the mean of its ``form_scores``, or with
        ``every_form_gains`` (once the start is scored) their least gain over the start's."""
        scores = self.form_scores(asset)
        if self.every_form_gains and self.start_forms is not None:
            return min(score - start for score, start in zip(scores, self.start_forms))
        return sum(scores) / len(scores)

    def _scorer(self):
        return None if self.validation is None else self.score

    def start(self, start: Asset) -> Asset:
        """``start`` as written, its alpha choice the best on the validation views (kept as
        ``choice``; with ``every_form_gains`` its forms' scores kept as ``start_forms``)."""
        self.choice = chosen_alpha(start, self.mode, self._scorer())
        self.alpha["start"] = alpha_label(start, self.mode, self.choice)
        written = written_alpha(start, self.mode, self.choice)
        if self.every_form_gains and self.validation is not None:
            self.start_forms = self.form_scores(written)
        return written

    def validate(self, latent: Latent) -> float:
        """The loop's validator: the state of ``latent`` as written with the start's choice;
        where the fit trains the alpha test in (``annealed``), the better of that and its own
        cutoff (parts thinner than the cutoff's coverage, hair or grass blades, vanish at it
        and show only dithered or at a lower cutoff)."""
        model = latent.export()
        choices = {self.choice, AlphaChoice()} if self.annealed else {self.choice}
        return max(self.score(written_alpha(model, self.mode, choice)) for choice in choices)

    def finished(self, best: Asset) -> Asset:
        """The fit's best model as written, its alpha choice made again for it."""
        choice = chosen_alpha(best, self.mode, self._scorer())
        self.alpha["ours"] = alpha_label(best, self.mode, choice)
        return written_alpha(best, self.mode, choice)

    def kept(self, ours: Asset, start: Asset) -> tuple[Asset, bool]:
        """``(model, is_start)``: ``ours``, or ``start`` where ``ours`` does not score above it on
        the validation views (both as written): a fit that did not improve returns its start."""
        is_start = False
        if self.validation is not None:
            self.scores = {"start": self.score(start), "ours": self.score(ours)}
            is_start = self.scores["start"] >= self.scores["ours"]
        self.alpha["written"] = self.alpha.get("start" if is_start else "ours")
        return (start, True) if is_start else (ours, False)
