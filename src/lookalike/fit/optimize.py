"""The optimisation loop (paper Sec. 6.3): Adam on positions and textures of a :class:`Latent`.

Each step draws a mini-batch of views (camera, light, reference image), renders the latent
model under them, composites both renders over the same random background colour per view
(so that coverage and alpha are compared along with colour) and minimises

    L = L_image(latent, reference) + w_outline * L_outline + lambda_t * L_laplacian(v_pos),

where L_outline = mean |coverage(latent) - coverage(reference)| over a few more views of the
batch, drawn for their outline only (``outline_views``; by default from warm starts only), with
lr_t = lr_0 * 10^(-k t) for each parameter group and lambda_t from
``lookalike.fit.schedule``. Textures are clamped to their valid ranges after each step.

Robustness:
- a non-finite loss or gradient rolls the model and Adam back to the last good snapshot
  (taken every ``SNAPSHOT_EVERY`` steps), halves the learning rate, and carries on;
- the best model so far is kept: the one that scores best on the validation views (scored
  every ``optim.validate_every`` steps, at the start and at the end), or, without a
  validator, the one with the lowest moving average of the training loss;
- ``KeyboardInterrupt`` stops the loop cleanly after writing a checkpoint;
- a checkpoint is written atomically every ``checkpoint_seconds`` and on interruption, and
  ``read_checkpoint`` and ``Fitter.load_state_dict`` continue from one exactly where it stopped.
"""

from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Protocol

import numpy as np
import torch
from tqdm import tqdm

from ..asset import Asset
from ..asset.laplacian import UniformLaplacian
from ..errors import ConfigError
from ..shading.camera import Camera
from ..shading.light import PointLight
from ..shading.pipeline import render_coverage
from .config import Config, config_from_dict, config_to_dict, learning_rates, outline_views, start_defaults
from .latent import Latent
from .losses import composite, image_loss
from .outdir import atomic_path
from .schedule import laplacian_decay_rate, laplacian_weight, learning_rate, learning_rate_decay

SNAPSHOT_EVERY = 20
"""Steps between snapshots of the last good state (the rollback target)."""

CALIBRATION_STEPS = 4
"""Steps timed (after the first, which pays one-off compilation) to set the iteration count."""

REPLAN_EVERY = 20
"""Steps between re-plannings of the iteration count under a time budget."""

LOSS_EMA = 0.9
"""Smoothing factor of the loss average that decides which state is the best without a validator."""

LAMBDA_HEURISTIC = 0.25
"""lambda_0 = LAMBDA_HEURISTIC * L_image / L_laplacian when not configured (paper Sec. 6.3)."""

CHECKPOINT_VERSION = 2


@dataclass
class Batch:
    """Views of one step: ``camera`` and ``light`` (batch B) and the reference ``target``
    ``[B, H, W, 4]`` float32 (linear RGB weighted by coverage, and coverage)."""

    camera: Camera
    light: PointLight
    target: torch.Tensor

    def split(self, n: int) -> tuple["Batch", "Batch | None"]:
        """The first ``n`` views and the rest (``None`` if there are none)."""
        head = Batch(self.camera[:n], self.light[:n], self.target[:n])
        if self.target.shape[0] <= n:
            return head, None
        return head, Batch(self.camera[n:], self.light[n:], self.target[n:])


class BatchSource(Protocol):
    """Where training views come from (``lookalike.fit.targets``); its state (if any) is part
    of a checkpoint."""

    def sample(self, rng: np.random.Generator, batch_size: int) -> Batch:
        ...

    def state_dict(self) -> dict:
        ...

    def load_state_dict(self, state: dict) -> None:
        ...


RenderFn = Callable[[Asset, Camera, PointLight], torch.Tensor]
"""Renders an asset under B views: ``[B, H, W, 4]`` (differentiable)."""

