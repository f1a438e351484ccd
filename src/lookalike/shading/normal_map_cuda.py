"""CUDA forms of the shading normals (:mod:`.normal_map_kernels`): one thread per point, each
running the CPU form's per-point body (compiled for the GPU by ``devices.device_function``). The
plain-torch twin is :func:`.normal_map.shading_normal_python`.
"""

from __future__ import annotations

from numba import cuda

from ..devices import device_function
from . import normal_map_kernels as kernels

_forward_point = device_function(kernels.shading_normal_point)
_backward_point = device_function(kernels.shading_normal_backward_point)


@cuda.jit
def shading_normal_forward(normal, tangent, tangent_space, mapped, geometric, view_dir, facing, bend, out):
    """Thread per point: :func:`.normal_map_kernels.shading_normal_forward`."""
    p = cuda.grid(1)
    if p < normal.shape[0]:
        _forward_point(normal, tangent, tangent_space, mapped, geometric, view_dir, facing, bend, out, p)


@cuda.jit
def shading_normal_backward(normal, tangent, tangent_space, mapped, geometric, view_dir, facing, bend, grad_out,
                            grad_normal, grad_tangent, grad_tangent_space, grad_geometric, grad_view_dir):
    """Thread per point: :func:`.normal_map_kernels.shading_normal_backward`."""
    p = cuda.grid(1)
    if p < normal.shape[0]:
        _backward_point(normal, tangent, tangent_space, mapped, geometric, view_dir, facing, bend, grad_out,
                        grad_normal, grad_tangent, grad_tangent_space, grad_geometric, grad_view_dir, p)
