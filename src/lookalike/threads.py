"""One thread policy for every parallel part: torch's intra-op pool, Numba's parallel kernels
and the Embree ray-tracing blocks all use ``thread_count()`` threads. By default that is the
cores this process may use (``os.sched_getaffinity``: a container's or a scheduler's share, not
the machine's); ``set_threads(n)`` sets it, e.g. so that N batch tasks on one machine share its
cores instead of each claiming all of them.

Where the count is not set, the optimisation loop gives cores to other busy programs while they
run (``CoreShare``): every few seconds it measures how many of this process's cores others kept
busy and uses the rest. Beside a second ``simplify``, each then steps on its share of the cores
instead of both fighting over all of them, because two programs that each claim every core slow
each other down far more than sharing does (``lookalike bench contention``; figures in
``docs/benchmarks.md``). Idle OpenMP threads keep spinning briefly (the runtime's default):
making them sleep at once (``OMP_WAIT_POLICY=PASSIVE``) gave the same fairness but made every
step of a program alone slower.

A set count is never changed, so a run with ``set_threads`` (``--threads``) repeats bit for
bit; the thread count changes how sums are split, so runs at different counts differ in the
last bits."""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable

_count: int | None = None

SHARE_SAMPLE_SECONDS = 2.0
"""How often ``CoreShare`` measures the other programs' load (wall seconds)."""

_BUSY_FIELDS = (0, 1, 2, 5, 6, 7)
"""Columns of a ``/proc/stat`` cpu line that count as busy: user, nice, system, irq, softirq,
steal (not idle, not iowait)."""


def available_cpus() -> list[int]:
    """The numbers of the cores this process may run on."""
    return sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else list(range(os.cpu_count() or 1))


def available_cores() -> int:
    """The cores this process may run on."""
    return len(available_cpus())


def thread_count() -> int:
    """Threads each parallel part may use: the ``set_threads`` value, else ``available_cores()``."""
    return _count if _count is not None else available_cores()


def set_threads(count: int) -> None:
    """Use ``count`` threads in torch, Numba (at most its pool's size) and the Embree blocks."""
    global _count
    _count = max(1, int(count))
    _use(_count)


def busy_seconds(cpus: list[int]) -> float | None:
    """CPU seconds the machine has spent busy on ``cpus`` since boot, by every program
    (``/proc/stat``); ``None`` where that file is missing (not Linux)."""
    try:
        with open("/proc/stat", encoding="ascii") as stat:
            lines = stat.readlines()
    except OSError:
        return None
    wanted = {f"cpu{cpu}" for cpu in cpus}
    ticks = sum(int(fields[1 + k]) for fields in (line.split() for line in lines)
                if fields and fields[0] in wanted for k in _BUSY_FIELDS)
    return ticks / os.sysconf("SC_CLK_TCK")


def threads_left(cores: int, others: float, ceiling: int) -> int:
    """Threads to use on ``cores`` cores of which other programs keep ``others`` busy on
    average: the cores they leave, rounded, within ``[1, ceiling]``."""
    return max(1, min(ceiling, math.floor(cores - others + 0.5)))


def _use(count: int) -> None:
    """``count`` threads in torch and Numba (this thread's Numba setting), ``thread_count()``
    left as it is."""
    import numba
    import torch

    torch.set_num_threads(count)
    numba.set_num_threads(min(count, numba.config.NUMBA_NUM_THREADS))


class CoreShare:
    """Gives this process's cores to other busy programs while they run (see the module
    docstring). Call ``update()`` once per step: every ``SHARE_SAMPLE_SECONDS`` it measures
    ``others = (busy - own) / wall`` over the last interval, in cores (``busy`` the machine's
    busy CPU seconds on this process's cores, ``own`` this process's CPU seconds), and uses
    ``threads_left(cores, others, thread_count())`` threads. ``restore()`` goes back to
    ``thread_count()``. Does nothing where the count is set (``set_threads``) or the load cannot
    be read.

    Args:
        clock, busy, own: the wall clock, ``busy_seconds`` and the process's CPU clock (tests
            give fakes).
    """

    def __init__(self, clock: Callable[[], float] = time.monotonic,
                 busy: Callable[[list[int]], float | None] = busy_seconds,
                 own: Callable[[], float] = time.process_time):
        self.clock, self.busy, self.own = clock, busy, own
        self.cpus = available_cpus()
        self.active = _count is None and busy(self.cpus) is not None
        self.threads = thread_count()
        self.last = self._sample() if self.active else None

    def _sample(self) -> tuple[float, float, float]:
        return self.clock(), self.busy(self.cpus), self.own()

    def update(self) -> None:
        """Measure and adapt, if ``SHARE_SAMPLE_SECONDS`` have passed since the last time."""
        if not self.active or self.clock() - self.last[0] < SHARE_SAMPLE_SECONDS:
            return
        sample = self._sample()
        wall = sample[0] - self.last[0]
        others = max(0.0, (sample[1] - self.last[1]) - (sample[2] - self.last[2])) / wall
        self.last = sample
        wanted = threads_left(len(self.cpus), others, thread_count())
        if wanted != self.threads:
            _use(wanted)
            self.threads = wanted

    def restore(self) -> None:
        """Back to ``thread_count()`` threads."""
        if self.active and self.threads != thread_count():
            _use(thread_count())
            self.threads = thread_count()
