"""CUDA forms of the mip downsampling (:mod:`.mip_kernels`): one thread per output texel for a
level, one per input texel for its adjoint (a gather, so no two threads write one texel), each
running the CPU form's per-texel body (compiled for the GPU by ``devices.device_function``).
The plain-torch twin is :func:`.mipmap.texture_construct_mip`.
"""

from __future__ import annotations

from numba import cuda

from ..devices import device_function
from . import mip_kernels as kernels

_texel = device_function(kernels.downsample_texel)
_adjoint_texel = device_function(kernels.downsample_adjoint_texel)
_covering = device_function(kernels._covering)


@cuda.jit
def downsample(table, src, h, w, dst, h2, w2, n_views):
    """Thread per texel of level ``dst``: :func:`.mip_kernels.downsample`."""
    job = cuda.grid(1)
    if job < n_views * h2 * w2:
        _texel(table, src, h, w, dst, h2, w2, job // (h2 * w2), (job // w2) % h2, job % w2)


@cuda.jit
def downsample_adjoint(grad, src, h, w, dst, h2, w2, n_views):
    """Thread per texel of level ``src``: :func:`.mip_kernels.downsample_adjoint`."""
    job = cuda.grid(1)
    if job < n_views * h * w:
        y = (job // w) % h
        oy0, oy1 = _covering(y, h, h2)
        _adjoint_texel(grad, src, h, w, dst, h2, w2, job // (h * w), y, job % w, oy0, oy1)
