"""The best state of a run, which the loop returns instead of its last one (paper Sec. 6.3): the
latent state that scores best on the validation views, or, without a validator, the one with the
lowest moving average of the training loss."""

from __future__ import annotations

import copy
import math
import time
from collections.abc import Callable

import torch

from ..phases import phase
from .latent import Latent

LOSS_EMA = 0.9
"""beta in m_t = beta * m_(t-1) + (1 - beta) * loss_t, the loss average that ranks states
without a validator."""

Validator = Callable[[Latent], float]
"""Scores a model on views it is not trained on; higher is better (e.g. the mean PSNR, or PSNR and
FLIP blended: ``lookalike.report.metrics.perceptual_score``)."""


class BestState:
    """Keeps a copy of the best state dict of a latent model seen so far and the scores that
    chose it.

    A state's score s is higher-is-better. With a validator, s is its score on held-back views,
    taken at step 0, every ``validate_every`` steps and when the loop asks (``validate``).
    Without one, s = -m_t with m_t = ``LOSS_EMA`` * m_(t-1) + (1 - ``LOSS_EMA``) * loss_t over the
    finite steps, taken at the loop's snapshots (``offer``): the average, because one
    mini-batch's loss says more about the views drawn than about the model. A state replaces the
    kept one only when its score is finite and strictly higher.

    Args:
        validator: scores a model on held-back views (``None``: rank by the loss average).
        validate_every: steps between scorings by the validator.
        start: the state dict kept until a state scores (a copy the keeper owns).

    Attributes:
        state: the kept state dict.
        score: its score (-inf until a state is kept).
        loss_ema: m_t (``None`` before the first finite step).
        validation: ``[(iteration, score), ...]`` the validator's scores, ``iteration`` being the
            number of steps taken before the scoring.
        validation_seconds: wall time spent scoring.
    """

    def __init__(self, validator: Validator | None, validate_every: int, start: dict):
        self.validator = validator
        self.validate_every = validate_every
        self.state = start
        self.score = -math.inf
        self.loss_ema: float | None = None
        self.validation: list[tuple[int, float]] = []
        self.validation_seconds = 0.0

    def observe_loss(self, loss: float) -> None:
        """Fold a finite step's loss into m_t."""
        self.loss_ema = loss if self.loss_ema is None else LOSS_EMA * self.loss_ema + (1 - LOSS_EMA) * loss

    def offer(self, state: dict) -> None:
        """A snapshot of the model (a copy the keeper may keep): without a validator it is kept
        if -m_t beats the best score."""
        if self.validator is None and self.loss_ema is not None:
            self.keep_if_best(-self.loss_ema, lambda: state)

    def at_start(self, latent: Latent, iteration: int) -> None:
        """Score the start, at step 0 only: a resumed session then scores where the
        uninterrupted one would, so it keeps the same best state."""
        if iteration == 0:
            self.validate(latent, iteration)

    def after_step(self, latent: Latent, iteration: int) -> None:
        """Score the model after a good step if ``iteration`` is a multiple of ``validate_every``."""
        if iteration % self.validate_every == 0:
            self.validate(latent, iteration)

    def validate(self, latent: Latent, iteration: int) -> None:
        """Score ``latent`` with the validator (if any), timed, and keep its state if it is the
        best; a state already scored at this iteration is not scored again."""
        if self.validator is None or (self.validation and self.validation[-1][0] == iteration):
            return
        started = time.monotonic()
        with torch.no_grad(), phase("validation"):
            score = float(self.validator(latent))
        self.validation_seconds += time.monotonic() - started
        self.validation.append((iteration, score))
        self.keep_if_best(score, lambda: copy.deepcopy(latent.state_dict()))

    def keep_if_best(self, score: float, state: Callable[[], dict]) -> None:
        """Keep ``state()`` if ``score`` is finite and beats the best so far; ``state`` is called
        only then, so that a losing state costs no copy."""
        if math.isfinite(score) and score > self.score:
            self.score = score
            self.state = state()

    @property
    def seconds_per_scoring(self) -> float:
        """Mean wall time of one scoring (0 before the first)."""
        return self.validation_seconds / len(self.validation) if self.validation else 0.0

    def scores(self) -> tuple[float, float] | None:
        """The latest validation score and the best score (``None`` before the first scoring)."""
        return (self.validation[-1][1], self.score) if self.validation else None

    def model(self, latent: Latent) -> Latent:
        """A detached copy of ``latent`` in the kept state."""
        best = copy.deepcopy(latent)
        best.load_state_dict(self.state)
        return best.requires_grad_(False)

    def state_dict(self) -> dict:
        """The kept state and the scores, for a checkpoint."""
        return {"state": self.state, "score": self.score, "loss_ema": self.loss_ema,
                "validation": list(self.validation), "validation_seconds": self.validation_seconds}

    def load_state_dict(self, state: dict) -> None:
        self.state = state["state"]
        self.score = state["score"]
        self.loss_ema = state["loss_ema"]
        self.validation = list(state["validation"])
        self.validation_seconds = state["validation_seconds"]
