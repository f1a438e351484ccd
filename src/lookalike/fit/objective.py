"""The objective (paper Sec. 6.3): what one step minimises.

    L = L_image + w_outline * L_outline + sum_r lambda_t^r * R_r(latent),

- L_image: the image loss (``lookalike.fit.losses``) between the latent's render and the
  reference's, both composited over the same random background colour per view (so that
  coverage and alpha are compared along with colour), over the first ``batch_size`` views,
  times the latent's ``image_weight`` of it where it has one (a latent drawn in several forms
  in turn balances them);
- L_outline = mean |c - c_ref| over the batch's remaining views (outline views), c the latent's
  antialiased coverage alone and c_ref the reference's;
- R_r: the latent's regularisers (the Laplacian for a mesh), with lambda_t^r following
  ``lookalike.fit.schedule.laplacian_weight`` from lambda_0, which is configured or set on the
  first step to ``LAMBDA_HEURISTIC * L_image / scale_r`` (the latent's ``regularizer_scales``).

The objective is given the latent, which renders itself; it imports no renderer.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from .latent import Latent
from .losses import composite, image_loss
from .schedule import laplacian_decay_rate, laplacian_weight
from .training_views import Batch

LAMBDA_HEURISTIC = 0.25
"""lambda_0 = LAMBDA_HEURISTIC * L_image / scale when not configured (paper Sec. 6.3)."""


@dataclass
class Terms:
    """One evaluation: ``total`` (differentiable scalar) and its parts, as floats."""

    total: torch.Tensor
    image: float
    regularizers: dict[str, float]


class Objective:
    """Image loss + outline loss + scheduled regularisers.

    Args:
        loss: name of the image loss (``lookalike.fit.losses.IMAGE_LOSSES``).
        batch_size: views per step that are shaded; views beyond them are outline views.
        outline_weight: w_outline.
        regularizer_weight: lambda_0 of every regulariser, or ``None`` for the heuristic.
        min_fraction: lambda_min = min_fraction * lambda_0.
        decay_fraction: fraction of the run after which lambda_t - lambda_min has fallen to 1 %
            of lambda_0 - lambda_min.
    """

    def __init__(self, loss: str, batch_size: int, outline_weight: float = 1.0,
                 regularizer_weight: float | None = None, min_fraction: float = 0.02, decay_fraction: float = 0.2):
        self.loss_fn = image_loss(loss)
        self.batch_size = batch_size
        self.outline_weight = outline_weight
        self.regularizer_weight = regularizer_weight
        self.min_fraction = min_fraction
        self.decay_fraction = decay_fraction
        self.lambda_0: dict[str, float] | None = None

    def image_loss(self, latent: Latent, batch: Batch, background: torch.Tensor) -> torch.Tensor:
        """L_image + w_outline * L_outline of ``latent`` on ``batch``, composited over
        ``background [batch_size, 3]`` (differentiable scalar); no outline term where the
        latent's coverage is not geometry's alone (``coverage`` gives ``None``)."""
        shaded, outline = batch.split(self.batch_size)
        resolution = shaded.target.shape[1]
        pred = latent.render(shaded.camera, shaded.light, resolution, shaded.pose)
        loss = self.loss_fn(composite(pred, background), composite(shaded.target, background))
        coverage = None if outline is None else latent.coverage(outline.camera, resolution, outline.pose)
        if coverage is not None:
            loss = loss + self.outline_weight * (coverage - outline.target[..., 3]).abs().mean()
        return loss

    def weights(self, latent: Latent, image_loss_value: float, step: int, total: int | None) -> dict[str, float]:
        """lambda_t of each regulariser at ``step`` of ``total`` (lambda_0 until the total is
        known); the first call fixes lambda_0."""
        if self.lambda_0 is None:
            scales = latent.regularizer_scales()
            self.lambda_0 = {name: (self.regularizer_weight if self.regularizer_weight is not None
                                    else LAMBDA_HEURISTIC * image_loss_value / max(scale, 1e-12))
                             for name, scale in scales.items()}
        if total is None:
            return dict(self.lambda_0)
        k = laplacian_decay_rate(total, self.decay_fraction)
        return {name: laplacian_weight(l0, step, k, self.min_fraction) for name, l0 in self.lambda_0.items()}

    def __call__(self, latent: Latent, batch: Batch, rng: np.random.Generator, step: int,
                 total: int | None) -> Terms:
        """L of ``latent`` on ``batch`` at ``step`` of ``total``; draws the background colours,
        uniform in [0, 1], from ``rng``."""
        background = torch.from_numpy(rng.uniform(0.0, 1.0, size=(self.batch_size, 3)).astype(np.float32)).to(
            batch.target.device)
        image = self.image_loss(latent, batch, background)
        if hasattr(latent, "image_weight"):
            image = image * latent.image_weight(float(image.detach()))
        weights = self.weights(latent, float(image.detach()), step, total)
        terms = latent.regularizers()
        total_loss = image
        for name, term in terms.items():
            total_loss = total_loss + weights[name] * term
        return Terms(total_loss, float(image.detach()), {name: float(t.detach()) for name, t in terms.items()})

    def state_dict(self) -> dict:
        return {"lambda_0": self.lambda_0}

    def load_state_dict(self, state: dict) -> None:
        self.lambda_0 = state["lambda_0"]
