"""Compiled texture filtering, forward and hand-written backward.

The plain-torch twin is :func:`.texture.texture_python` (built on :mod:`.sampling`);
tests compare values and gradients.  Each pass is a loop over pixels around a per-pixel body
(``texture_forward_pixel``, ``texture_backward_pixel``) that the CUDA forms
(:mod:`.texture_cuda`) run too, one thread per pixel, so the two forms cannot drift apart.
The mip pyramid is one flat ``table [N, C]`` (see :class:`.sampling.Pyramid`): level ``l`` of
view ``k`` starts at row ``offsets[l] + k heights[l] widths[l]``.

Filter modes: ``NEAREST``, ``LINEAR`` (level 0), ``MIP_NEAREST`` (bilinear in level
``floor(L + 1/2)``), ``MIP_LINEAR`` (bilinear in ``l0 = min(floor(L), top - 1)`` and
``l0 + 1`` blended by ``L - l0``), with ``L = clamp(0.5 log2(lambda_max) + bias, 0, top)``
and ``lambda_max`` the largest eigenvalue of ``J J^T`` for the footprint Jacobian in level-0
texels ``J = [[W du/dX, W du/dY], [H dv/dX, H dv/dY]]``.  Boundary modes: ``WRAP``,
``CLAMP``, ``ZERO`` (texels outside read as 0).  Bilinear: ``x = u w - 1/2``, ``x0 =
floor(x)``, ``fx = x - x0`` (same for ``y`` with ``v``, ``h``), value
``sum (1-fx|fx)(1-fy|fy) T[y0|y0+1, x0|x0+1]``; nearest: ``T[floor(v h), floor(u w)]``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..kernel_cache import CACHE
from ..kernel_scatter import scatter_add

NEAREST, LINEAR, MIP_NEAREST, MIP_LINEAR = 0, 1, 2, 3
WRAP, CLAMP, ZERO = 0, 1, 2
_TINY = 1e-30  # footprints below this give level -inf (clamped to 0), with zero gradient


@njit(cache=CACHE, inline="always")
def _resolve(i, n, boundary):
    """``(index, inside)`` along one axis after the boundary rule; in ``ZERO`` mode an
    outside texel gets index 0 and ``inside = 0.0`` (it reads as 0)."""
    if 0 <= i < n:
        return i, 1.0
    if boundary == WRAP:
        return i % n, 1.0
    if boundary == CLAMP:
        return min(max(i, 0), n - 1), 1.0
    return 0, 0.0


@njit(cache=CACHE, inline="always")
def _bilinear_taps(table_base, u, v, h, w, boundary):
    """Table rows of the four bilinear taps ``(i00, i01, i10, i11)`` (row, column offsets
    ``(0,0), (0,1), (1,0), (1,1)``), their inside masks ``(m00, m01, m10, m11)`` and the
    fractions ``(fx, fy)``."""
    x = u * w - 0.5
    y = v * h - 0.5
    x0 = math.floor(x)
    y0 = math.floor(y)
    c0, mc0 = _resolve(int(x0), w, boundary)
    c1, mc1 = _resolve(int(x0) + 1, w, boundary)
    r0, mr0 = _resolve(int(y0), h, boundary)
    r1, mr1 = _resolve(int(y0) + 1, h, boundary)
    row0 = table_base + r0 * w
    row1 = table_base + r1 * w
    return (
        row0 + c0, row0 + c1, row1 + c0, row1 + c1,
        mr0 * mc0, mr0 * mc1, mr1 * mc0, mr1 * mc1,
        x - x0, y - y0,
    )


@njit(cache=CACHE, inline="always")
def _level(uv_da, bias, p, has_da, has_bias, h0, w0, top):
    """``(L, raw, lam)`` of pixel ``p`` (``footprint_level`` of its row of ``uv_da`` and ``bias``,
    each read where present)."""
    du_dx, du_dy, dv_dx, dv_dy = 0.0, 0.0, 0.0, 0.0
    if has_da:
        du_dx, du_dy, dv_dx, dv_dy = uv_da[p, 0], uv_da[p, 1], uv_da[p, 2], uv_da[p, 3]
    return footprint_level(du_dx, du_dy, dv_dx, dv_dy, bias[p] if has_bias else 0.0, has_da, has_bias, h0, w0, top)


@njit(cache=CACHE, inline="always")
def footprint_level(du_dx, du_dy, dv_dx, dv_dy, bias, has_da, has_bias, h0, w0, top):
    """``(L, raw, lam)``: the clamped level, the unclamped one and ``lambda_max`` of a footprint
    ``(du/dX, du/dY, dv/dX, dv/dY)`` (used where ``has_da``) plus ``bias`` (where ``has_bias``)."""
    raw = 0.0
    lam = 0.0
    if has_da:
        dsx, dsy = du_dx * w0, du_dy * w0
        dtx, dty = dv_dx * h0, dv_dy * h0
        a = dsx * dsx + dsy * dsy
        c = dtx * dtx + dty * dty
        b = dsx * dtx + dsy * dty
        lam = 0.5 * (a + c) + math.sqrt(max(0.25 * (a - c) * (a - c) + b * b, _TINY))
        raw = 0.5 * math.log2(max(lam, _TINY))
    if has_bias:
        raw += bias
    level = raw if raw > 0.0 else 0.0  # also maps NaN to 0
    return level if level < top else float(top), raw, lam


@njit(cache=CACHE, inline="always")
def _bilinear_add(table, base, h, w, u, v, boundary, weight, out, p):
    """``out[p] += weight * bilinear(level starting at table row base)``."""
    i00, i01, i10, i11, m00, m01, m10, m11, fx, fy = _bilinear_taps(base, u, v, h, w, boundary)
    w00 = weight * m00 * (1 - fx) * (1 - fy)
    w01 = weight * m01 * fx * (1 - fy)
    w10 = weight * m10 * (1 - fx) * fy
    w11 = weight * m11 * fx * fy
    for ch in range(table.shape[1]):
        out[p, ch] += w00 * table[i00, ch] + w01 * table[i01, ch] + w10 * table[i10, ch] + w11 * table[i11, ch]


@njit(cache=CACHE, inline="always")
def _bilinear_backward(table, base, h, w, u, v, boundary, weight, grad_out, p, grad_table):
    """Accumulate ``weight * d bilinear / d texels`` into ``grad_table`` (``scatter_add``); return ``(g_u,
    g_v, g_value)``: gradients of ``weight * bilinear`` to ``u`` and ``v``, and ``sum_ch
    grad_out * bilinear`` (for the level blend).  Outside texels read as 0."""
    i00, i01, i10, i11, m00, m01, m10, m11, fx, fy = _bilinear_taps(base, u, v, h, w, boundary)
    w00 = m00 * (1 - fx) * (1 - fy)
    w01 = m01 * fx * (1 - fy)
    w10 = m10 * (1 - fx) * fy
    w11 = m11 * fx * fy
    g_x = 0.0
    g_y = 0.0
    g_value = 0.0
    for ch in range(table.shape[1]):
        g = grad_out[p, ch]
        t00 = m00 * table[i00, ch]
        t01 = m01 * table[i01, ch]
        t10 = m10 * table[i10, ch]
        t11 = m11 * table[i11, ch]
        top = t00 + fx * (t01 - t00)
        bottom = t10 + fx * (t11 - t10)
        g_value += g * (top + fy * (bottom - top))
        g_x += g * ((1 - fy) * (t01 - t00) + fy * (t11 - t10))
        g_y += g * (bottom - top)
        gw = g * weight
        scatter_add(grad_table, (i00, ch), gw * w00)
        scatter_add(grad_table, (i01, ch), gw * w01)
        scatter_add(grad_table, (i10, ch), gw * w10)
        scatter_add(grad_table, (i11, ch), gw * w11)
    return weight * g_x * w, weight * g_y * h, g_value


@njit(cache=CACHE)
def _level_backward(uv_da, p, h0, w0, lam, g_raw, grad_uv_da):
    """``grad_uv_da[p] = g_raw * d(0.5 log2 lambda_max)/d uv_da``."""
    grad_uv_da[p, 0], grad_uv_da[p, 1], grad_uv_da[p, 2], grad_uv_da[p, 3] = footprint_level_gradient(
        uv_da[p, 0], uv_da[p, 1], uv_da[p, 2], uv_da[p, 3], h0, w0, lam, g_raw)


@njit(cache=CACHE, inline="always")
def footprint_level_gradient(du_dx, du_dy, dv_dx, dv_dy, h0, w0, lam, g_raw):
    """``g_raw * d(0.5 log2 lambda_max) / d(du/dX, du/dY, dv/dX, dv/dY)`` of a footprint whose
    ``lambda_max`` is ``lam``, as four values."""
    dsx, dsy = du_dx * w0, du_dy * w0
    dtx, dty = dv_dx * h0, dv_dy * h0
    a = dsx * dsx + dsy * dsy
    c = dtx * dtx + dty * dty
    b = dsx * dtx + dsy * dty
    q = 0.25 * (a - c) * (a - c) + b * b
    g_lam = g_raw * 0.5 / (lam * math.log(2.0))
    g_a, g_c, g_b = 0.5 * g_lam, 0.5 * g_lam, 0.0
    if q >= _TINY:
        r = math.sqrt(q)
        g_a += g_lam * 0.25 * (a - c) / r
        g_c -= g_lam * 0.25 * (a - c) / r
        g_b = g_lam * b / r
    return ((2 * g_a * dsx + g_b * dtx) * w0, (2 * g_a * dsy + g_b * dty) * w0,
            (2 * g_c * dtx + g_b * dsx) * h0, (2 * g_c * dty + g_b * dsy) * h0)


@njit(cache=CACHE, inline="always")
def _mip_pair(mode, lvl, top):
    """``(level, frac)`` of a lookup at mip level ``lvl`` (clamped to [0, top]): the finer
    level read and the weight of the next coarser one, which is 0 for ``MIP_NEAREST`` (the
    nearest level) and where the pyramid has one level only."""
    if mode == MIP_NEAREST:
        return int(math.floor(lvl + 0.5)), 0.0
    if top > 0:
        level = min(int(math.floor(lvl)), top - 1)
        return level, lvl - level
    return 0, 0.0


@njit(cache=CACHE, parallel=True)
def texture_forward(table, heights, widths, offsets, per_view, pixels_per_view, uv, uv_da, bias, mode, boundary, out):
    """``out [P, C]`` (zeroed) = filtered lookups at ``uv [P, 2]``.  ``uv_da [P, 4]`` and
    ``bias [P]`` may have 0 rows (absent); ``per_view``: the table holds one texture per
    view, pixel ``p`` belongs to view ``p // pixels_per_view``."""
    for p in prange(uv.shape[0]):
        texture_forward_pixel(table, heights, widths, offsets, per_view, pixels_per_view, uv, uv_da, bias, mode,
                              boundary, out, p)


