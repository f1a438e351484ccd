"""Tangent-space normal maps held as slopes: ``(x / z, y / z)`` per texel, so that any value is
a valid normal facing outwards and the trained map needs no renormalising projection.

``slopes_to_normal`` (compiled, hand-written backward, run once per optimisation step on the
whole map, because torch's concatenation, norm and division each make a full pass over the map
both ways) has the plain-torch twin ``slopes_to_normal_python``; tests compare values and
gradients.
"""

from __future__ import annotations

import math

import torch
from numba import njit, prange

from ..kernel_cache import CACHE


def normal_to_slopes(normal: torch.Tensor) -> torch.Tensor:
    """``[..., 2]`` slopes (x / z, y / z) of tangent-space normals ``[..., 3]`` (z > 0)."""
    return normal[..., :2] / normal[..., 2:].clamp(min=1e-6)


def slopes_to_normal_python(slopes: torch.Tensor) -> torch.Tensor:
    """``[..., 3]`` unit normals ``n = (x, y, 1) / sqrt(x^2 + y^2 + 1)`` of slopes ``[..., 2]``
    (differentiable): the twin of ``slopes_to_normal``."""
    return torch.nn.functional.normalize(torch.cat([slopes, torch.ones_like(slopes[..., :1])], dim=-1), dim=-1)


def slopes_to_normal(slopes: torch.Tensor) -> torch.Tensor:
    """``[..., 3]`` unit normals ``n = (x, y, 1) / r``, ``r = sqrt(x^2 + y^2 + 1)``, of slopes
    ``[..., 2]``, compiled; the backward is ``g_(x, y) = (g - n (n . g))_(x, y) / r``."""
    return _SlopesToNormal.apply(slopes)


class _SlopesToNormal(torch.autograd.Function):
    @staticmethod
    def forward(ctx, slopes):
        flat = slopes.detach().contiguous().reshape(-1, 2)
        normal = flat.new_empty(flat.shape[0], 3)
        _forward(flat.numpy(), normal.numpy())
        ctx.save_for_backward(normal)
        return normal.reshape(*slopes.shape[:-1], 3)

    @staticmethod
    def backward(ctx, grad):
        (normal,) = ctx.saved_tensors
        out = normal.new_empty(normal.shape[0], 2)
        _backward(normal.numpy(), grad.to(normal.dtype).contiguous().reshape(-1, 3).numpy(), out.numpy())
        return out.reshape(*grad.shape[:-1], 2)


@njit(cache=CACHE, parallel=True)
def _forward(slopes, normal):
    """``normal [N, 3]`` of ``slopes [N, 2]``."""
    for i in prange(slopes.shape[0]):
        x, y = slopes[i, 0], slopes[i, 1]
        inverse = 1.0 / math.sqrt(x * x + y * y + 1.0)
        normal[i, 0] = x * inverse
        normal[i, 1] = y * inverse
        normal[i, 2] = inverse


@njit(cache=CACHE, parallel=True)
def _backward(normal, grad, out):
    """``out [N, 2]``: gradients to the slopes of ``grad [N, 3]`` at ``normal [N, 3]``
    (``1 / r = n_z``)."""
    for i in prange(normal.shape[0]):
        nx, ny, nz = normal[i, 0], normal[i, 1], normal[i, 2]
        along = nx * grad[i, 0] + ny * grad[i, 1] + nz * grad[i, 2]
        out[i, 0] = (grad[i, 0] - nx * along) * nz
        out[i, 1] = (grad[i, 1] - ny * along) * nz
