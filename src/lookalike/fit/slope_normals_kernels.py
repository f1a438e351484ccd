"""Compiled slope normals (:func:`.slope_normals.slopes_to_normal`), forward and hand-written
backward: ``n = (x, y, 1) / r``, ``r = sqrt(x^2 + y^2 + 1)``, and ``g_(x, y) = (g - n (n . g))_(x,
y) / r``, one pass over the texels each way. Their per-texel bodies are also the CUDA forms'
(:mod:`.slope_normals_cuda`), one thread per texel. The plain-torch twin is
:func:`.slope_normals.slopes_to_normal_python`.
"""

from __future__ import annotations

import math

from numba import njit, prange

from ..kernel_cache import CACHE


@njit(cache=CACHE, parallel=True)
def slopes_to_normal(slopes, normal):
    """``normal [N, 3]`` of ``slopes [N, 2]``."""
    for i in prange(slopes.shape[0]):
        slope_normal(slopes, normal, i)


@njit(cache=CACHE, inline="always")
def slope_normal(slopes, normal, i):
    """Row ``i`` of :func:`slopes_to_normal` (both its CPU and its CUDA form)."""
    x, y = slopes[i, 0], slopes[i, 1]
    inverse = 1.0 / math.sqrt(x * x + y * y + 1.0)
    normal[i, 0] = x * inverse
    normal[i, 1] = y * inverse
    normal[i, 2] = inverse


@njit(cache=CACHE, parallel=True)
def slopes_to_normal_backward(normal, grad, out):
    """``out [N, 2]``: gradients to the slopes of ``grad [N, 3]`` at ``normal [N, 3]``
    (``1 / r = n_z``)."""
    for i in prange(normal.shape[0]):
        slope_normal_backward(normal, grad, out, i)


@njit(cache=CACHE, inline="always")
def slope_normal_backward(normal, grad, out, i):
    """Row ``i`` of :func:`slopes_to_normal_backward` (both its CPU and its CUDA form)."""
    nx, ny, nz = normal[i, 0], normal[i, 1], normal[i, 2]
    along = nx * grad[i, 0] + ny * grad[i, 1] + nz * grad[i, 2]
    out[i, 0] = (grad[i, 0] - nx * along) * nz
    out[i, 1] = (grad[i, 1] - ny * along) * nz
