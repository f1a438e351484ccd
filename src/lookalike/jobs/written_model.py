"""The model a run writes, chosen as the user receives it: the start and every state of the
fit are scored on the validation views as they would be written (alpha-tested at the chosen
cutoff, dithered, or blended: ``jobs.alpha_export``), so that the best state is the best
*written* state, and a fit that ends below its start returns its start. The score is the mean
PSNR, or where FLIP weighs in (``optim.validation_flip_share``) a blend of PSNR and FLIP in dB
(``lookalike.report.metrics.perceptual_score``); a model scored in several forms (a displaced
model at each tessellation level) scores the mean over them, or, where every form must gain, the
least gain of a form over the start's same form. Without validation views, the fit's best state
is written as it is chosen by the loop (nothing to compare on).

Where the run also draws its models as an engine does (``engine_draw``: one texture lookup and
one alpha test per pixel at the engine's mip level, ``jobs.run.engine_draw``), the written model
must gain on the start there too: of the fit, the fit with the start's base colour and alpha,
and the fit with the start's RGB under its own alpha (``with_base_colour_of``: texels trained
under a soft coverage ramp can be tuned to coverage the written alpha test does not draw), the
one with the largest least gain over the start in the two draws is written, and the start where
none gains in both. Why: an alpha-tested model's score
in our supersampled draw can rise while an engine, or a viewer built on one, draws it worse than
its start; the engine draw ranks them as three.js does (``docs/benchmarks.md``)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import torch

from ..asset import Asset, Texture
from ..asset.edge_texels import with_texels_from_inside
from ..fit.latent import Latent
from ..report.heldout import AssetRenderer, HeldoutViews
from .alpha_export import AlphaChoice, alpha_label, chosen_alpha, written_alpha

BASE_COLOUR_OF_START = "ours with the start's base colour"
"""The label of the fit with the start's base colour and alpha (``with_base_colour_of``)."""
RGB_OF_START = "ours with the start's RGB"
"""The label of the fit with the start's RGB under its own alpha (``with_base_colour_of``)."""
MIXES = {BASE_COLOUR_OF_START: "the start's base colour and alpha", RGB_OF_START: "the start's RGB under its own alpha"}
"""What each mix of the fit with its start takes from the start, for the report's notes."""
EDGE_TEXELS_TAKEN = "its texels beside hard edges taken from further in"
"""Added to the label of a model offered with ``asset.edge_texels.with_texels_from_inside``."""


def with_edge_texels_taken(models: dict[str, Asset]) -> dict[str, Asset]:
    """Each of ``models`` (by label) with its texels beside hard edges taken from further in
    (``asset.edge_texels.with_texels_from_inside``), by its label and ``EDGE_TEXELS_TAKEN``,
    where that changes it: offered beside them, because a fit pulls those texels towards the
    other side of the edge, a rim in every other draw, while at a seam of a finely curved chart
    they hold detail; the validation views choose."""
    offered = {}
    for label, model in models.items():
        if (taken := with_texels_from_inside(model)) is not None:
            offered[f"{label}, {EDGE_TEXELS_TAKEN}"] = taken
    return offered


def with_base_colour_of(model: Asset, start: Asset, alpha: bool = True) -> Asset | None:
    """``model`` with ``start``'s base colour: each material's ``kd`` RGB, and with ``alpha`` its
    alpha and alpha cutoff too (else ``model``'s own), where the two share one atlas (the same
    triangles, UV sets and materials, their base colour maps of one size, mips fitted in both or
    in neither: a fit of ``start`` that moved its vertices and texels); ``None`` where they do
    not."""
    mine, theirs = model.mesh, start.mesh
    shared = (len(model.materials) == len(start.materials) and torch.equal(mine.t_pos_idx, theirs.t_pos_idx)
              and len(mine.uv) == len(theirs.uv)
              and all(torch.equal(a, b) for pair, other in zip(mine.uv, theirs.uv) for a, b in zip(pair, other))
              and all(m.kd.data.shape == s.kd.data.shape and (m.kd.mips is None) == (s.kd.mips is None)
                      for m, s in zip(model.materials, start.materials)))
    if not shared:
        return None
    if alpha:
        materials = [dataclasses.replace(m, kd=s.kd, alpha_cutoff=s.alpha_cutoff)
                     for m, s in zip(model.materials, start.materials)]
    else:
        materials = [dataclasses.replace(m, kd=_rgb_of(s.kd, m.kd)) for m, s in zip(model.materials, start.materials)]
    return dataclasses.replace(model, materials=materials)


def _rgb_of(colour: Texture, alpha: Texture) -> Texture:
    """``alpha`` with ``colour``'s RGB, at every level (``[..., 4]`` texels)."""
    def mixed(rgb: torch.Tensor, a: torch.Tensor) -> torch.Tensor:
        return torch.cat([rgb[..., :3], a[..., 3:]], dim=-1)

    mips = None if alpha.mips is None else [mixed(c, a) for c, a in zip(colour.mips, alpha.mips)]
    return dataclasses.replace(alpha, data=mixed(colour.data, alpha.data), mips=mips)


