"""The optimisation loop (paper Sec. 6.3): Adam on the parameter groups of a
:class:`~lookalike.fit.latent.Latent`, minimising an :class:`~lookalike.fit.objective.Objective`
on views from a :class:`~lookalike.fit.training_views.BatchSource`.

The loop knows nothing of meshes. Each step draws a mini-batch, evaluates the objective,
steps Adam with lr_t = lr_0 * 10^(-k t) per group (``lookalike.fit.schedule``) and lets the
latent clamp itself. A non-finite loss or gradient rolls the model and Adam back to the last
good snapshot (taken every ``SNAPSHOT_EVERY`` steps), scales the learning rate down, and
carries on. ``KeyboardInterrupt`` stops the loop cleanly (Ctrl-C and SIGTERM are acted on
between steps, ``lookalike.interrupts``); a ``Checkpointer`` writes the state periodically and
then, and ``load_state_dict`` continues from it exactly where it stopped.

The loop's other concerns are parts of their own: the best state and the validator's scoring
(``best_state``), the step count under a time budget (``pacing``), the bar (``progress_bar``)
and giving cores to other busy programs (``lookalike.threads.CoreShare``).
"""

from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass, field

import numpy as np
import torch

from ..devices import moved
from ..interrupts import BetweenSteps
from ..phases import phase
from ..threads import CoreShare
from .best_state import BestState, Validator
from .checkpoint import Checkpointer
from .latent import Latent
from .objective import Objective
from .pacing import Pacing, closing
from .progress_bar import ProgressBar
from .schedule import learning_rate, learning_rate_decay
from .training_views import BatchSource

SNAPSHOT_EVERY = 20
"""Steps between snapshots of the last good state (the rollback target)."""

