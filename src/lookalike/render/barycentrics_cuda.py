"""CUDA forms of rasterize's barycentric kernels (:mod:`.barycentrics_kernels`): one thread per
pixel where the CPU forms walk pixels in ``prange``, one per (view, triangle) for the
coefficients, each running the CPU form's per-element body (compiled for the GPU by
``devices.device_function``), whose additions to a triangle's coefficient gradients are atomic
here (the CPU form runs one view per thread instead). The plain-torch twin is
:func:`.barycentrics.barycentrics_python`.
"""

from __future__ import annotations

from numba import cuda

from ..devices import device_function
from . import barycentrics_kernels as kernels
from .pixels import unravel_pixel

_forward_pixel = device_function(kernels.barycentrics_pixel)
_backward_pixel = device_function(kernels.barycentrics_backward_pixel)
_coefficients = device_function(kernels.triangle_coefficients_one)
_shown = device_function(kernels.shown_triangle)
_pixel = device_function(unravel_pixel)


@cuda.jit
def barycentrics_forward(coef, tri_id, depth, window, rast, rast_db):
    """Thread per pixel: :func:`.barycentrics_kernels.barycentrics_forward`."""
    n_views, height, width = tri_id.shape
    job = cuda.grid(1)
    if job < n_views * height * width:
        b, iy, ix = _pixel(job, height, width)
        _forward_pixel(coef, tri_id, depth, window, rast, rast_db, b, iy, ix)


@cuda.jit
def barycentrics_backward(coef, tri_id, window, grad_rast, grad_db, use_db, grad_coef):
    """Thread per pixel: :func:`.barycentrics_kernels.barycentrics_backward` (``grad_coef``
    zeroed)."""
    n_views, height, width = tri_id.shape
    job = cuda.grid(1)
    if job < n_views * height * width:
        b, iy, ix = _pixel(job, height, width)
        _backward_pixel(coef, tri_id, window, grad_rast, grad_db, use_db, grad_coef, b, iy, ix)


@cuda.jit
def triangle_coefficients_forward(xyw, tri, shown, coef):
    """Thread per (view, triangle): :func:`.barycentrics_kernels.triangle_coefficients_forward`."""
    n_tris = tri.shape[0]
    job = cuda.grid(1)
    if job < xyw.shape[0] * n_tris:
        _coefficients(xyw, tri, shown, coef, job // n_tris, job % n_tris)


@cuda.jit
def shown_triangles(tri_id, shown):
    """Thread per pixel: :func:`.barycentrics_kernels.shown_triangles`."""
    n_views, height, width = tri_id.shape
    job = cuda.grid(1)
    if job < n_views * height * width:
        b, y, x = _pixel(job, height, width)
        _shown(tri_id, shown, b, y, x)
