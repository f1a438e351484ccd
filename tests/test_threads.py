"""One thread policy for torch, Numba and the Embree blocks (``lookalike.threads``)."""

from __future__ import annotations

import numba
import numpy as np
import torch

from lookalike import threads
from lookalike.init import raycast


def test_set_threads_reaches_torch_numba_and_embree(monkeypatch):
    before = torch.get_num_threads(), numba.get_num_threads(), threads._count
    pools = []

    class Recording(raycast.ThreadPoolExecutor):
        def __init__(self, max_workers):
            pools.append(max_workers)
            super().__init__(max_workers=max_workers)

    monkeypatch.setattr(raycast, "ThreadPoolExecutor", Recording)
    try:
        assert threads.thread_count() == threads.available_cores()
        threads.set_threads(1)
        assert threads.thread_count() == 1 and torch.get_num_threads() == 1 and numba.get_num_threads() == 1
        caster = raycast.RayCaster(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float), np.array([[0, 1, 2]]))
        rays = 4 * raycast.THREAD_BLOCK
        caster.intersect(np.tile([[0.2, 0.2, 1.0]], (rays, 1)), np.tile([[0, 0, -1.0]], (rays, 1)), np.full(rays, 2.0))
        assert pools[-1] == 1
    finally:
        torch.set_num_threads(before[0])
        numba.set_num_threads(before[1])
        threads._count = before[2]


class _FakeMachine:
    """A clock, the machine's busy CPU seconds and this process's, moved by ``advance``."""

    def __init__(self):
        self.now = self.busy = self.own = 0.0

    def advance(self, seconds: float, own_cores: float, other_cores: float) -> None:
        self.now += seconds
        self.own += own_cores * seconds
        self.busy += (own_cores + other_cores) * seconds


def test_core_share_gives_cores_to_other_programs_and_takes_them_back(monkeypatch):
    monkeypatch.setattr(threads, "_count", None)
    monkeypatch.setattr(threads.os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)
    used = []
    monkeypatch.setattr(threads, "_use", used.append)
    monkeypatch.setattr(threads, "available_cores", lambda: 2)
    machine = _FakeMachine()
    share = threads.CoreShare(clock=lambda: machine.now, busy=lambda cpus: machine.busy, own=lambda: machine.own)
    machine.advance(1.0, own_cores=1.9, other_cores=1.0)
    share.update()
    assert used == []                                      # not yet SHARE_SAMPLE_SECONDS
    machine.advance(threads.SHARE_SAMPLE_SECONDS, own_cores=1.9, other_cores=1.0)
    share.update()
    assert used == [1] and share.threads == 1              # a second busy program: one core each
    machine.advance(threads.SHARE_SAMPLE_SECONDS, own_cores=1.0, other_cores=0.9)
    share.update()
    assert used == [1]
    machine.advance(threads.SHARE_SAMPLE_SECONDS, own_cores=1.0, other_cores=0.05)
    share.update()
    assert used == [1, 2]                                  # it ended: both cores again
    machine.advance(threads.SHARE_SAMPLE_SECONDS, own_cores=1.9, other_cores=1.0)
    share.update()
    share.restore()
    assert used == [1, 2, 1, 2]


def test_core_share_keeps_a_pinned_count(monkeypatch):
    monkeypatch.setattr(threads, "_count", 2)
    used = []
    monkeypatch.setattr(threads, "_use", used.append)
    machine = _FakeMachine()
    share = threads.CoreShare(clock=lambda: machine.now, busy=lambda cpus: machine.busy, own=lambda: machine.own)
    machine.advance(10.0, own_cores=1.0, other_cores=2.0)
    share.update()
    share.restore()
    assert used == [] and not share.active


def test_threads_left_rounds_the_free_cores_within_bounds():
    assert threads.threads_left(2, 0.05, 2) == 2
    assert threads.threads_left(2, 1.0, 2) == 1
    assert threads.threads_left(2, 3.0, 2) == 1
    assert threads.threads_left(8, 2.4, 4) == 4
    assert threads.threads_left(8, 2.6, 8) == 5


def test_busy_seconds_reads_the_machine_where_it_can():
    import os

    seconds = threads.busy_seconds(sorted(os.sched_getaffinity(0)))
    if not os.path.exists("/proc/stat"):
        assert seconds is None
    else:
        assert seconds > 0
