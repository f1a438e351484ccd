"""How the C heap serves the large blocks that torch and Numba allocate.

A step allocates and frees hundreds of megabytes of short-lived arrays (images of 4 x 512^2
pixels, 1024^2 texture stacks and their gradients). glibc's ``malloc`` serves blocks above its
``mmap`` threshold (at most 32 MB, and 128 KB until a first such block is freed) with fresh
pages from the kernel and gives them back on ``free``, so every such array is paid for again in
page faults, one per 4 KB page touched. ``keep_freed_memory`` makes ``malloc`` serve every block
from its heap (``M_MMAP_MAX = 0``) and keep up to ``TRIM_THRESHOLD_BYTES`` of freed memory for
the next blocks instead of returning it (``M_TRIM_THRESHOLD``), because the page faults on fresh
pages cost a large share of a step, for little more peak memory (figures in
``docs/benchmarks.md``).

Importing lookalike leaves the process's heap as it is: the ``lookalike`` command
(``lookalike.cli.main``) and the worker programs it starts call ``keep_freed_memory`` once (on
glibc; elsewhere it does nothing). A library user (a notebook, Blender, a Ray worker) who wants
the same calls ``lookalike.heap.keep_freed_memory()`` once, early. The process then returns freed
memory to the system only beyond ``TRIM_THRESHOLD_BYTES`` at the heap's top. Set
``LOOKALIKE_HEAP=system`` to keep the C library's defaults in the command too (a service that
must hand memory back between jobs)."""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import platform

TRIM_THRESHOLD_BYTES = 1 << 30
"""Freed memory at the top of the heap kept for reuse before any is returned to the system."""

_M_TRIM_THRESHOLD, _M_MMAP_MAX = -1, -4  # mallopt parameters (glibc's malloc.h)

_applied = False
"""Whether ``keep_freed_memory`` has set the heap in this process, so that it sets it once."""


def keep_freed_memory(environ=os.environ) -> bool:
    """Have glibc's ``malloc`` keep freed blocks for reuse (see the module docstring); whether
    the setting is made (False: not glibc, or ``LOOKALIKE_HEAP=system`` in ``environ``)."""
    global _applied
    if _applied:
        return True
    if environ.get("LOOKALIKE_HEAP") == "system" or platform.libc_ver()[0] != "glibc":
        return False
    libc = ctypes.CDLL(ctypes.util.find_library("c"))
    _applied = bool(libc.mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES)) and bool(libc.mallopt(_M_MMAP_MAX, 0))
    return _applied