@njit(cache=CACHE, inline="always")
def texture_forward_pixel(table, heights, widths, offsets, per_view, pixels_per_view, uv, uv_da, bias, mode, boundary,
                          out, p):
    """Pixel ``p`` of :func:`texture_forward` (both its CPU and its CUDA form): ``out[p]`` =
    the lookup at ``uv[p]`` in the filter ``mode`` and the ``boundary`` mode."""
    top = heights.shape[0] - 1
    has_da, has_bias = uv_da.shape[0] > 0, bias.shape[0] > 0
    view = p // pixels_per_view if per_view else 0
    u, v = uv[p, 0], uv[p, 1]
    if mode == NEAREST:
        h, w = heights[0], widths[0]
        base = offsets[0] + view * h * w
        col, col_in = _resolve(int(math.floor(u * w)), w, boundary)
        row, row_in = _resolve(int(math.floor(v * h)), h, boundary)
        for ch in range(table.shape[1]):
            out[p, ch] = col_in * row_in * table[base + row * w + col, ch]
        return
    level, frac = 0, 0.0
    if mode != LINEAR:
        lvl, _, _ = _level(uv_da, bias, p, has_da, has_bias, heights[0], widths[0], top)
        level, frac = _mip_pair(mode, lvl, top)
    h, w = heights[level], widths[level]
    _bilinear_add(table, offsets[level] + view * h * w, h, w, u, v, boundary, 1.0 - frac, out, p)
    if frac != 0.0:
        h, w = heights[level + 1], widths[level + 1]
        _bilinear_add(table, offsets[level + 1] + view * h * w, h, w, u, v, boundary, frac, out, p)


