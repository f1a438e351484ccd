"""CUDA forms of texture filtering (:mod:`.texture_kernels`), the same lookups on torch's CUDA
tensors through the same per-lookup helpers (taps, boundary rule, mip level and its gradient):
one thread per pixel (the helpers that read and write arrays are the CPU form's, compiled for the
GPU as device functions), and atomic adds where the backward pass scatters into the texels (the CPU
form keeps a private table per chunk of pixels instead). The plain-torch twin is
:func:`.texture.texture_python`.
"""

from __future__ import annotations

import math

from numba import cuda

from . import texture_kernels
from .texture_kernels import (_TINY, LINEAR, MIP_LINEAR, NEAREST, _bilinear_taps, _mip_pair, _resolve,
                              footprint_level_gradient)


_level = cuda.jit(device=True)(texture_kernels._level.py_func)
_bilinear_add = cuda.jit(device=True)(texture_kernels._bilinear_add.py_func)


@cuda.jit(device=True)
def _bilinear_backward(table, base, h, w, u, v, boundary, weight, grad_out, p, grad_table):
    """``texture_kernels._bilinear_backward``, its additions to ``grad_table`` atomic."""
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
        cuda.atomic.add(grad_table, (i00, ch), gw * w00)
        cuda.atomic.add(grad_table, (i01, ch), gw * w01)
        cuda.atomic.add(grad_table, (i10, ch), gw * w10)
        cuda.atomic.add(grad_table, (i11, ch), gw * w11)
    return weight * g_x * w, weight * g_y * h, g_value


@cuda.jit
def texture_forward(table, heights, widths, offsets, per_view, pixels_per_view, uv, uv_da, bias, mode, boundary, out):
    """Thread per pixel: :func:`.texture_kernels.texture_forward` (``out`` zeroed)."""
    p = cuda.grid(1)
    if p >= uv.shape[0]:
        return
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


@cuda.jit
def texture_backward(table, heights, widths, offsets, per_view, pixels_per_view, uv, uv_da, bias, mode, boundary,
                     grad_out, grad_table, grad_uv, grad_uv_da, grad_bias):
    """Thread per pixel: :func:`.texture_kernels.texture_backward` (gradients zeroed; pixels
    whose output gradient is all zero are skipped)."""
    p = cuda.grid(1)
    if p >= uv.shape[0]:
        return
    silent = True
    for ch in range(grad_out.shape[1]):
        silent = silent and grad_out[p, ch] == 0.0
    if silent:
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
            cuda.atomic.add(grad_table, (offsets[0] + view * h * w + row * w + col, ch), col_in * row_in * grad_out[p, ch])
        return
    level, frac = 0, 0.0
    raw, lam = 0.0, 0.0
    if mode != LINEAR:
        lvl, raw, lam = _level(uv_da, bias, p, has_da, has_bias, heights[0], widths[0], top)
        level, frac = _mip_pair(mode, lvl, top)
    h, w = heights[level], widths[level]
    g_u, g_v, fine = _bilinear_backward(table, offsets[level] + view * h * w, h, w, u, v, boundary, 1.0 - frac,
                                        grad_out, p, grad_table)
    if mode == MIP_LINEAR and top > 0:
        h, w = heights[level + 1], widths[level + 1]
        g_u1, g_v1, coarse = _bilinear_backward(table, offsets[level + 1] + view * h * w, h, w, u, v, boundary, frac,
                                                grad_out, p, grad_table)
        g_u += g_u1
        g_v += g_v1
        if 0.0 <= raw <= top:
            g_raw = coarse - fine
            if has_bias:
                grad_bias[p] = g_raw
            if has_da and lam >= _TINY:
                grad_uv_da[p, 0], grad_uv_da[p, 1], grad_uv_da[p, 2], grad_uv_da[p, 3] = footprint_level_gradient(
                    uv_da[p, 0], uv_da[p, 1], uv_da[p, 2], uv_da[p, 3], heights[0], widths[0], lam, g_raw)
    grad_uv[p, 0] = g_u
    grad_uv[p, 1] = g_v
