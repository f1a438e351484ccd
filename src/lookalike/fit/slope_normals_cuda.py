"""CUDA forms of the slope normals (:mod:`.slope_normals_kernels`): one thread per texel, each
running the CPU form's per-texel body (compiled for the GPU by ``devices.device_function``).
The plain-torch twin is :func:`.slope_normals.slopes_to_normal_python`.
"""

from __future__ import annotations

from numba import cuda

from ..devices import device_function
from . import slope_normals_kernels as kernels

_normal = device_function(kernels.slope_normal)
_backward = device_function(kernels.slope_normal_backward)


@cuda.jit
def slopes_to_normal(slopes, normal):
    """Thread per texel: :func:`.slope_normals_kernels.slopes_to_normal`."""
    i = cuda.grid(1)
    if i < slopes.shape[0]:
        _normal(slopes, normal, i)


@cuda.jit
def slopes_to_normal_backward(normal, grad, out):
    """Thread per texel: :func:`.slope_normals_kernels.slopes_to_normal_backward`."""
    i = cuda.grid(1)
    if i < normal.shape[0]:
        _backward(normal, grad, out, i)
