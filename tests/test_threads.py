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


def test_importing_lookalike_makes_idle_openmp_threads_sleep_unless_the_user_chose(monkeypatch):
    import os
    import subprocess
    import sys

    probe = "import os, lookalike, torch; print(os.environ['OMP_WAIT_POLICY'])"
    monkeypatch.delenv("OMP_WAIT_POLICY", raising=False)
    assert subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          check=True).stdout.strip() == "PASSIVE"
    chosen = {**os.environ, "OMP_WAIT_POLICY": "ACTIVE"}
    assert subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True,
                          env=chosen).stdout.strip() == "ACTIVE"
