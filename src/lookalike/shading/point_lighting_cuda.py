"""CUDA forms of point lighting (:mod:`.point_lighting_kernels`): one thread per point, each
running the CPU form's loop over a run of points (``_forward_run``, ``_backward_run``, compiled
for the GPU by ``devices.device_function``) on a run of one point, its own. The plain-torch twin
is :func:`.point_lighting.lit_radiance_python`.
"""

from __future__ import annotations

from numba import cuda

from ..devices import device_function
from . import point_lighting_kernels as kernels

_forward_run = device_function(kernels._forward_run)
_backward_run = device_function(kernels._backward_run)


@cuda.jit
def lit_radiance_forward(kd, ks, normal, view_dir, position, geometric, view, light_pos, intensity, horizon, out):
    """Thread per point: :func:`.point_lighting_kernels.lit_radiance_forward`."""
    p = cuda.grid(1)
    if p < kd.shape[0]:
        _forward_run(kd, ks, normal, view_dir, position, geometric, view, light_pos, intensity, horizon, out, p, p + 1)


@cuda.jit
def lit_radiance_backward(kd, ks, normal, view_dir, position, geometric, view, light_pos, intensity, horizon, grad_out,
                          grad_kd, grad_ks, grad_normal, grad_view_dir, grad_position, grad_intensity):
    """Thread per point: :func:`.point_lighting_kernels.lit_radiance_backward`."""
    p = cuda.grid(1)
    if p < kd.shape[0]:
        _backward_run(kd, ks, normal, view_dir, position, geometric, view, light_pos, intensity, horizon, grad_out,
                      grad_kd, grad_ks, grad_normal, grad_view_dir, grad_position, grad_intensity, p, p + 1)