@njit(cache=CACHE, inline="always")
def _all_zero(grad_out, p):
    for ch in range(grad_out.shape[1]):
        if grad_out[p, ch] != 0.0:
            return False
    return True


@njit(cache=CACHE, inline="always")
def texture_backward_pixel(
    table, heights, widths, offsets, per_view, pixels_per_view, uv, uv_da, bias, mode, boundary,
    grad_out, grad_table, grad_uv, grad_uv_da, grad_bias, p,
):
    """Pixel ``p`` of :func:`texture_backward` (both its CPU and its CUDA form): its texel
    gradients added into ``grad_table`` (``scatter_add``), its rows of ``grad_uv``,
    ``grad_uv_da`` and ``grad_bias`` written. A pixel whose output gradient is all zero is
    skipped (its gradients stay 0): masked pixels, typically the background."""
    if _all_zero(grad_out, p):
        return
    top = heights.shape[0] - 1
    has_da, has_bias = uv_da.shape[0] > 0, bias.shape[0] > 0
    view = p // pixels_per_view if per_view else 0
    u, v = uv[p, 0], uv[p, 1]
    if mode == NEAREST:
        h, w = heights[0], widths[0]
        col, col_in = _resolve(int(math.floor(u * w)), w, boundary)
        row, row_in = _resolve(int(math.floor(v * h)), h, boundary)
        for ch in range(table.shape[1]):
            scatter_add(grad_table, (offsets[0] + view * h * w + row * w + col, ch), col_in * row_in * grad_out[p, ch])
        return
    level, frac = 0, 0.0
    raw, lam = 0.0, 0.0
    if mode != LINEAR:
        lvl, raw, lam = _level(uv_da, bias, p, has_da, has_bias, heights[0], widths[0], top)
        level, frac = _mip_pair(mode, lvl, top)
    h, w = heights[level], widths[level]
    g_u, g_v, fine = _bilinear_backward(
        table, offsets[level] + view * h * w, h, w, u, v, boundary, 1.0 - frac, grad_out, p, grad_table
    )
    if mode == MIP_LINEAR and top > 0:
        h, w = heights[level + 1], widths[level + 1]
        g_u1, g_v1, coarse = _bilinear_backward(
            table, offsets[level + 1] + view * h * w, h, w, u, v, boundary, frac, grad_out, p, grad_table
        )
        g_u += g_u1
        g_v += g_v1
        if 0.0 <= raw <= top:
            g_raw = coarse - fine
            if has_bias:
                grad_bias[p] = g_raw
            if has_da and lam >= _TINY:
                _level_backward(uv_da, p, heights[0], widths[0], lam, g_raw, grad_uv_da)
    grad_uv[p, 0] = g_u
    grad_uv[p, 1] = g_v


