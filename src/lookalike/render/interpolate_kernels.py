"""Compiled per-pixel loops of interpolate, forward and hand-written backward.

The plain-torch twin is :func:`.interpolate.interpolate_python`; tests compare values and
gradients.  Pixels are walked row by row in parallel (``prange``) in the forward pass; the
backward pass accumulates into per-view gradient buffers, so it runs in parallel over views.
"""

from __future__ import annotations

from numba import njit, prange


@njit(cache=True, parallel=True)
def interpolate_forward(attr, tri, rast, rast_db, diff, out, out_da):
    """Fill ``out [B,H,W,C]`` with ``u a_0 + v a_1 + (1-u-v) a_2`` and ``out_da [B,H,W,2D]``
    with ``(dA/dX, dA/dY)`` of channels ``diff [D]``: ``dA/dX = (a_0-a_2) du/dX + (a_1-a_2)
    dv/dX``.  ``attr [Ba, V, C]`` (``Ba`` is 1 or B), ``tri [T, 3]`` int64, ``rast``,
    ``rast_db [B,H,W,4]`` (``rast_db`` unused when ``D = 0``); background pixels get 0."""
    n_views, height, width = rast.shape[0], rast.shape[1], rast.shape[2]
    attr_stride = 0 if attr.shape[0] == 1 else 1  # attr view of view b is b * attr_stride
    n_channels = attr.shape[2]
    for row in prange(n_views * height):
        b, iy = row // height, row % height
        ab = b * attr_stride
        for ix in range(width):
            t = int(rast[b, iy, ix, 3]) - 1
            if t < 0:
                out[b, iy, ix, :] = 0.0
                out_da[b, iy, ix, :] = 0.0
                continue
            u, v = rast[b, iy, ix, 0], rast[b, iy, ix, 1]
            i0, i1, i2 = tri[t, 0], tri[t, 1], tri[t, 2]
            for ch in range(n_channels):
                a2 = attr[ab, i2, ch]
                out[b, iy, ix, ch] = a2 + u * (attr[ab, i0, ch] - a2) + v * (attr[ab, i1, ch] - a2)
            for k in range(diff.shape[0]):
                ch = diff[k]
                a2 = attr[ab, i2, ch]
                da_du = attr[ab, i0, ch] - a2
                da_dv = attr[ab, i1, ch] - a2
                out_da[b, iy, ix, 2 * k] = da_du * rast_db[b, iy, ix, 0] + da_dv * rast_db[b, iy, ix, 2]
                out_da[b, iy, ix, 2 * k + 1] = da_du * rast_db[b, iy, ix, 1] + da_dv * rast_db[b, iy, ix, 3]


@njit(cache=True, parallel=True)
def interpolate_backward(attr, tri, rast, rast_db, diff, grad_out, grad_da, grad_attr, grad_rast, grad_db):
    """Gradients of :func:`interpolate_forward`: accumulate into ``grad_attr [B, V, C]``
    (zeroed; one slice per view, summed by the caller for a shared ``attr``) and overwrite
    every element of ``grad_rast [B,H,W,4]`` (channels 2, 3 get 0) and, when it has pixels,
    of ``grad_db [B,H,W,4]`` (a 0-size array skips it)."""
    n_views, height, width = rast.shape[0], rast.shape[1], rast.shape[2]
    attr_stride = 0 if attr.shape[0] == 1 else 1  # attr view of view b is b * attr_stride
    n_channels = attr.shape[2]
    write_db = grad_db.size > 0
    for b in prange(n_views):
        ab = b * attr_stride
        for iy in range(height):
            for ix in range(width):
                for k in range(4):
                    grad_rast[b, iy, ix, k] = 0.0
                    if write_db:
                        grad_db[b, iy, ix, k] = 0.0
                t = int(rast[b, iy, ix, 3]) - 1
                if t < 0:
                    continue
                u, v = rast[b, iy, ix, 0], rast[b, iy, ix, 1]
                i0, i1, i2 = tri[t, 0], tri[t, 1], tri[t, 2]
                g_u = 0.0
                g_v = 0.0
                for ch in range(n_channels):
                    g = grad_out[b, iy, ix, ch]
                    a2 = attr[ab, i2, ch]
                    g_u += g * (attr[ab, i0, ch] - a2)
                    g_v += g * (attr[ab, i1, ch] - a2)
                    grad_attr[b, i0, ch] += g * u
                    grad_attr[b, i1, ch] += g * v
                    grad_attr[b, i2, ch] += g * (1.0 - u - v)
                grad_rast[b, iy, ix, 0] = g_u
                grad_rast[b, iy, ix, 1] = g_v
                for k in range(diff.shape[0]):
                    ch = diff[k]
                    gx, gy = grad_da[b, iy, ix, 2 * k], grad_da[b, iy, ix, 2 * k + 1]
                    a2 = attr[ab, i2, ch]
                    da_du = attr[ab, i0, ch] - a2
                    da_dv = attr[ab, i1, ch] - a2
                    dudx, dudy = rast_db[b, iy, ix, 0], rast_db[b, iy, ix, 1]
                    dvdx, dvdy = rast_db[b, iy, ix, 2], rast_db[b, iy, ix, 3]
                    grad_db[b, iy, ix, 0] += gx * da_du
                    grad_db[b, iy, ix, 1] += gy * da_du
                    grad_db[b, iy, ix, 2] += gx * da_dv
                    grad_db[b, iy, ix, 3] += gy * da_dv
                    g0 = gx * dudx + gy * dudy
                    g1 = gx * dvdx + gy * dvdy
                    grad_attr[b, i0, ch] += g0
                    grad_attr[b, i1, ch] += g1
                    grad_attr[b, i2, ch] -= g0 + g1
