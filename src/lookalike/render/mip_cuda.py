"""CUDA forms of the mip downsampling (:mod:`.mip_kernels`), the same area rule and the same span
helpers on torch's CUDA tensors: one thread per output texel for a level, one per input texel for
its adjoint (a gather, so no two threads write one texel). The plain-torch twin is
:func:`.mipmap.texture_construct_mip`.
"""

from __future__ import annotations

from numba import cuda

from .mip_kernels import _covering, _span


@cuda.jit
def downsample(table, src, h, w, dst, h2, w2, n_views):
    """Thread per texel of level ``dst``: :func:`.mip_kernels.downsample`."""
    job = cuda.grid(1)
    if job >= n_views * h2 * w2:
        return
    b, oy, ox = job // (h2 * w2), (job // w2) % h2, job % w2
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


@cuda.jit
def downsample_adjoint(grad, src, h, w, dst, h2, w2, n_views):
    """Thread per texel of level ``src``: :func:`.mip_kernels.downsample_adjoint`, which gathers
    ``g / area`` from the texels of level ``dst`` whose spans cover it."""
    job = cuda.grid(1)
    if job >= n_views * h * w:
        return
    b, y, x = job // (h * w), (job // w) % h, job % w
    target = src + (b * h + y) * w + x
    oy0, oy1 = _covering(y, h, h2)
    ox0, ox1 = _covering(x, w, w2)
    for oy in range(oy0, oy1):
        y0, y1 = _span(oy, h, h2)
        for ox in range(ox0, ox1):
            x0, x1 = _span(ox, w, w2)
            scale = 1.0 / ((y1 - y0) * (x1 - x0))
            out = dst + (b * h2 + oy) * w2 + ox
            for ch in range(grad.shape[1]):
                grad[target, ch] += grad[out, ch] * scale
