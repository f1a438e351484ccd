"""Where a run's time goes (``lookalike.phases``)."""

from __future__ import annotations

import time

from lookalike.phases import Profile, phase, recording


def busy(seconds: float) -> None:
    """Spin for ``seconds`` of this thread's CPU time (the process's would also count other
    threads still busy from earlier tests, and end the spin early)."""
    end = time.thread_time() + seconds
    while time.thread_time() < end:
        pass


def test_phases_nest_add_up_and_count_cpu():
    profile = Profile()
    with recording(profile), phase("outer"):
        busy(0.05)
        for _ in range(2):
            with phase("inner"):
                time.sleep(0.05)
    phases = profile.as_dict()
    assert list(phases) == ["outer", "outer > inner"]
    outer, inner = phases["outer"], phases["outer > inner"]
    assert inner["calls"] == 2 and outer["calls"] == 1
    assert inner["wall_s"] >= 0.1 and outer["wall_s"] >= inner["wall_s"] + 0.05
    assert inner["cpu_per_wall"] < 0.5                      # asleep
    assert outer["cpu_s"] >= 0.05


def test_nothing_is_recorded_without_a_profile():
    profile = Profile()
    with phase("alone"):
        pass
    with recording(profile):
        pass
    with phase("after"):
        pass
    assert profile.phases == {}
