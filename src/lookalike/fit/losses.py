"""Image losses (paper Sec. 6.3). The Laplacian regulariser is ``lookalike.asset.laplacian``.

Every image loss takes two ``[B, H, W, C]`` float tensors of linear radiance (same shape;
``pred`` is the latent model's render, ``target`` the reference's) and returns a scalar: the
mean over all elements of a per-element error.
"""

from __future__ import annotations

from collections.abc import Callable

import torch

from ..colour import tonemap

SMAPE_EPS = 1e-2
RELATIVE_L2_EPS = 1e-2


def l1_tonemapped(pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """mean |tonemap(pred) - tonemap(target)| (the paper's default)."""
    return (tonemap(pred) - tonemap(target)).abs().mean()


def l2(pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """mean (pred - target)^2 on linear values."""
    return ((pred - target) ** 2).mean()


def l2_tonemapped(pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """mean (tonemap(pred) - tonemap(target))^2 (the paper's loss for aggregate geometry, Sec. 5.4)."""
    return ((tonemap(pred) - tonemap(target)) ** 2).mean()


def smape(pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Symmetric mean absolute percentage error: mean |pred - target| / (|pred| + |target| + eps),
    eps = 1e-2."""
    return ((pred - target).abs() / (pred.abs() + target.abs() + SMAPE_EPS)).mean()


def relative_l2(pred: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """Relative L2 (as in HDR denoising): mean (pred - target)^2 / (sg(pred)^2 + eps), eps = 1e-2,
    where sg stops the gradient."""
    return ((pred - target) ** 2 / (pred.detach() ** 2 + RELATIVE_L2_EPS)).mean()


IMAGE_LOSSES: dict[str, Callable[[torch.Tensor, torch.Tensor], torch.Tensor]] = {
    "l1-tonemapped": l1_tonemapped,
    "l2-tonemapped": l2_tonemapped,
    "l2": l2,
    "smape": smape,
    "relative-l2": relative_l2,
}


def image_loss(name: str) -> Callable[[torch.Tensor, torch.Tensor], torch.Tensor]:
    """The loss function registered under ``name`` (a key of ``IMAGE_LOSSES``)."""
    return IMAGE_LOSSES[name]


def composite(rgba: torch.Tensor, background: torch.Tensor) -> torch.Tensor:
    """``rgba`` ``[B, H, W, 4]`` (colour already weighted by coverage, as the renderer
    antialiases it against an empty background) over ``background`` ``[B, 3]``:
    rgb + (1 - alpha) * background, ``[B, H, W, 3]``. Comparing composites over the same
    background penalises both colour and coverage (silhouette, alpha) differences."""
    return rgba[..., :3] + (1 - rgba[..., 3:4]) * background[:, None, None, :]
