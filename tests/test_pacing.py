"""``Pacing``: the step count under a time budget, from given step durations and a given clock."""

from __future__ import annotations

from lookalike.fit.pacing import CALIBRATION_STEPS, REPLAN_EVERY, Pacing


class Clock:
    """A clock that reads ``now``."""

    def __init__(self):
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_the_total_is_set_after_the_calibration_from_the_pace_and_the_time_left():
    clock = Clock()
    pacing = Pacing(60.0, validate_every=4, clock=clock)
    durations = [9.0] + [0.5] * CALIBRATION_STEPS  # the first step pays compilation
    totals = [pacing.plan(i + 1, None, d, scoring_seconds=2.0) for i, d in enumerate(durations[:-1])]
    assert totals == [None] * CALIBRATION_STEPS
    clock.now += 12.0
    # pace = mean(0.5, ...) + 2 / 4 = 1.0 s per step; 60 - 12 = 48 s left, 2 of them for the last scoring
    assert pacing.plan(len(durations), None, durations[-1], scoring_seconds=2.0) == len(durations) + 46


def test_the_total_is_replanned_every_few_steps_from_the_recent_pace_only():
    clock = Clock()
    pacing = Pacing(100.0, validate_every=10, clock=clock)
    totals = [pacing.plan(step, None, 1.0, scoring_seconds=0.0) for step in range(1, CALIBRATION_STEPS + 2)]
    planned = CALIBRATION_STEPS + 1 + 100  # 100 s left at 1 s per step
    assert totals[-1] == planned
    clock.now += 70.0
    kept = {pacing.plan(step, planned, 1.0, scoring_seconds=0.0) for step in range(CALIBRATION_STEPS + 2, REPLAN_EVERY)}
    assert kept == {planned}  # not re-planned between the multiples of REPLAN_EVERY
    # the first duration is left out: the mean of REPLAN_EVERY - 2 durations of 1 s and one of 3 s
    pace = (REPLAN_EVERY - 2 + 3.0) / (REPLAN_EVERY - 1)
    assert pacing.plan(REPLAN_EVERY, planned, 3.0, scoring_seconds=0.0) == REPLAN_EVERY + int(30.0 / pace)


def test_no_steps_are_planned_when_the_time_is_spent():
    clock = Clock()
    pacing = Pacing(1.0, validate_every=1, clock=clock)
    clock.now += 5.0
    for step in range(1, CALIBRATION_STEPS + 2):
        total = pacing.plan(step, None, 1.0, scoring_seconds=0.0)
    assert total == CALIBRATION_STEPS + 1