BACKOFF_FACTOR = 0.5
"""What a backoff (``Fitter._back_off``) multiplies the position learning rate by."""


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
        position_backoff: dB below the best validation score at which the loop returns to the
            best state and halves the position learning rate (0: never; see ``_back_off``).

    No field has a default: a run's settings give them all (``fit.from_settings.loop_settings``),
    so that each default is written once, in ``lookalike.settings``.
    """

    learning_rates: dict[str, float]
    views_per_step: int
    iterations: int | None
    lr_decay: float | None
    lr_decades: float
    seed: int
    validate_every: int
    rollback_lr_factor: float
    max_rollbacks: int
    position_backoff: float


@dataclass
class FitResult:
    """What the loop produced.

    Attributes:
        best: the best latent model (a detached copy).
        iterations: steps taken in total (over all resumed sessions).
        losses: ``[iterations]`` training loss per step (NaN for rolled-back steps).
        seconds: wall time spent stepping (over all sessions).
        rollbacks: number of rollbacks after non-finite steps.
        backoffs: number of returns to the best state that halved the position learning rate.
        validation: ``[(iteration, score), ...]`` the validator's scores (empty without one);
            ``iteration`` is the number of steps taken before the scoring.
        interrupted: stopped by Ctrl-C.
    """

    best: Latent
    iterations: int
    losses: list[float]
    seconds: float
    rollbacks: int
    backoffs: int = 0
    validation: list[tuple[int, float]] = field(default_factory=list)
    interrupted: bool = False


@dataclass
class _Progress:
    """The loop's counters, which a checkpoint carries (the names as in ``FitResult``;
    ``total``: the planned step count, ``None`` until a time budget sets it; ``lr_scale``: the
    learning rates' reduction after rollbacks; ``position_scale``: the position rate's after
    backoffs)."""

    iteration: int = 0
    total: int | None = None
    lr_scale: float = 1.0
    position_scale: float = 1.0
    backoffs: int = 0
    losses: list[float] = field(default_factory=list)
    seconds: float = 0.0
    rollbacks: int = 0
    rollbacks_in_a_row: int = 0


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

    Attributes:
        progress: the loop's counters (iteration, total, losses, rollbacks).
        best: the best state and the validator's scores (``BestState``).
    """

    def __init__(self, latent: Latent, source: BatchSource, objective: Objective, settings: LoopSettings,
                 validate: Validator | None = None, checkpointer: Checkpointer | None = None,
                 cores: CoreShare | None = None):
        self.latent = latent
        self.device = next(iter(latent.parameters())).device  # where each step's views are moved
        self.source = source
        self.objective = objective
        self.settings = settings
        self.checkpointer = checkpointer
        self.cores = cores
        torch.manual_seed(settings.seed)
        self.rng = np.random.default_rng(settings.seed)
        self.optimizer = torch.optim.Adam([
            {"params": params, "lr": settings.learning_rates[name], "lr_0": settings.learning_rates[name], "name": name}
            for name, params in latent.parameter_groups().items()
        ], fused=True)
        self.progress = _Progress(total=settings.iterations)
        self.best = BestState(validate, settings.validate_every, copy.deepcopy(latent.state_dict()))
        self._snapshot()
        self._mark_random_state()

    def _mark_random_state(self) -> None:
        """Remember the random state between steps, so that a checkpoint written while a step
        is interrupted resumes by repeating that step with the same views."""
        self._random_state = (torch.get_rng_state(), copy.deepcopy(self.rng.bit_generator.state))

    # -- one step -------------------------------------------------------------------------

    def _set_learning_rates(self) -> None:
        """lr_t = lr_0 * 10^(-k t) per group (k = 0 until the total is known), times the
        reduction after rollbacks (and, for the positions, after backoffs; a checkpoint of an
        earlier version names no group, and its positions keep their rate)."""
        p, k = self.progress, self.settings.lr_decay
        if k is None:
            k = 0.0 if p.total is None else learning_rate_decay(p.total, self.settings.lr_decades)
        for group in self.optimizer.param_groups:
            scale = p.lr_scale * (p.position_scale if group.get("name") == "positions" else 1.0)
            group["lr"] = learning_rate(group["lr_0"], p.iteration, k) * scale

    def step(self) -> float:
        """One optimisation step; returns the total loss (NaN if the step was rolled back)."""
        p = self.progress
        with phase("views"):
            batch = moved(self.source.sample(self.rng, self.settings.views_per_step), self.device)
        self._set_learning_rates()
        self.latent.at_progress(None if p.total is None else p.iteration / max(p.total, 1))
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
            self.best.observe_loss(value)
        p.iteration += 1
        p.losses.append(value)
        if p.rollbacks_in_a_row == 0:
            if p.iteration % SNAPSHOT_EVERY == 0:
                self._snapshot()
            self.best.after_step(self.latent, p.iteration)
            self._back_off()
        self._mark_random_state()
        return value

    def _gradients_finite(self) -> bool:
        """Whether every gradient is finite (a NaN or infinity anywhere makes its sum non-finite)."""
        sums = [q.grad.sum() for q in self.latent.parameters() if q.grad is not None]
        return bool(torch.stack(sums).isfinite().all()) if sums else True

    def _back_off(self) -> None:
        """Where the validation has just scored ``position_backoff`` dB or more below the best
        state's, return to that state, forget the positions' Adam moments and halve their
        rate: vertices that a rate shakes off a smooth surface faster than the images pull them
        back get a rate they can use, while a fit that climbs keeps its own."""
        p, drop, scored = self.progress, self.settings.position_backoff, self.best.validation
        if drop <= 0 or not scored or scored[-1][0] != p.iteration or not scored[-1][1] <= self.best.score - drop:
            return
        self.latent.load_state_dict(self.best.state)
        for group in self.optimizer.param_groups:
            if group.get("name") == "positions":
                for param in group["params"]:
                    self.optimizer.state.pop(param, None)
        p.position_scale *= BACKOFF_FACTOR
        p.backoffs += 1
        self._snapshot()

    def _snapshot(self) -> None:
        """Remember the current state as the last good one (and offer it as the best)."""
        self._good = (copy.deepcopy(self.latent.state_dict()), copy.deepcopy(self.optimizer.state_dict()))
        self.best.offer(self._good[0])

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
        """Step until ``progress.total`` steps are done, or under ``seconds_available`` (the
        loop's share of a time budget; only when ``settings.iterations`` is unset) until the
        total that ``Pacing`` plans from the clock is; show a bar if ``progress``. The validator
        scores the start (at step 0 only), every ``validate_every`` steps and the end."""
        p = self.progress
        if p.total is None and seconds_available is None:
            raise ValueError("the loop needs settings.iterations or seconds_available")
        bar = ProgressBar(p.iteration, p.total, seconds_available, progress)
        pacing = None if seconds_available is None else Pacing(seconds_available, self.settings.validate_every)
        self.best.at_start(self.latent, p.iteration)
        interrupted = False
        try:
            with BetweenSteps() as stops:
                self._loop(bar, pacing, stops)
        except KeyboardInterrupt:
            interrupted = True
            self._checkpoint(always=True)
        finally:
            bar.close()
            if self.cores is not None:
                self.cores.restore()
        self._snapshot()
        if p.rollbacks_in_a_row == 0:
            self.best.validate(self.latent, p.iteration)
        return FitResult(best=self.best_model(), iterations=p.iteration, losses=list(p.losses),
                         seconds=p.seconds, rollbacks=p.rollbacks, backoffs=p.backoffs, validation=list(self.best.validation),
                         interrupted=interrupted)

    def _loop(self, bar: ProgressBar, pacing: Pacing | None, stops: BetweenSteps) -> None:
        """Step until the total is reached or too many steps in a row were rolled back; between
        steps, re-plan, show, checkpoint (not among the plan's last steps: ``pacing.closing``),
        share cores and deliver held signals."""
        p = self.progress
        while p.total is None or p.iteration < p.total:
            started = time.monotonic()
            value = self.step()
            seconds = time.monotonic() - started
            p.seconds += seconds
            if pacing is not None:
                p.total = pacing.plan(p.iteration, p.total, seconds, self.best.seconds_per_scoring)
            bar.step(p.iteration, p.total, value, self.best.scores())
            if p.rollbacks_in_a_row >= self.settings.max_rollbacks:
                bar.write(f"stopping: {p.rollbacks_in_a_row} non-finite steps in a row")
                return
            if not closing(p.iteration, p.total):
                self._checkpoint(always=False)
            if self.cores is not None:
                self.cores.update()
            stops.deliver()

    def _checkpoint(self, always: bool) -> None:
        """Write a checkpoint (if there is a checkpointer) when ``always`` or when one is due."""
        if self.checkpointer is not None and (always or self.checkpointer.due()):
            self.checkpointer.save(self.state_dict())

    def best_model(self) -> Latent:
        """A detached copy of the best model so far."""
        return self.best.model(self.latent)

    # -- state ----------------------------------------------------------------------------

    def state_dict(self) -> dict:
        """Everything needed to continue exactly where the loop stands."""
        return {
            "latent": self.latent.state_dict(),
            "optimizer": self.optimizer.state_dict(),
            "objective": self.objective.state_dict(),
            "best": self.best.state_dict(),
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
        self.best.load_state_dict(state["best"])
        self._good = state["snapshot"]
        self.progress = _Progress(**state["progress"])
        self.source.load_state_dict(state["source"])
        torch.set_rng_state(state["torch_rng"])
        self.rng.bit_generator.state = state["numpy_rng"]
        self._mark_random_state()
