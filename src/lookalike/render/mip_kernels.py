"""Compiled area downsampling between mip levels, forward and adjoint.

The rule is that of ``torch.nn.functional.interpolate(mode="area")`` (adaptive average
pooling): output texel ``i`` of ``n_out`` averages input texels
``floor(i n_in / n_out) .. ceil((i + 1) n_in / n_out) - 1`` along each axis, so a 2x2 box
filter when the input side is even.  Levels live in a flat ``[N, C]`` table, level
blocks in ``[B, h, w]`` order starting at a row offset.  Used by
:func:`.mipmap.texture_pyramid`, whose plain-torch twin is :func:`.mipmap.texture_construct_mip`;
tests compare values and gradients.  Each texel is a body (``downsample_texel``,
``downsample_adjoint_texel``) that the CUDA forms (:mod:`.mip_cuda`) run too, one thread per
texel.
"""

from __future__ import annotations

from numba import njit, prange

from ..kernel_cache import CACHE


@njit(cache=CACHE, inline="always")
def _span(i, n_in, n_out):
    return (i * n_in) // n_out, ((i + 1) * n_in + n_out - 1) // n_out


@njit(cache=CACHE, parallel=True)
def downsample(table, src, h, w, dst, h2, w2, n_views):
    """Write level ``dst`` (``h2 x w2``, starting at row ``dst``) as the area average of
    level ``src`` (``h x w``) of the same ``table [N, C]``."""
    for row in prange(n_views * h2):
        b, oy = row // h2, row % h2
        for ox in range(w2):
            downsample_texel(table, src, h, w, dst, h2, w2, b, oy, ox)


@njit(cache=CACHE, inline="always")
def downsample_texel(table, src, h, w, dst, h2, w2, b, oy, ox):
    """Texel ``(oy, ox)`` of view ``b`` of level ``dst`` in :func:`downsample` (both its CPU and
    its CUDA form)."""
    y0, y1 = _span(oy, h, h2)
    x0, x1 = _span(ox, w, w2)
    scale = 1.0 / ((y1 - y0) * (x1 - x0))
    out = dst + (b * h2 + oy) * w2 + ox
    for ch in range(table.shape[1]):
        acc = 0.0
        for y in range(y0, y1):
            for x in range(x0, x1):
                acc += table[src + (b * h + y) * w + x, ch]
        table[out, ch] = acc * scale


@njit(cache=CACHE, inline="always")
def _covering(i, n_in, n_out):
    """First and one-past-last output texel whose span contains input texel ``i``."""
    first = max(0, (i * n_out) // n_in - 1)
    while first < n_out and _span(first, n_in, n_out)[1] <= i:
        first += 1
    last = first
    while last < n_out and _span(last, n_in, n_out)[0] <= i:
        last += 1
    return first, last


@njit(cache=CACHE, parallel=True)
def downsample_adjoint(grad, src, h, w, dst, h2, w2, n_views):
    """Add to level ``src`` of ``grad [N, C]`` the adjoint of :func:`downsample` applied to
    level ``dst``: each input texel gathers ``g / area`` from every output texel whose span
    covers it (a gather, so input rows run in parallel without races)."""
    for row in prange(n_views * h):
        b, y = row // h, row % h
        oy0, oy1 = _covering(y, h, h2)
        for x in range(w):
            downsample_adjoint_texel(grad, src, h, w, dst, h2, w2, b, y, x, oy0, oy1)


@njit(cache=CACHE, inline="always")
def downsample_adjoint_texel(grad, src, h, w, dst, h2, w2, b, y, x, oy0, oy1):
    """Texel ``(y, x)`` of view ``b`` of level ``src`` in :func:`downsample_adjoint` (both its
    CPU and its CUDA form), ``oy0 .. oy1 - 1`` being the output rows that cover row ``y``
    (``_covering``, once per row on the CPU)."""
    target = src + (b * h + y) * w + x
    if h == 2 * h2 and w == 2 * w2:  # plain 2x2 boxes: one output per input texel
        out = dst + (b * h2 + y // 2) * w2 + x // 2
        for ch in range(grad.shape[1]):
            grad[target, ch] += 0.25 * grad[out, ch]
        return
    ox0, ox1 = _covering(x, w, w2)
    for oy in range(oy0, oy1):
        y0, y1 = _span(oy, h, h2)
        for ox in range(ox0, ox1):
            x0, x1 = _span(ox, w, w2)
            scale = 1.0 / ((y1 - y0) * (x1 - x0))
            out = dst + (b * h2 + oy) * w2 + ox
            for ch in range(grad.shape[1]):
                grad[target, ch] += grad[out, ch] * scale
