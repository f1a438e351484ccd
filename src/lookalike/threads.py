"""One thread policy for every parallel part: torch's intra-op pool, Numba's parallel kernels
and the Embree ray-tracing blocks all use ``thread_count()`` threads. By default that is the
cores this process may use (``os.sched_getaffinity``: a container's or a scheduler's share, not
the machine's); ``set_threads(n)`` sets it, e.g. so that N batch tasks on one machine share its
cores instead of each claiming all of them. Threads with nothing to do sleep rather than spin
(``sleep_while_waiting``), so that another busy program gets the cores they would hold."""

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


def sleep_while_waiting() -> None:
    """Make idle OpenMP threads (torch's pool, and Numba's with its ``omp`` layer) sleep at once
    instead of spinning, unless the user chose otherwise (``OMP_WAIT_POLICY``). Spinning threads
    hold the cores another busy program needs: beside a second ``simplify``, a step on spot took
    2.09 s with them against 0.51 s alone (4.1 x), 0.87 s without them against 0.55 s alone
    (1.6 x); alone, waking sleeping threads costs about 7 % (``lookalike bench contention``).
    Takes effect only before torch is first imported (``lookalike`` calls it on import)."""
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
