"""Compiled per-pixel loops of interpolate, forward and hand-written backward.

The plain-torch twin is :func:`.interpolate.interpolate_python`; tests compare values and
gradients. The loops run over a list of pixels (flat indices into ``[B, H, W]``) or over every
pixel of the images; both passes are split into ``n_chunks`` contiguous runs of the list in
parallel (``prange``), the backward one with a private attribute-gradient table per run, summed
in run order (deterministic for a given thread count).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..kernel_cache import CACHE


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
    per_view = attr.shape[0] > 1  # else one attribute set shared by every view
    n_channels = attr.shape[2]
    for i in prange(out.shape[0]):
        p = _pixel(pixels, every, i)
        t = int(rast[p, 3]) - 1
        if t < 0:
            out[i, :] = 0.0
            out_da[i, :] = 0.0
            continue
        ab = p // pixels_per_view if per_view else 0
        u, v = rast[p, 0], rast[p, 1]
        i0, i1, i2 = tri[t, 0], tri[t, 1], tri[t, 2]
        for ch in range(n_channels):
            a2 = attr[ab, i2, ch]
            out[i, ch] = a2 + u * (attr[ab, i0, ch] - a2) + v * (attr[ab, i1, ch] - a2)
        for k in range(diff.shape[0]):
            ch = diff[k]
            a2 = attr[ab, i2, ch]
            da_du = attr[ab, i0, ch] - a2
            da_dv = attr[ab, i1, ch] - a2
            out_da[i, 2 * k] = da_du * rast_db[p, 0] + da_dv * rast_db[p, 2]
            out_da[i, 2 * k + 1] = da_du * rast_db[p, 1] + da_dv * rast_db[p, 3]


@njit(cache=CACHE)
def _backward_run(attr, tri, rast, rast_db, diff, pixels, every, pixels_per_view, grad_out, grad_da, target,
                  grad_rast, grad_db, start, end):
    """:func:`interpolate_backward` for list entries ``start .. end-1``, attribute gradients
    into ``target [Ba, V, C]``."""
    per_view = attr.shape[0] > 1
    n_channels = attr.shape[2]
    write_db = grad_db.shape[0] > 0
    for i in range(start, end):
        p = _pixel(pixels, every, i)
        t = int(rast[p, 3]) - 1
        if t < 0:
            continue
        ab = p // pixels_per_view if per_view else 0
        u, v = rast[p, 0], rast[p, 1]
        i0, i1, i2 = tri[t, 0], tri[t, 1], tri[t, 2]
        g_u = 0.0
        g_v = 0.0
        for ch in range(n_channels):
            g = grad_out[i, ch]
            a2 = attr[ab, i2, ch]
            g_u += g * (attr[ab, i0, ch] - a2)
            g_v += g * (attr[ab, i1, ch] - a2)
            target[ab, i0, ch] += g * u
            target[ab, i1, ch] += g * v
            target[ab, i2, ch] += g * (1.0 - u - v)
        grad_rast[p, 0] += g_u
        grad_rast[p, 1] += g_v
        for k in range(diff.shape[0]):
            ch = diff[k]
            gx, gy = grad_da[i, 2 * k], grad_da[i, 2 * k + 1]
            a2 = attr[ab, i2, ch]
            da_du = attr[ab, i0, ch] - a2
            da_dv = attr[ab, i1, ch] - a2
            if write_db:
                grad_db[p, 0] += gx * da_du
                grad_db[p, 1] += gy * da_du
                grad_db[p, 2] += gx * da_dv
                grad_db[p, 3] += gy * da_dv
            g0 = gx * rast_db[p, 0] + gy * rast_db[p, 1]
            g1 = gx * rast_db[p, 2] + gy * rast_db[p, 3]
            target[ab, i0, ch] += g0
            target[ab, i1, ch] += g1
            target[ab, i2, ch] -= g0 + g1


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
        start, end = chunk * n // n_chunks, (chunk + 1) * n // n_chunks
        if chunk == 0:
            _backward_run(attr, tri, rast, rast_db, diff, pixels, every, pixels_per_view, grad_out, grad_da, grad_attr,
                          grad_rast, grad_db, start, end)
        else:
            _backward_run(attr, tri, rast, rast_db, diff, pixels, every, pixels_per_view, grad_out, grad_da,
                          private[chunk - 1], grad_rast, grad_db, start, end)
    for vertex in prange(grad_attr.shape[1]):
        for k in range(n_chunks - 1):
            for b in range(grad_attr.shape[0]):
                for ch in range(grad_attr.shape[2]):
                    grad_attr[b, vertex, ch] += private[k, b, vertex, ch]
