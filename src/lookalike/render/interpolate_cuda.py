"""CUDA forms of interpolate's kernels (:mod:`.interpolate_kernels`): one thread per listed
pixel, each running the CPU form's per-entry body (compiled for the GPU by
``devices.device_function``), whose additions to the vertices' attribute gradients are atomic
here (the CPU form keeps a private table per run of the list instead). The plain-torch twin is
:func:`.interpolate.interpolate_python`.
"""

from __future__ import annotations

from numba import cuda

from ..devices import device_function
from . import interpolate_kernels as kernels

_forward_entry = device_function(kernels.interpolate_entry)
_backward_entry = device_function(kernels.interpolate_backward_entry)


@cuda.jit
def interpolate_forward(attr, tri, rast, rast_db, diff, pixels, every, pixels_per_view, out, out_da):
    """Thread per listed pixel: :func:`.interpolate_kernels.interpolate_forward`."""
    i = cuda.grid(1)
    if i < out.shape[0]:
        _forward_entry(attr, tri, rast, rast_db, diff, pixels, every, pixels_per_view, out, out_da, i)


@cuda.jit
def interpolate_backward(attr, tri, rast, rast_db, diff, pixels, every, pixels_per_view, grad_out, grad_da,
                         grad_attr, grad_rast, grad_db):
    """Thread per listed pixel: :func:`.interpolate_kernels.interpolate_backward` (the gradients
    zeroed; the listed pixels are distinct, so a pixel's own ``grad_rast`` and ``grad_db`` rows
    have one writer)."""
    i = cuda.grid(1)
    if i < grad_out.shape[0]:
        _backward_entry(attr, tri, rast, rast_db, diff, pixels, every, pixels_per_view, grad_out, grad_da, grad_attr,
                        grad_rast, grad_db, i)
