"""The optimisation loop (paper Sec. 6.3): Adam on the parameter groups of a
:class:`~lookalike.fit.latent.Latent`, minimising an :class:`~lookalike.fit.objective.Objective`
on views from a :class:`~lookalike.fit.training_views.BatchSource`.

The loop knows nothing of meshes. Each step draws a mini-batch, evaluates the objective,
steps Adam with lr_t = lr_0 * 10^(-k t) per group (``lookalike.fit.schedule``) and lets the
latent clamp itself. Around that:
- a non-finite loss or gradient rolls the model and Adam back to the last good snapshot
  (taken every ``SNAPSHOT_EVERY`` steps), scales the learning rate down, and carries on;
- the best state is kept: the one that scores best on the validation views (scored every
  ``validate_every`` steps, at the start and at the end), or, without a validator, the one
  with the lowest moving average of the training loss;
- under a time budget the step count follows the clock;
- with a ``CoreShare``, the loop gives cores to other busy programs while they run
  (``lookalike.threads``);
- ``KeyboardInterrupt`` stops the loop cleanly (Ctrl-C and SIGTERM are acted on between
  steps, ``lookalike.interrupts``); a ``Checkpointer`` writes the state periodically and
  then, and ``load_state_dict`` continues from it exactly where it stopped.
"""

from __future__ import annotations

import copy
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import torch
from tqdm import tqdm

from ..interrupts import BetweenSteps
from ..phases import phase
from ..threads import CoreShare
from .checkpoint import Checkpointer
from .latent import Latent
from .objective import Objective
from .schedule import learning_rate, learning_rate_decay
from .training_views import BatchSource

SNAPSHOT_EVERY = 20
"""Steps between snapshots of the last good state (the rollback target)."""

CALIBRATION_STEPS = 4
"""Steps timed (after the first, which pays one-off compilation) to set the iteration count."""

REPLAN_EVERY = 20
"""Steps between re-plannings of the iteration count under a time budget."""

LOSS_EMA = 0.9
"""Smoothing factor of the loss average that decides which state is the best without a validator."""

Validator = Callable[[Latent], float]
"""Scores a model on views it is not trained on; higher is better (e.g. mean PSNR in dB)."""


@dataclass
class LoopSettings:
    """How the loop steps.

    Attributes:
        learning_rates: lr_0 of each of the latent's parameter groups, by group name.
        views_per_step: views drawn from the source per step (the objective's shaded views
            and outline views).
        iterations: fixed step count, or ``None`` to follow a time budget.
        lr_decay: k in lr_t = lr_0 * 10^(-k t), or ``None`` for k = ``lr_decades`` / total.
        lr_decades: decades the learning rate falls over the run when ``lr_decay`` is unset.
        seed: seeds torch and the loop's numpy generator.
        validate_every: steps between scorings by the validator.
        rollback_lr_factor: a non-finite step rolls back and multiplies the lr by this.
        max_rollbacks: give up (keeping the best state) after this many rollbacks in a row.
    """

    learning_rates: dict[str, float]
    views_per_step: int = 1
    iterations: int | None = None
    lr_decay: float | None = None
    lr_decades: float = 2.0
    seed: int = 0
    validate_every: int = 25
    rollback_lr_factor: float = 0.5
    max_rollbacks: int = 8


@dataclass
class FitResult:
    """What the loop produced.

    Attributes:
        best: the best latent model (a detached copy).
        iterations: steps taken in total (over all resumed sessions).
        losses: ``[iterations]`` training loss per step (NaN for rolled-back steps).
        seconds: wall time spent stepping (over all sessions).
        rollbacks: number of rollbacks after non-finite steps.
        validation: ``[(iteration, score), ...]`` the validator's scores (empty without one);
            ``iteration`` is the number of steps taken before the scoring.
        interrupted: stopped by Ctrl-C.
    """

    best: Latent
    iterations: int
    losses: list[float]
    seconds: float
    rollbacks: int
    validation: list[tuple[int, float]] = field(default_factory=list)
    interrupted: bool = False


@dataclass
class _Progress:
    """Counters that a checkpoint carries."""

    iteration: int = 0
    total: int | None = None
    lr_scale: float = 1.0
    losses: list[float] = field(default_factory=list)
    loss_ema: float | None = None
    best_score: float = -math.inf
    validation: list[tuple[int, float]] = field(default_factory=list)
    seconds: float = 0.0
    validation_seconds: float = 0.0
    rollbacks: int = 0
    rollbacks_in_a_row: int = 0


def _progress_bar(progress: _Progress, seconds_available: float | None, show: bool) -> tqdm:
    """The loop's bar. With a fixed step count it counts steps; under a time budget it counts the
    budget's seconds (the step count is re-planned as the pace changes, the seconds are not),
    so its ETA only ever counts down. The postfix shows the steps either way (``_postfix``)."""
    if seconds_available is None:
        return tqdm(total=progress.total, initial=progress.iteration, disable=not show, unit="it",
                    dynamic_ncols=True, desc="optimising")
    return tqdm(total=round(seconds_available, 1), disable=not show, unit="s", dynamic_ncols=True,
                desc="optimising", bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} s "
                "[{elapsed}<{remaining}{postfix}]")


