"""Compiled per-pixel loops of interpolate, forward and hand-written backward.

The plain-torch twin is :func:`.interpolate.interpolate_python`; tests compare values and
gradients. The loops run over a list of pixels (flat indices into ``[B, H, W]``) or over every
pixel of the images; both passes are split into ``n_chunks`` contiguous runs of the list in
parallel (``prange``), the backward one with a private attribute-gradient table per run, summed
in run order (deterministic for a given thread count). Each list entry is a body
(``interpolate_entry``, ``interpolate_backward_entry``) that the CUDA forms
(:mod:`.interpolate_cuda`) run too, one thread per entry.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..kernel_cache import CACHE
from ..kernel_scatter import scatter_add


@njit(cache=CACHE, inline="always")
def _pixel(pixels, every, i):
    """Flat pixel index of list entry ``i`` (``i`` itself when the list is every pixel)."""
    return np.int64(i) if every else pixels[i]


@njit(cache=CACHE, parallel=True)
def interpolate_forward(attr, tri, rast, rast_db, diff, pixels, every, pixels_per_view, out, out_da):
    """Fill ``out [N, C]`` with ``u a_0 + v a_1 + (1-u-v) a_2`` and ``out_da [N, 2D]`` with
    ``(dA/dX, dA/dY)`` of channels ``diff [D]``: ``dA/dX = (a_0-a_2) du/dX + (a_1-a_2) dv/dX``,
    at the pixels ``pixels [N]`` (flat indices into ``[B, H, W]``; every pixel, ``N = B H W``,
    when ``every``). ``attr [Ba, V, C]`` (``Ba`` is 1 or B), ``tri [T, 3]`` int64, ``rast``,
    ``rast_db [B H W, 4]`` (``rast_db`` unused when ``D = 0``); pixels showing no triangle get 0."""
    for i in prange(out.shape[0]):
        interpolate_entry(attr, tri, rast, rast_db, diff, pixels, every, pixels_per_view, out, out_da, i)


@njit(cache=CACHE, inline="always")
def interpolate_entry(attr, tri, rast, rast_db, diff, pixels, every, pixels_per_view, out, out_da, i):
    """List entry ``i`` of :func:`interpolate_forward` (both its CPU and its CUDA form): rows
    ``i`` of ``out`` and ``out_da``."""
    p = _pixel(pixels, every, i)
    t = int(rast[p, 3]) - 1
    if t < 0:
        for ch in range(out.shape[1]):
            out[i, ch] = 0.0
        for ch in range(out_da.shape[1]):
            out_da[i, ch] = 0.0
        return
    ab = p // pixels_per_view if attr.shape[0] > 1 else 0  # else one attribute set shared by every view
    u, v = rast[p, 0], rast[p, 1]
    i0, i1, i2 = tri[t, 0], tri[t, 1], tri[t, 2]
    for ch in range(attr.shape[2]):
        a2 = attr[ab, i2, ch]
        out[i, ch] = a2 + u * (attr[ab, i0, ch] - a2) + v * (attr[ab, i1, ch] - a2)
    for k in range(diff.shape[0]):
        ch = diff[k]
        a2 = attr[ab, i2, ch]
        da_du = attr[ab, i0, ch] - a2
        da_dv = attr[ab, i1, ch] - a2
        out_da[i, 2 * k] = da_du * rast_db[p, 0] + da_dv * rast_db[p, 2]
        out_da[i, 2 * k + 1] = da_du * rast_db[p, 1] + da_dv * rast_db[p, 3]


@njit(cache=CACHE, inline="always")
def interpolate_backward_entry(attr, tri, rast, rast_db, diff, pixels, every, pixels_per_view, grad_out, grad_da,
                               grad_attr, grad_rast, grad_db, i):
    """List entry ``i`` of :func:`interpolate_backward` (both its CPU and its CUDA form): its
    attribute gradients added into ``grad_attr`` (``scatter_add``), its pixel's rows of
    ``grad_rast`` and ``grad_db`` (a listed pixel's own) added to."""
    p = _pixel(pixels, every, i)
    t = int(rast[p, 3]) - 1
    if t < 0:
        return
    ab = p // pixels_per_view if attr.shape[0] > 1 else 0
    u, v = rast[p, 0], rast[p, 1]
    i0, i1, i2 = tri[t, 0], tri[t, 1], tri[t, 2]
    g_u = 0.0
    g_v = 0.0
    for ch in range(attr.shape[2]):
        g = grad_out[i, ch]
        a2 = attr[ab, i2, ch]
        g_u += g * (attr[ab, i0, ch] - a2)
        g_v += g * (attr[ab, i1, ch] - a2)
        scatter_add(grad_attr, (ab, i0, ch), g * u)
        scatter_add(grad_attr, (ab, i1, ch), g * v)
        scatter_add(grad_attr, (ab, i2, ch), g * (1.0 - u - v))
    grad_rast[p, 0] += g_u
    grad_rast[p, 1] += g_v
    for k in range(diff.shape[0]):
        ch = diff[k]
        gx, gy = grad_da[i, 2 * k], grad_da[i, 2 * k + 1]
        a2 = attr[ab, i2, ch]
        da_du = attr[ab, i0, ch] - a2
        da_dv = attr[ab, i1, ch] - a2
        if grad_db.shape[0] > 0:
            grad_db[p, 0] += gx * da_du
            grad_db[p, 1] += gy * da_du
            grad_db[p, 2] += gx * da_dv
            grad_db[p, 3] += gy * da_dv
        g0 = gx * rast_db[p, 0] + gy * rast_db[p, 1]
        g1 = gx * rast_db[p, 2] + gy * rast_db[p, 3]
        scatter_add(grad_attr, (ab, i0, ch), g0)
        scatter_add(grad_attr, (ab, i1, ch), g1)
        scatter_add(grad_attr, (ab, i2, ch), -(g0 + g1))


@njit(cache=CACHE, parallel=True)
def interpolate_backward(attr, tri, rast, rast_db, diff, pixels, every, pixels_per_view, grad_out, grad_da,
                         grad_attr, grad_rast, grad_db, n_chunks):
    """Gradients of :func:`interpolate_forward` for ``grad_out [N, C]`` and ``grad_da [N, 2D]``:
    accumulate into ``grad_attr [Ba, V, C]``, ``grad_rast [B H W, 4]`` (channels 0, 1) and,
    when it has rows, ``grad_db [B H W, 4]`` (all zeroed; the listed pixels are distinct). Each
    of ``n_chunks`` runs of the list adds its attribute gradients into a private table, the
    first into ``grad_attr``; the tables are summed at the end."""
    n = grad_out.shape[0]
    private = np.zeros((n_chunks - 1, grad_attr.shape[0], grad_attr.shape[1], grad_attr.shape[2]), grad_attr.dtype)
    for chunk in prange(n_chunks):
        target = grad_attr if chunk == 0 else private[chunk - 1]
        for i in range(chunk * n // n_chunks, (chunk + 1) * n // n_chunks):
            interpolate_backward_entry(attr, tri, rast, rast_db, diff, pixels, every, pixels_per_view, grad_out,
                                       grad_da, target, grad_rast, grad_db, i)
    for vertex in prange(grad_attr.shape[1]):
        for k in range(n_chunks - 1):
            for b in range(grad_attr.shape[0]):
                for ch in range(grad_attr.shape[2]):
                    grad_attr[b, vertex, ch] += private[k, b, vertex, ch]
