"""How a model whose alpha was trained is written (``latent.alpha_mode``).

- Training: ``"auto"`` trains the start's own mode (the input's: ``MASK`` with a
  straight-through gradient, ``lookalike.shading.surface``); ``"mask"`` and ``"blend"`` train
  blended, soft alpha. A straight-through mask learns little from a billboard cloud's
  projected alpha (on a test clump the held-out score did not move in 150 steps, while the
  same run blended gained 0.6-1.2 dB): coverage that the cards must move lives in partial alpha.
- The cutoff of a ``MASK`` model: the one of ``CUTOFFS`` (and the model's own) whose model
  scores the best PSNR on the run's validation views; ``"mask"`` turns the soft model into an
  alpha-tested one that way.
- Colour under texels no sample can see: each RGB texel whose 3 x 3 neighbourhood is all
  invisible (alpha below the cutoff, or zero when blending) takes the colour of the nearest
  visible texel, so that the mip levels engines build from the texture do not bleed the dark
  fringes of unseen texels into the leaves' edges. Texels next to a visible one keep their
  trained colour: bilinear lookups at full resolution render as they did in the fit.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np
import torch
from scipy.ndimage import binary_dilation, distance_transform_edt

from ..asset import Asset

CUTOFFS = (0.3, 0.4, 0.5, 0.6, 0.7)
"""The alpha cutoffs tried on the validation views."""


def training_start(asset: Asset, mode: str) -> Asset:
    """``asset`` as the fit trains it for ``latent.alpha_mode`` ``mode``: its alpha-using
    materials blended for ``"mask"`` and ``"blend"``, as it is for ``"auto"``. Opaque
    materials stay opaque."""
    return asset if mode == "auto" else with_alpha_mode(asset, "BLEND")


def with_alpha_mode(asset: Asset, mode: str) -> Asset:
    """``asset`` with its alpha-using materials set to glTF alpha mode ``mode`` (``"MASK"``,
    ``"BLEND"``); opaque materials stay opaque."""
    if not any(m.uses_alpha for m in asset.materials):
        return asset
    materials = [dataclasses.replace(m, alpha_mode=mode) if m.uses_alpha else m for m in asset.materials]
    return dataclasses.replace(asset, materials=materials)


def finished_alpha(model: Asset, mode: str, score: Callable[[Asset], float] | None) -> Asset:
    """``model`` as written for ``latent.alpha_mode`` ``mode``: alpha-tested for ``"mask"``;
    a ``MASK`` model at the cutoff of ``CUTOFFS`` that ``score`` (e.g. validation PSNR; higher
    is better) rates best, ties to the model's own (kept where ``score`` is ``None``); every
    alpha-using material's colour filled under unseen texels (``filled_colour``). Opaque models
    are returned as they are."""
    if not any(m.uses_alpha for m in model.materials):
        return model
    if mode == "mask":
        model = with_alpha_mode(model, "MASK")
    if score is not None and any(m.alpha_mode == "MASK" for m in model.materials):
        own = model.materials[0].alpha_cutoff
        candidates = sorted({own, *CUTOFFS}, key=lambda c: (c != own, c))
        scored = [(score(_at_cutoff(model, c)), -i, c) for i, c in enumerate(candidates)]
        model = _at_cutoff(model, max(scored)[2])
    materials = [dataclasses.replace(m, kd=dataclasses.replace(m.kd, data=filled_colour(m.kd.data, _seen_from(m))))
                 if m.uses_alpha else m for m in model.materials]
    return dataclasses.replace(model, materials=materials)


def _at_cutoff(model: Asset, cutoff: float) -> Asset:
    materials = [dataclasses.replace(m, alpha_cutoff=float(cutoff)) if m.alpha_mode == "MASK" else m
                 for m in model.materials]
    return dataclasses.replace(model, materials=materials)


def _seen_from(material) -> float:
    """The alpha from which a texel of ``material`` shows: its cutoff when masked, else just
    above zero."""
    return material.alpha_cutoff if material.alpha_mode == "MASK" else 1.0 / 255.0


def filled_colour(kd: torch.Tensor, visible_from: float) -> torch.Tensor:
    """``kd [H, W, 4]`` (RGB + alpha) with the RGB of every texel whose 3 x 3 neighbourhood has
    no texel of alpha >= ``visible_from`` replaced by that of the nearest such texel (Euclidean
    distance in texels); alpha unchanged. Returned as is where no texel is visible."""
    texels = kd.detach().numpy()
    visible = texels[..., 3] >= visible_from
    if not visible.any() or visible.all():
        return kd
    unseen = ~binary_dilation(visible, structure=np.ones((3, 3), bool))
    rows, cols = distance_transform_edt(~visible, return_distances=False, return_indices=True)
    filled = texels.copy()
    filled[unseen, :3] = texels[rows[unseen], cols[unseen], :3]
    return torch.from_numpy(filled)
