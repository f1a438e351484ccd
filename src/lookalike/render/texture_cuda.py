"""CUDA forms of texture filtering (:mod:`.texture_kernels`): one thread per pixel, each running
the per-pixel body of the CPU form (``texture_forward_pixel``, ``texture_backward_pixel``,
compiled for the GPU by ``devices.device_function``), whose texel gradients add atomically
here (the CPU form keeps a private table per chunk of pixels instead). The plain-torch twin is
:func:`.texture.texture_python`.
"""

from __future__ import annotations

from numba import cuda

from ..devices import device_function
from . import texture_kernels

_forward_pixel = device_function(texture_kernels.texture_forward_pixel)
_backward_pixel = device_function(texture_kernels.texture_backward_pixel)


@cuda.jit
def texture_forward(table, heights, widths, offsets, per_view, pixels_per_view, uv, uv_da, bias, mode, boundary, out):
    """Thread per pixel: :func:`.texture_kernels.texture_forward` (``out`` zeroed)."""
    p = cuda.grid(1)
    if p < uv.shape[0]:
        _forward_pixel(table, heights, widths, offsets, per_view, pixels_per_view, uv, uv_da, bias, mode, boundary,
                       out, p)


@cuda.jit
def texture_backward(table, heights, widths, offsets, per_view, pixels_per_view, uv, uv_da, bias, mode, boundary,
                     grad_out, grad_table, grad_uv, grad_uv_da, grad_bias):
    """Thread per pixel: :func:`.texture_kernels.texture_backward` (gradients zeroed)."""
    p = cuda.grid(1)
    if p < uv.shape[0]:
        _backward_pixel(table, heights, widths, offsets, per_view, pixels_per_view, uv, uv_da, bias, mode, boundary,
                        grad_out, grad_table, grad_uv, grad_uv_da, grad_bias, p)