@njit(cache=CACHE, parallel=True)
def texture_backward(
    table, heights, widths, offsets, per_view, pixels_per_view, uv, uv_da, bias, mode, boundary,
    grad_out, grad_table, grad_uv, grad_uv_da, grad_bias, n_chunks,
):
    """Gradients of :func:`texture_forward`: accumulate into ``grad_table [N, C]`` (zeroed;
    each parallel chunk of pixels but the first sums into its own copy, added at the end)
    and write ``grad_uv [P, 2]``, ``grad_uv_da [P, 4]`` and ``grad_bias [P]`` (zeroed; the
    last two when present)."""
    n_pixels = uv.shape[0]
    private = np.zeros((n_chunks - 1, table.shape[0], table.shape[1]), table.dtype)
    for chunk in prange(n_chunks):
        target = grad_table if chunk == 0 else private[chunk - 1]
        for p in range(chunk * n_pixels // n_chunks, (chunk + 1) * n_pixels // n_chunks):
            texture_backward_pixel(table, heights, widths, offsets, per_view, pixels_per_view, uv, uv_da, bias, mode,
                                   boundary, grad_out, target, grad_uv, grad_uv_da, grad_bias, p)
    for row in prange(table.shape[0]):
        for k in range(n_chunks - 1):
            for ch in range(table.shape[1]):
                grad_table[row, ch] += private[k, row, ch]
