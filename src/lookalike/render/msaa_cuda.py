"""CUDA forms of stochastic MSAA's loops (:mod:`.msaa_kernels`): one thread per low-resolution
pixel (per picked sample for the scatter), each running the CPU form's per-pixel body (compiled
for the GPU by ``devices.device_function``); a pixel writes only its own ``f x f`` block of
samples, so no two threads write one element. The plain-torch twins are
:func:`.msaa.covered_sample_index_python`, :func:`.msaa.pick_samples_python` and
:func:`.msaa.upsample_over_python`.
"""

from __future__ import annotations

from numba import cuda

from ..devices import device_function
from . import msaa_kernels as kernels
from .pixels import unravel_pixel

_pixel = device_function(unravel_pixel)
_covered_sample = device_function(kernels.covered_sample_pixel)
_scatter_row = device_function(kernels.scatter_row)
_over = device_function(kernels.upsample_over_pixel)
_over_backward = device_function(kernels.upsample_over_backward_pixel)


@cuda.jit
def covered_sample_index(ids, u, factor, out):
    """Thread per pixel: :func:`.msaa_kernels.covered_sample_index`."""
    n_views, height, width = u.shape
    job = cuda.grid(1)
    if job < n_views * height * width:
        b, y, x = _pixel(job, height, width)
        _covered_sample(ids, u, factor, out, b, y, x)


@cuda.jit
def scatter_rows(values, index, out):
    """Thread per row: :func:`.msaa_kernels.scatter_rows` (the rows ``index`` are distinct)."""
    i = cuda.grid(1)
    if i < index.shape[0]:
        _scatter_row(values, index, out, i)


@cuda.jit
def upsample_over_forward(accum, colour, ids, factor, out):
    """Thread per pixel: :func:`.msaa_kernels.upsample_over_forward`."""
    n_views, height, width = colour.shape[0], colour.shape[1], colour.shape[2]
    job = cuda.grid(1)
    if job < n_views * height * width:
        b, y, x = _pixel(job, height, width)
        _over(accum, colour, ids, factor, out, b, y, x)


@cuda.jit
def upsample_over_backward(accum, colour, ids, factor, grad_out, grad_accum, grad_colour):
    """Thread per pixel: :func:`.msaa_kernels.upsample_over_backward`."""
    n_views, height, width = colour.shape[0], colour.shape[1], colour.shape[2]
    job = cuda.grid(1)
    if job < n_views * height * width:
        b, y, x = _pixel(job, height, width)
        _over_backward(accum, colour, ids, factor, grad_out, grad_accum, grad_colour, b, y, x)
