"""The CUDA form of :func:`.kernel_scatter.scatter_add`, which ``devices.device_function`` puts in
its place when it compiles a kernel's body for the GPU."""

from __future__ import annotations

from numba import cuda


@cuda.jit(device=True)
def scatter_add(array, index, value):
    """``array[index] += value`` as one atomic add, so that the threads of one launch may add into
    the same element."""
    cuda.atomic.add(array, index, value)