class Fitter:
    """Runs the optimisation of one latent model.

    Args:
        latent: the model to optimise (modified in place).
        source: training views and reference images.
        objective: what each step minimises.
        settings: how the loop steps.
        validate: scores a model on held-back views; the best-scoring state is kept
            (``None``: the state with the lowest moving average of the training loss).
        checkpointer: writes checkpoints (``None``: never).
        cores: adapts the thread count to the machine's load between steps (``None``: keeps it).
    """

    def __init__(self, latent: Latent, source: BatchSource, objective: Objective, settings: LoopSettings,
                 validate: Validator | None = None, checkpointer: Checkpointer | None = None,
                 cores: CoreShare | None = None):
        self.latent = latent
        self.source = source
        self.objective = objective
        self.settings = settings
        self.validate = validate
        self.checkpointer = checkpointer
        self.cores = cores
        torch.manual_seed(settings.seed)
        self.rng = np.random.default_rng(settings.seed)
        self.optimizer = torch.optim.Adam([
            {"params": params, "lr": settings.learning_rates[name], "lr_0": settings.learning_rates[name]}
            for name, params in latent.parameter_groups().items()
        ], fused=True)
        self.progress = _Progress(total=settings.iterations)
        self.best_state = copy.deepcopy(latent.state_dict())
        self._snapshot()
        self._mark_random_state()

    def _mark_random_state(self) -> None:
        """Remember the random state between steps, so that a checkpoint written while a step
        is interrupted resumes by repeating that step with the same views."""
        self._random_state = (torch.get_rng_state(), copy.deepcopy(self.rng.bit_generator.state))

    # -- one step -------------------------------------------------------------------------

    def _set_learning_rates(self) -> None:
        """lr_t = lr_0 * 10^(-k t) per group (k = 0 until the total is known), times the
        reduction after rollbacks."""
        p, k = self.progress, self.settings.lr_decay
        if k is None:
            k = 0.0 if p.total is None else learning_rate_decay(p.total, self.settings.lr_decades)
        for group in self.optimizer.param_groups:
            group["lr"] = learning_rate(group["lr_0"], p.iteration, k) * p.lr_scale

    def step(self) -> float:
        """One optimisation step; returns the total loss (NaN if the step was rolled back)."""
        p = self.progress
        with phase("views"):
            batch = self.source.sample(self.rng, self.settings.views_per_step)
        self._set_learning_rates()
        self.optimizer.zero_grad(set_to_none=True)
        with phase("forward"):
            terms = self.objective(self.latent, batch, self.rng, p.iteration, p.total)
        with phase("backward"):
            terms.total.backward()
        value = float(terms.total.detach())
        if not (math.isfinite(value) and self._gradients_finite()):
            self._roll_back()
            value = math.nan
        else:
            with phase("update"):
                self.optimizer.step()
                self.latent.clamp_()
            p.rollbacks_in_a_row = 0
            p.loss_ema = value if p.loss_ema is None else LOSS_EMA * p.loss_ema + (1 - LOSS_EMA) * value
        p.iteration += 1
        p.losses.append(value)
        if p.iteration % SNAPSHOT_EVERY == 0 and p.rollbacks_in_a_row == 0:
            self._snapshot()
        if p.iteration % self.settings.validate_every == 0 and p.rollbacks_in_a_row == 0:
            self._score()
        self._mark_random_state()
        return value

    def _gradients_finite(self) -> bool:
        """Whether every gradient is finite (a NaN or infinity anywhere makes its sum non-finite)."""
        sums = [q.grad.sum() for q in self.latent.parameters() if q.grad is not None]
        return bool(torch.stack(sums).isfinite().all()) if sums else True

    def _snapshot(self) -> None:
        """Remember the current state as the last good one (and, without a validator, as the
        best if its loss average is the lowest so far)."""
        self._good = (copy.deepcopy(self.latent.state_dict()), copy.deepcopy(self.optimizer.state_dict()))
        if self.validate is None and self.progress.loss_ema is not None:
            self._keep_if_best(-self.progress.loss_ema, self._good[0])

    def _score(self) -> None:
        """Score the current state with the validator (if any) and keep it if it is the best;
        a state already scored at this iteration is not scored again."""
        p = self.progress
        if self.validate is None or (p.validation and p.validation[-1][0] == p.iteration):
            return
        started = time.monotonic()
        with torch.no_grad(), phase("validation"):
            score = float(self.validate(self.latent))
        p.validation_seconds += time.monotonic() - started
        p.validation.append((p.iteration, score))
        self._keep_if_best(score)

    def _keep_if_best(self, score: float, state: dict | None = None) -> None:
        """Make the current state the best one if ``score`` (higher is better) beats the best
        so far; ``state`` is a copy of it already taken (else one is taken only then)."""
        if math.isfinite(score) and score > self.progress.best_score:
            self.progress.best_score = score
            self.best_state = state if state is not None else copy.deepcopy(self.latent.state_dict())

    def _roll_back(self) -> None:
        """Restore the last good snapshot and lower the learning rate."""
        p = self.progress
        self.latent.load_state_dict(self._good[0])
        self.optimizer.load_state_dict(self._good[1])
        self.optimizer.zero_grad(set_to_none=True)
        p.lr_scale *= self.settings.rollback_lr_factor
        p.rollbacks += 1
        p.rollbacks_in_a_row += 1

    # -- the loop -------------------------------------------------------------------------

    def run(self, seconds_available: float | None = None, progress: bool = True) -> FitResult:
        """Step until ``progress.total`` steps are done.

        With ``seconds_available`` (the loop's share of a time budget; only when
        ``settings.iterations`` is unset), the total follows the clock: it is set after the
        first ``1 + CALIBRATION_STEPS`` steps (the first pays one-off compilation and is not
        timed) from their pace, and re-planned every ``REPLAN_EVERY`` steps from the pace of
        the recent ones (each step's share of the validation time included), so that the loop
        ends in time even when the machine's load changes.

        The start is scored only at step 0: a resumed run scores where the uninterrupted one
        would, so it keeps the same best state.
        """
        p = self.progress
        if p.total is None and seconds_available is None:
            raise ValueError("the loop needs settings.iterations or seconds_available")
        interrupted = False
        bar = _progress_bar(p, seconds_available, progress)
        loop_start = time.monotonic()
        durations: list[float] = []
        if p.iteration == 0:
            self._score()
        try:
            with BetweenSteps() as stops:
                while p.total is None or p.iteration < p.total:
                    started = time.monotonic()
                    value = self.step()
                    durations.append(time.monotonic() - started)
                    p.seconds += durations[-1]
                    if seconds_available is not None and len(durations) > CALIBRATION_STEPS and (
                            p.total is None or len(durations) % REPLAN_EVERY == 0):
                        pace = float(np.mean(durations[1:][-REPLAN_EVERY:])) + self._validation_pace()
                        left = seconds_available - (time.monotonic() - loop_start)
                        p.total = p.iteration + max(0, int(left / pace))
                    bar.set_postfix(self._postfix(value), refresh=False)
                    bar.update(1 if seconds_available is None
                               else min(time.monotonic() - loop_start, seconds_available) - bar.n)
                    if p.rollbacks_in_a_row >= self.settings.max_rollbacks:
                        bar.write(f"stopping: {p.rollbacks_in_a_row} non-finite steps in a row")
                        break
                    if self.checkpointer is not None and self.checkpointer.due():
                        self.checkpointer.save(self.state_dict())
                    if self.cores is not None:
                        self.cores.update()
                    stops.deliver()
        except KeyboardInterrupt:
            interrupted = True
            if self.checkpointer is not None:
                self.checkpointer.save(self.state_dict())
        finally:
            bar.close()
            if self.cores is not None:
                self.cores.restore()
        self._snapshot()
        if p.rollbacks_in_a_row == 0:
            self._score()
        return FitResult(best=self.best_model(), iterations=p.iteration, losses=list(p.losses),
                         seconds=p.seconds, rollbacks=p.rollbacks, validation=list(p.validation),
                         interrupted=interrupted)

    def _postfix(self, loss: float) -> dict[str, str]:
        """What the progress bar shows after the count: the step's loss and, with a validator,
        the latest and the best validation scores (``val``, ``best``)."""
        p = self.progress
        postfix = {"step": f"{p.iteration}/{p.total or '?'}", "loss": f"{loss:.4f}"}
        if p.validation:
            postfix["val"] = f"{p.validation[-1][1]:.2f}"
            postfix["best"] = f"{p.best_score:.2f}"
        return postfix

    def _validation_pace(self) -> float:
        """Seconds of validation per step so far (mean scoring time / ``validate_every``)."""
        scorings = len(self.progress.validation)
        if not scorings:
            return 0.0
        return self.progress.validation_seconds / scorings / self.settings.validate_every

    def best_model(self) -> Latent:
        """A detached copy of the best model so far."""
        best = copy.deepcopy(self.latent)
        best.load_state_dict(self.best_state)
        return best.requires_grad_(False)

    # -- state ----------------------------------------------------------------------------

    def state_dict(self) -> dict:
        """Everything needed to continue exactly where the loop stands."""
        return {
            "latent": self.latent.state_dict(),
            "optimizer": self.optimizer.state_dict(),
            "objective": self.objective.state_dict(),
            "best": self.best_state,
            "snapshot": self._good,
            "progress": self.progress.__dict__.copy(),
            "source": self.source.state_dict(),
            "torch_rng": self._random_state[0],
            "numpy_rng": self._random_state[1],
        }

    def load_state_dict(self, state: dict) -> None:
        self.latent.load_state_dict(state["latent"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.objective.load_state_dict(state["objective"])
        self.best_state = state["best"]
        self._good = state["snapshot"]
        self.progress = _Progress(**state["progress"])
        self.source.load_state_dict(state["source"])
        torch.set_rng_state(state["torch_rng"])
        self.rng.bit_generator.state = state["numpy_rng"]
        self._mark_random_state()
