"""One thread policy for every parallel part: torch's intra-op pool, Numba's parallel kernels
and the Embree ray-tracing blocks all use ``thread_count()`` threads. By default that is the
cores this process may use (``os.sched_getaffinity``: a container's or a scheduler's share, not
the machine's); ``set_threads(n)`` sets it, e.g. so that N batch tasks on one machine share its
cores instead of each claiming all of them."""

from __future__ import annotations

import os

_count: int | None = None


def available_cores() -> int:
    """The cores this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def thread_count() -> int:
    """Threads each parallel part may use: the ``set_threads`` value, else ``available_cores()``."""
    return _count if _count is not None else available_cores()


def set_threads(count: int) -> None:
    """Use ``count`` threads in torch, Numba (at most its pool's size) and the Embree blocks."""
    import numba
    import torch

    global _count
    _count = max(1, int(count))
    torch.set_num_threads(_count)
    numba.set_num_threads(min(_count, numba.config.NUMBA_NUM_THREADS))
