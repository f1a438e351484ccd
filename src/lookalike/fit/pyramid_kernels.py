"""Compiled bilinear upsampling of channels-last images and its adjoint, for the sum of a
texture pyramid's levels (:class:`.texture_pyramid.TexturePyramid`).

The rule is ``torch.nn.functional.interpolate(mode="bilinear", align_corners=False)`` with an
output size: along an axis of ``n_in`` input and ``n_out`` output texels, output ``o`` reads
``src = max((o + 1/2) n_in / n_out - 1/2, 0)``, ``i0 = floor(src)``, ``i1 = min(i0 + 1,
n_in - 1)`` with weights ``1 - f`` and ``f = src - i0``; the 2D weights are the products of
the row and column ones.  Images are ``[h, w, C]`` arrays (the levels' own layout, no
permutation to ``[1, C, h, w]``).  Both directions are separable passes whose inner loops run
over whole rows of ``w C`` contiguous values (vectorised), each row a body (``widen_row``,
``add_row``, ``adjoint_row``) that the CUDA forms (:mod:`.pyramid_cuda`) run too, one thread
per row.  The plain-torch twin is :func:`.texture_pyramid.upsample` (``F.interpolate``); tests
compare values and gradients.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..kernel_cache import CACHE


@njit(cache=CACHE)
def axis_taps(n_in, n_out):
    """``(i0 [n_out], i1 [n_out], f [n_out])``: the two input texels each output texel reads
    along one axis and the weight of the second (float32, as torch computes it)."""
    i0 = np.empty(n_out, np.int64)
    i1 = np.empty(n_out, np.int64)
    f = np.empty(n_out, np.float32)
    scale = np.float32(n_in) / np.float32(n_out)
    for o in range(n_out):
        src = scale * np.float32(o + 0.5) - np.float32(0.5)
        if src < 0:
            src = np.float32(0.0)
        i = int(src)
        i0[o] = i
        i1[o] = min(i + 1, n_in - 1)
        f[o] = src - np.float32(i)
    return i0, i1, f


@njit(cache=CACHE)
def readers(n_in, n_out):
    """The transpose of ``axis_taps``: ``(start [n_in + 1], output [2 n_out], weight [2
    n_out])``, input texel ``j`` being read by outputs ``output[start[j]:start[j + 1]]`` with
    those weights."""
    i0, i1, f = axis_taps(n_in, n_out)
    start = np.zeros(n_in + 1, np.int64)
    for o in range(n_out):
        start[i0[o] + 1] += 1
        start[i1[o] + 1] += 1
    for j in range(n_in):
        start[j + 1] += start[j]
    output = np.empty(2 * n_out, np.int64)
    weight = np.empty(2 * n_out, np.float32)
    fill = start[:-1].copy()
    for o in range(n_out):
        output[fill[i0[o]]] = o
        weight[fill[i0[o]]] = 1 - f[o]
        fill[i0[o]] += 1
        output[fill[i1[o]]] = o
        weight[fill[i1[o]]] = f[o]
        fill[i1[o]] += 1
    return start, output, weight


@njit(cache=CACHE, parallel=True)
def upsample_add(coarse, fine, scale, low, high, out):
    """``out [H, W, C] = clamp(scale * fine [H, W, C] + up(coarse [h, w, C]), low [C], high
    [C])``; where the clamp moves a texel, the move divided by ``scale`` is added to ``fine``
    (so that ``scale * fine + up(coarse)`` is the clamped value from then on).  ``scale > 0``."""
    height, width, channels = out.shape
    rows = coarse.shape[0]
    r0, r1, fr = axis_taps(rows, height)
    c0, c1, fc = axis_taps(coarse.shape[1], width)
    span = width * channels
    wide = np.empty((rows, span), coarse.dtype)  # the coarse rows upsampled along x
    for r in prange(rows):
        widen_row(coarse, c0, c1, fc, wide, r)
    lows = np.empty(span, out.dtype)
    highs = np.empty(span, out.dtype)
    for k in range(span):
        lows[k] = low[k % channels]
        highs[k] = high[k % channels]
    fine_rows = fine.reshape(height, span)
    out_rows = out.reshape(height, span)
    weight = out.dtype.type(scale)
    inverse = out.dtype.type(1.0 / scale)
    for y in prange(height):
        add_row(wide, r0, r1, fr, fine_rows, weight, inverse, lows, highs, out_rows, y)


@njit(cache=CACHE, inline="always")
def widen_row(coarse, c0, c1, fc, wide, r):
    """Row ``r`` of ``wide [h, W C]``, row ``r`` of ``coarse [h, w, C]`` upsampled along x with the
    taps ``(c0, c1, fc)`` of ``axis_taps`` (in :func:`upsample_add`, both its CPU and its CUDA
    form)."""
    channels = coarse.shape[2]
    for x in range(c0.shape[0]):
        p, q, wx = c0[x], c1[x], fc[x]
        for ch in range(channels):
            wide[r, x * channels + ch] = (1 - wx) * coarse[r, p, ch] + wx * coarse[r, q, ch]


@njit(cache=CACHE, inline="always")
def add_row(wide, r0, r1, fr, fine_rows, weight, inverse, lows, highs, out_rows, y):
    """Row ``y`` of ``out_rows [H, W C]`` in :func:`upsample_add` (both its CPU and its CUDA form):
    ``weight * fine_rows[y]`` plus the rows of ``wide`` upsampled along y (taps ``(r0, r1,
    fr)``), clamped to ``[lows, highs] [W C]``, the clamp's move times ``inverse`` added to
    ``fine_rows[y]``."""
    a, b, wy = r0[y], r1[y], fr[y]
    for k in range(out_rows.shape[1]):
        value = weight * fine_rows[y, k] + (1 - wy) * wide[a, k] + wy * wide[b, k]
        bounded = min(max(value, lows[k]), highs[k])
        out_rows[y, k] = bounded
        if bounded != value:
            fine_rows[y, k] += (bounded - value) * inverse


@njit(cache=CACHE, parallel=True)
def upsample_adjoint(grad, height, width):
    """``[height, width, C]``: the adjoint of upsampling a ``height x width`` image to
    ``grad [H, W, C]``'s size (contiguous), applied to ``grad`` (each fine texel's gradient
    spread over the four coarse texels it read, with the same weights), gathered per coarse
    row: the fine rows that read it (whole rows, vectorised; twice as fast as reading a
    strided ``grad`` texel by texel), then the fine columns (``readers``)."""
    fine_h, fine_w, channels = grad.shape
    row_start, row_output, row_weight = readers(height, fine_h)
    col_start, col_output, col_weight = readers(width, fine_w)
    span = fine_w * channels
    fine_rows = grad.reshape(fine_h, span)
    out = np.empty((height, width, channels), grad.dtype)
    for y in prange(height):
        adjoint_row(fine_rows, row_start, row_output, row_weight, col_start, col_output, col_weight,
                    np.zeros(span, grad.dtype), out, y)
    return out


@njit(cache=CACHE, inline="always")
def adjoint_row(fine_rows, row_start, row_output, row_weight, col_start, col_output, col_weight, row, out, y):
    """Row ``y`` of ``out [h, w, C]`` in :func:`upsample_adjoint` (both its CPU and its CUDA
    form): into ``row [W C]`` (zeroed) the fine rows of ``fine_rows [H, W C]`` that read coarse
    row ``y`` (``readers`` of the rows), then ``out[y]`` from ``row``'s columns (``readers`` of
    the columns)."""
    channels = out.shape[2]
    for t in range(row_start[y], row_start[y + 1]):
        source, w = row_output[t], row_weight[t]
        for k in range(row.shape[0]):
            row[k] += w * fine_rows[source, k]
    for x in range(out.shape[1]):
        for ch in range(channels):
            total = out.dtype.type(0.0)
            for t in range(col_start[x], col_start[x + 1]):
                total += col_weight[t] * row[col_output[t] * channels + ch]
            out[y, x, ch] = total
