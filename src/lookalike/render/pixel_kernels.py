"""Compiled per-pixel loops of rasterize (barycentrics) and interpolate, forward and
hand-written backward.  Their plain-torch twins are :func:`.barycentrics.barycentrics` and
:func:`.interpolate.interpolate_reference`; tests compare values and gradients.

Pixels are walked row by row in parallel (``prange``) in the forward passes.  Backward
passes accumulate into per-view gradient buffers, so they run in parallel over views.
Pixel ``(ix, iy)`` has its centre at NDC ``((2 ix + 1)/W - 1, (2 iy + 1)/H - 1)``.
"""

from __future__ import annotations

from numba import njit, prange


@njit(cache=True, parallel=True)
def barycentrics_forward(coef, tri_id, depth, rast, rast_db):
    """Fill ``rast [B,H,W,4] = (u, v, z/w, id)`` and ``rast_db [B,H,W,4]``.

    ``coef [B, T, 9]`` holds per triangle ``(c_0, c_1, s)`` with ``c_i = v_j x v_k`` and
    ``s = c_0 + c_1 + c_2`` (``v = (x, y, w)``); at ``p = (px, py, 1)``: ``u = c_0.p / s.p``,
    ``v = c_1.p / s.p``, ``du/dX = (2/W)(c_0x - u s_x) / s.p`` and likewise for the others.
    ``tri_id [B,H,W]`` int32 (triangle + 1, 0 = none), ``depth [B,H,W]`` float32.
    """
    n_views, height, width = tri_id.shape
    kx, ky = 2.0 / width, 2.0 / height
    for row in prange(n_views * height):
        b, iy = row // height, row % height
        py = (2 * iy + 1) / height - 1.0
        for ix in range(width):
            t = tri_id[b, iy, ix] - 1
            if t < 0:
                for k in range(4):
                    rast[b, iy, ix, k] = 0.0
                    rast_db[b, iy, ix, k] = 0.0
                continue
            px = (2 * ix + 1) / width - 1.0
            s = coef[b, t, 6] * px + coef[b, t, 7] * py + coef[b, t, 8]
            u = (coef[b, t, 0] * px + coef[b, t, 1] * py + coef[b, t, 2]) / s
            v = (coef[b, t, 3] * px + coef[b, t, 4] * py + coef[b, t, 5]) / s
            rast[b, iy, ix, 0] = u
            rast[b, iy, ix, 1] = v
            rast[b, iy, ix, 2] = depth[b, iy, ix]
            rast[b, iy, ix, 3] = t + 1
            rast_db[b, iy, ix, 0] = (coef[b, t, 0] - u * coef[b, t, 6]) / s * kx
            rast_db[b, iy, ix, 1] = (coef[b, t, 1] - u * coef[b, t, 7]) / s * ky
            rast_db[b, iy, ix, 2] = (coef[b, t, 3] - v * coef[b, t, 6]) / s * kx
            rast_db[b, iy, ix, 3] = (coef[b, t, 4] - v * coef[b, t, 7]) / s * ky


@njit(cache=True, parallel=True)
def barycentrics_backward(coef, tri_id, grad_rast, grad_db, use_db, grad_coef):
    """Accumulate into ``grad_coef [B, T, 9]`` (zeroed) the gradient of
    :func:`barycentrics_forward` given ``grad_rast [B,H,W,4]`` (channels 0, 1 used) and
    ``grad_db [B,H,W,4]`` (used when ``use_db``).

    Per pixel, with ``S = s.p``: the db terms give direct gradients to ``c_0x, c_0y, c_1x,
    c_1y`` (``k/S``), to ``s_x, s_y`` (``-k u/S``, ``-k v/S``) and to ``S`` and ``u, v``;
    then ``u = c_0.p / S`` sends ``g_u p / S`` to ``c_0`` and ``-g_u u / S`` to ``S``, and
    ``S = s.p`` sends ``g_S p`` to ``s``.
    """
    n_views, height, width = tri_id.shape
    kx, ky = 2.0 / width, 2.0 / height
    for b in prange(n_views):
        for iy in range(height):
            py = (2 * iy + 1) / height - 1.0
            for ix in range(width):
                t = tri_id[b, iy, ix] - 1
                if t < 0:
                    continue
                px = (2 * ix + 1) / width - 1.0
                s = coef[b, t, 6] * px + coef[b, t, 7] * py + coef[b, t, 8]
                u = (coef[b, t, 0] * px + coef[b, t, 1] * py + coef[b, t, 2]) / s
                v = (coef[b, t, 3] * px + coef[b, t, 4] * py + coef[b, t, 5]) / s
                g_u = grad_rast[b, iy, ix, 0]
                g_v = grad_rast[b, iy, ix, 1]
                g_s = 0.0
                if use_db:
                    gux, guy = grad_db[b, iy, ix, 0] * kx, grad_db[b, iy, ix, 1] * ky
                    gvx, gvy = grad_db[b, iy, ix, 2] * kx, grad_db[b, iy, ix, 3] * ky
                    sx, sy = coef[b, t, 6], coef[b, t, 7]
                    dudx_s = coef[b, t, 0] - u * sx  # S * du/dX / kx, etc.
                    dudy_s = coef[b, t, 1] - u * sy
                    dvdx_s = coef[b, t, 3] - v * sx
                    dvdy_s = coef[b, t, 4] - v * sy
                    grad_coef[b, t, 0] += gux / s
                    grad_coef[b, t, 1] += guy / s
                    grad_coef[b, t, 3] += gvx / s
                    grad_coef[b, t, 4] += gvy / s
                    grad_coef[b, t, 6] -= (gux * u + gvx * v) / s
                    grad_coef[b, t, 7] -= (guy * u + gvy * v) / s
                    g_u -= (gux * sx + guy * sy) / s
                    g_v -= (gvx * sx + gvy * sy) / s
                    g_s -= (gux * dudx_s + guy * dudy_s + gvx * dvdx_s + gvy * dvdy_s) / (s * s)
                g_s -= (g_u * u + g_v * v) / s
                g_e0 = g_u / s
                g_e1 = g_v / s
                grad_coef[b, t, 0] += g_e0 * px
                grad_coef[b, t, 1] += g_e0 * py
                grad_coef[b, t, 2] += g_e0
                grad_coef[b, t, 3] += g_e1 * px
                grad_coef[b, t, 4] += g_e1 * py
                grad_coef[b, t, 5] += g_e1
                grad_coef[b, t, 6] += g_s * px
                grad_coef[b, t, 7] += g_s * py
                grad_coef[b, t, 8] += g_s


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