class WrittenModel:
    """Scores and chooses models as written for ``latent.alpha_mode`` ``mode`` on
    ``validation`` (``None``: no validation views), drawn by ``draw``; ``annealed``: the fit
    trains its alpha test in (``latent.mask_anneal``), at the start's cutoff; ``forms``: the
    forms a model is scored in, by the mean of their scores (e.g. a displaced model at each of
    its tessellation levels; by default the model alone); ``flip_share``: FLIP's weight in the
    score (``HeldoutViews.validation_score``; 0: PSNR alone); ``every_form_gains``: score a
    model by ``min_k (s_k - s_k(start))``, its least gain over the start among its forms, so
    that the state chosen lifts each form rather than their mean at one form's cost;
    ``engine_draw``: where given, ``kept`` also asks each candidate to gain on the start drawn
    this way (module docstring).

    Attributes:
        choice: the alpha choice of the start, with which every state of the fit is scored.
        scores: ``{"start": score, "ours": score}`` of the written models on the validation
            views (``score``), once ``kept`` has compared them; with ``engine_draw`` also the
            fit's mixes with the start's base colour (``MIXES``), and each model's score in the
            engine's draw under ``"<key>, engine"``.
        kept_label: which model ``kept`` returned: ``"ours"``, ``"start"`` or a key of
            ``MIXES``.
        alpha: ``{"start": label, "ours": label}``, how each writes its alpha
            (``alpha_export.alpha_label``), once chosen; ``"written"`` is added by ``kept``
            (the one of the model it returns).
        start_forms: each form's score of the start as written, once ``start`` has scored it
            (with ``every_form_gains``).
    """

    def __init__(self, mode: str, validation: HeldoutViews | None, draw: AssetRenderer, annealed: bool = False,
                 forms: Callable[[Asset], list[Asset]] = lambda model: [model], flip_share: float = 0.0,
                 every_form_gains: bool = False, engine_draw: AssetRenderer | None = None):
        self.mode, self.validation, self.draw, self.annealed, self.forms = mode, validation, draw, annealed, forms
        self.flip_share, self.every_form_gains, self.engine_draw = flip_share, every_form_gains, engine_draw
        self.kept_label = "ours"
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
        """The validation score of ``asset`` (as it is): ``combined`` of its ``form_scores``."""
        return self.combined(self.form_scores(asset))

    def combined(self, scores: list[float]) -> float:
        """One score of a model's ``form_scores``: their mean, or with ``every_form_gains``
        (once the start is scored) their least gain over the start's."""
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
        and show only dithered or at a lower cutoff). With ``every_form_gains``, a latent that
        has ``observe_form_gains`` is told each form's gain over the start (of the better)."""
        model = latent.export()
        choices = {self.choice, AlphaChoice()} if self.annealed else {self.choice}
        scores = max((self.form_scores(written_alpha(model, self.mode, choice)) for choice in choices),
                     key=self.combined)
        if self.every_form_gains and self.start_forms is not None and hasattr(latent, "observe_form_gains"):
            latent.observe_form_gains([score - start for score, start in zip(scores, self.start_forms)])
        return self.combined(scores)

    def finished(self, best: Asset) -> Asset:
        """The fit's best model as written, its alpha choice made again for it."""
        choice = chosen_alpha(best, self.mode, self._scorer())
        self.alpha["ours"] = alpha_label(best, self.mode, choice)
        return written_alpha(best, self.mode, choice)

    def kept(self, ours: Asset, start: Asset, alternatives: dict[str, Asset] | None = None) -> tuple[Asset, bool]:
        """``(model, is_start)``: ``ours``, or ``start`` where ``ours`` does not score above it on
        the validation views (both as written): a fit that did not improve returns its start.
        ``alternatives`` (by label; e.g. a field baked again onto the fitted mesh,
        ``jobs.reference_kinds``) compete with ``ours``: the one of the largest gain over the
        start is written. With ``engine_draw``, ``ours`` and its two mixes with the start's base
        colour (``MIXES``) compete too, each by its least gain over the start in the run's draw
        and the engine's, where that gain is positive (module docstring)."""
        self.kept_label = "ours"
        if self.validation is None:
            self.alpha["written"] = self.alpha.get("ours")
            return ours, False
        models = {"start": start, "ours": ours, **(alternatives or {})}
        for label, alpha in ((BASE_COLOUR_OF_START, True), (RGB_OF_START, False)):
            if self.engine_draw is not None and (mixed := with_base_colour_of(ours, start, alpha)) is not None:
                models[label] = mixed
        self.scores = {key: self.score(model) for key, model in models.items()}
        gains = {key: self.scores[key] - self.scores["start"] for key in models if key != "start"}
        if self.engine_draw is not None:
            engine = {key: self.validation.validation_score(model, self.engine_draw, self.flip_share)
                      for key, model in models.items()}
            self.scores.update({f"{key}, engine": score for key, score in engine.items()})
            gains = {key: min(gain, engine[key] - engine["start"]) for key, gain in gains.items()}
        best = max(gains, key=gains.get)
        self.kept_label = best if gains[best] > 0 else "start"
        alpha_of_start = self.kept_label in ("start", BASE_COLOUR_OF_START)
        self.alpha["written"] = self.alpha.get("start" if alpha_of_start else "ours")
        return models[self.kept_label], self.kept_label == "start"
