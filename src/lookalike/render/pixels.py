"""Covered pixels of a ``rast`` image, and scattering per-pixel values back to images (used by
the plain-torch twin :func:`.interpolate.interpolate_python`); a flat pixel index's view, row
and column (the CUDA kernels' thread index)."""

from __future__ import annotations

import torch
from numba import njit

from ..kernel_cache import CACHE


@njit(cache=CACHE, inline="always")
def unravel_pixel(job, height, width):
    """``(b, y, x)``: view, row and column of the flat pixel index ``job`` into ``[B, H, W]``."""
    return job // (height * width), (job // width) % height, job % width


def covered_pixels(rast: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """``(flat_pixel [N] int64, tri_idx [N] int64)``: flat indices into ``[B, H, W]`` of the
    pixels of ``rast [B, H, W, 4]`` that show a triangle, and that triangle's index
    (``rast[..., 3] - 1``)."""
    flat_id = rast[..., 3].detach().reshape(-1)
    flat_pixel = torch.nonzero(flat_id > 0).squeeze(1)
    return flat_pixel, flat_id.index_select(0, flat_pixel).long() - 1


def scatter_to_image(values: torch.Tensor, flat_pixel: torch.Tensor, image_shape: tuple[int, int, int]) -> torch.Tensor:
    """``[B, H, W, C]`` image that is ``values [N, C]`` at ``flat_pixel [N]`` and zero elsewhere
    (differentiable in ``values``)."""
    n_pixels = image_shape[0] * image_shape[1] * image_shape[2]
    out = values.new_zeros(n_pixels, values.shape[1]).index_copy(0, flat_pixel, values)
    return out.reshape(*image_shape, values.shape[1])