Validator = Callable[[Asset], float]
"""Scores a model on views it is not trained on; higher is better (e.g. mean PSNR in dB)."""


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
    lambda_0: float | None = None
    losses: list[float] = field(default_factory=list)
    loss_ema: float | None = None
    best_score: float = -math.inf
    validation: list[tuple[int, float]] = field(default_factory=list)
    seconds: float = 0.0
    validation_seconds: float = 0.0
    rollbacks: int = 0
    rollbacks_in_a_row: int = 0


class Fitter:
    """Runs the optimisation of one latent model.

    Args:
        latent: the model to optimise (modified in place).
        source: training views and reference images.
        render: renders the latent's asset under a batch of views.
        config: the run's settings (``optim``, ``views``, ``clamp`` sections are used).
        checkpoint: where to write checkpoints (``None``: never).
        validate: scores a model on held-back views; the best-scoring state is kept
            (``None``: the state with the lowest moving average of the training loss).
    """

    def __init__(self, latent: Latent, source: BatchSource, render: RenderFn, config: Config,
                 checkpoint: Path | None = None, validate: Validator | None = None):
        self.latent = latent
        self.source = source
        self.render = render
        self.config = config
        self.checkpoint = checkpoint
        self.validate = validate
        opt = config.optim
        torch.manual_seed(opt.seed)
        self.rng = np.random.default_rng(opt.seed)
        self.loss_fn = image_loss(opt.loss)
        self.laplacian = UniformLaplacian(latent.t_pos_idx, latent.v_pos.shape[0])
        self.rest_delta = self.laplacian.differentials(latent.v_pos.detach())
        lr_positions, lr_textures = learning_rates(config)
        self.optimizer = torch.optim.Adam([
            {"params": latent.position_parameters(), "lr": lr_positions, "lr_0": lr_positions},
            {"params": latent.texture_parameters(), "lr": lr_textures, "lr_0": lr_textures},
        ], fused=True)
        self.outline_count = self._count_outline_views()
        self.progress = _Progress(total=opt.iterations)
        self.best_state = copy.deepcopy(latent.state_dict())
        self._snapshot()
        self._mark_random_state()

    def _count_outline_views(self) -> int:
        """Coverage-only views per step: ``outline_views``, at most the pool's views besides
        the batch; none where the latent has alpha (its coverage is then a texture's too)."""
        if self.latent.alpha_mode != "OPAQUE":
            return 0
        views = self.config.views
        count = outline_views(self.config)
        return count if views.pool_size == 0 else min(count, views.pool_size - views.batch_size)

    def _mark_random_state(self) -> None:
        """Remember the random state between steps, so that a checkpoint written while a step
        is interrupted resumes by repeating that step with the same views."""
        self._random_state = (torch.get_rng_state(), copy.deepcopy(self.rng.bit_generator.state))

    # -- one step -------------------------------------------------------------------------

    def _set_learning_rates(self) -> None:
        """lr_t = lr_0 * 10^(-k t) per group (k = 0 until the total is known), times the
        reduction after rollbacks."""
        p, k = self.progress, self.config.optim.lr_decay
        if k is None:
            k = 0.0 if p.total is None else learning_rate_decay(p.total, start_defaults(self.config).lr_decades)
        for group in self.optimizer.param_groups:
            group["lr"] = learning_rate(group["lr_0"], p.iteration, k) * p.lr_scale

    def _lambda(self, image_loss_value: float) -> float:
        """lambda_t; on the first call without a configured lambda_0 the heuristic sets it from
        the image loss and the absolute Laplacian energy of the initial mesh, mean |delta'|^2
        (the relative term itself is zero at the start)."""
        opt, p = self.config.optim, self.progress
        if p.lambda_0 is None:
            if opt.laplacian_weight is not None:
                p.lambda_0 = opt.laplacian_weight
            else:
                rest_energy = float((self.rest_delta ** 2).sum(dim=-1).mean())
                p.lambda_0 = LAMBDA_HEURISTIC * image_loss_value / max(rest_energy, 1e-12)
        if p.total is None:
            return p.lambda_0
        k = laplacian_decay_rate(p.total, opt.laplacian_decay_fraction)
        return laplacian_weight(p.lambda_0, p.iteration, k, opt.laplacian_min_fraction)

    def _background(self, batch_size: int) -> torch.Tensor:
        """``[B, 3]`` random background colours, uniform in [0, 1]."""
        return torch.from_numpy(self.rng.uniform(0.0, 1.0, size=(batch_size, 3)).astype(np.float32))

    def loss(self, batch: Batch, background: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``(image loss, Laplacian loss)`` of the current model on ``batch`` (differentiable).

        The image loss compares the first ``views.batch_size`` views, shaded, over
        ``background [B, 3]``; where ``batch`` holds more (outline views), it adds
        ``optim.outline_weight * mean |c - c_ref|`` over their pixels, c the latent's
        antialiased coverage (``render_coverage``) and c_ref the reference's alpha.
        """
        asset = self.latent.as_asset()
        shaded, outline = batch.split(self.config.views.batch_size)
        pred = self.render(asset, shaded.camera, shaded.light)
        image = self.loss_fn(composite(pred, background), composite(shaded.target, background))
        if outline is not None:
            coverage = render_coverage(asset.mesh, outline.camera, outline.target.shape[1:3], self.config.render.latent_msaa)
            image = image + self.config.optim.outline_weight * (coverage - outline.target[..., 3]).abs().mean()
        return image, self.laplacian.loss(self.latent.v_pos, self.rest_delta)

    def step(self) -> float:
        """One optimisation step; returns the total loss (NaN if the step was rolled back)."""
        p = self.progress
        batch = self.source.sample(self.rng, self.config.views.batch_size + self.outline_count)
        background = self._background(self.config.views.batch_size)
        self._set_learning_rates()
        self.optimizer.zero_grad(set_to_none=True)
        image, lap = self.loss(batch, background)
        total = image + self._lambda(float(image.detach())) * lap
        total.backward()
        value = float(total.detach())
        if not (math.isfinite(value) and self._gradients_finite()):
            self._roll_back()
            value = math.nan
        else:
            self.optimizer.step()
            self.latent.clamp_(self.config.clamp)
            p.rollbacks_in_a_row = 0
            p.loss_ema = value if p.loss_ema is None else LOSS_EMA * p.loss_ema + (1 - LOSS_EMA) * value
        p.iteration += 1
        p.losses.append(value)
        if p.iteration % SNAPSHOT_EVERY == 0 and p.rollbacks_in_a_row == 0:
            self._snapshot()
        if p.iteration % self.config.optim.validate_every == 0 and p.rollbacks_in_a_row == 0:
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
        with torch.no_grad():
            score = float(self.validate(self.latent.as_asset()))
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
        p.lr_scale *= self.config.optim.rollback_lr_factor
        p.rollbacks += 1
        p.rollbacks_in_a_row += 1

    # -- the loop -------------------------------------------------------------------------

    def run(self, seconds_available: float | None = None, progress: bool = True) -> FitResult:
        """Step until ``progress.total`` steps are done.

        With ``seconds_available`` (the loop's share of a time budget; only when
        ``optim.iterations`` is unset), the total follows the clock: it is set after the
        first ``1 + CALIBRATION_STEPS`` steps (the first pays one-off compilation and is not
        timed) from their pace, and re-planned every ``REPLAN_EVERY`` steps from the pace of
        the recent ones (each step's share of the validation time included), so that the loop
        ends in time even when the machine's load changes.
        """
        p = self.progress
        if p.total is None and seconds_available is None:
            raise ValueError("the loop needs optim.iterations or seconds_available")
        interrupted = False
        bar = tqdm(total=p.total, initial=p.iteration, disable=not progress, unit="it", dynamic_ncols=True,
                   desc="optimising")
        loop_start = last_checkpoint = time.monotonic()
        durations: list[float] = []
        self._score()
        try:
            while p.total is None or p.iteration < p.total:
                started = time.monotonic()
                value = self.step()
                durations.append(time.monotonic() - started)
                p.seconds += durations[-1]
                bar.update(1)
                bar.set_postfix(self._postfix(value), refresh=False)
                if seconds_available is not None and len(durations) > CALIBRATION_STEPS and (
                        p.total is None or len(durations) % REPLAN_EVERY == 0):
                    pace = float(np.mean(durations[1:][-REPLAN_EVERY:])) + self._validation_pace()
                    left = seconds_available - (time.monotonic() - loop_start)
                    p.total = p.iteration + max(0, int(left / pace))
                    bar.total = p.total
                    bar.refresh()
                if p.rollbacks_in_a_row >= self.config.optim.max_rollbacks:
                    bar.write(f"stopping: {p.rollbacks_in_a_row} non-finite steps in a row")
                    break
                if self.checkpoint is not None and time.monotonic() - last_checkpoint > self.config.optim.checkpoint_seconds:
                    self.save_checkpoint(self.checkpoint)
                    last_checkpoint = time.monotonic()
        except KeyboardInterrupt:
            interrupted = True
            if self.checkpoint is not None:
                self.save_checkpoint(self.checkpoint)
        finally:
            bar.close()
        self._snapshot()
        if p.rollbacks_in_a_row == 0:
            self._score()
        return FitResult(best=self.best_model(), iterations=p.iteration, losses=list(p.losses),
                         seconds=p.seconds, rollbacks=p.rollbacks, validation=list(p.validation),
                         interrupted=interrupted)

    def _postfix(self, loss: float) -> dict[str, str]:
        """What the progress bar shows after the count: the step's loss and, with a validator,
        the latest and the best validation scores (``val``, ``best``; PSNR in dB in ``simplify``)."""
        p = self.progress
        postfix = {"loss": f"{loss:.4f}"}
        if p.validation:
            postfix["val"] = f"{p.validation[-1][1]:.2f}"
            postfix["best"] = f"{p.best_score:.2f}"
        return postfix

    def _validation_pace(self) -> float:
        """Seconds of validation per step so far (mean scoring time / ``validate_every``)."""
        scorings = len(self.progress.validation)
        if not scorings:
            return 0.0
        return self.progress.validation_seconds / scorings / self.config.optim.validate_every

    def best_model(self) -> Latent:
        """A detached copy of the best model so far."""
        return Latent.from_state_dict(self.best_state)

    # -- checkpoints ----------------------------------------------------------------------

    def state_dict(self) -> dict:
        """Everything needed to continue exactly where the loop stands."""
        return {
            "version": CHECKPOINT_VERSION,
            "config": config_to_dict(self.config),
            "latent": self.latent.state_dict(),
            "optimizer": self.optimizer.state_dict(),
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
        self.best_state = state["best"]
        self._good = state["snapshot"]
        self.progress = _Progress(**state["progress"])
        self.source.load_state_dict(state["source"])
        torch.set_rng_state(state["torch_rng"])
        self.rng.bit_generator.state = state["numpy_rng"]
        self._mark_random_state()

    def save_checkpoint(self, path: Path) -> None:
        """Write ``state_dict()`` to ``path`` atomically."""
        with atomic_path(path) as temp:
            torch.save(self.state_dict(), temp)


def read_checkpoint(path: Path) -> tuple[dict, Config, Latent]:
    """``(state, config, latent)`` of a checkpoint written by ``Fitter.save_checkpoint``; the
    latent holds the checkpoint's current (not best) state. Build the ``Fitter`` from these and
    call ``load_state_dict(state)`` to continue."""
    try:
        state = torch.load(path, map_location="cpu", weights_only=False)
    except Exception as e:  # torch raises many kinds for a truncated or foreign file
        raise ConfigError(f"{path}: cannot read the checkpoint ({e})") from None
    if not isinstance(state, dict) or state.get("version") != CHECKPOINT_VERSION:
        raise ConfigError(f"{path}: not a lookalike checkpoint of version {CHECKPOINT_VERSION}")
    return state, config_from_dict(state["config"], origin=str(path)), Latent.from_state_dict(state["latent"])
