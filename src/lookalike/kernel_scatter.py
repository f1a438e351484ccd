"""``scatter_add``: the one operation by which a compiled kernel's per-element body differs
between its CPU and its CUDA form.

A backward pass scatters: several pixels add into one texel's, one vertex's or one triangle's
gradient. The CPU forms give each parallel run of pixels a private table, so a plain add is
safe there; on the GPU every pixel is a thread, so the add must be atomic. Writing the add as
``scatter_add(array, index, value)`` lets one body serve both forms: the CPU kernels inline this
plain add, and ``devices.device_function``, which compiles a body for the GPU, puts
:func:`.kernel_scatter_cuda.scatter_add` (``cuda.atomic.add``) in its place.
"""

from __future__ import annotations

from numba import njit

from .kernel_cache import CACHE


@njit(cache=CACHE, inline="always")
def scatter_add(array, index, value):
    """``array[index] += value`` (``index``: an integer or a tuple of them, as
    ``cuda.atomic.add`` takes), where on the GPU other threads may add into the same element."""
    array[index] += value
