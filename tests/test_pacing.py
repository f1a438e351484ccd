"""``Pacing``: the step count under a time budget, from given step durations and a given clock."""

from __future__ import annotations

from lookalike.fit.pacing import CALIBRATION_STEPS, REPLAN_EVERY, Pacing, closing


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
    totals = []
    for i, d in enumerate(durations[:-1]):
        clock.now += d  # nothing between the steps
        totals.append(pacing.plan(i + 1, None, d, scoring_seconds=2.0))
    assert totals == [None] * CALIBRATION_STEPS
    clock.now += durations[-1]
    # pace = mean(0.5, ...) + 2 / 4 = 1.0 s per step; 60 - 11 = 49 s left, 2 of them for the last scoring
    assert pacing.plan(len(durations), None, durations[-1], scoring_seconds=2.0) == len(durations) + 47


def test_the_total_is_replanned_every_few_steps_from_the_recent_pace_only():
    clock = Clock()
    pacing = Pacing(100.0, validate_every=10, clock=clock)
    totals = []
    for step in range(1, CALIBRATION_STEPS + 2):
        clock.now += 1.0
        totals.append(pacing.plan(step, None, 1.0, scoring_seconds=0.0))
    planned = 100  # (100 - 5) s left at 1 s per step
    assert totals[-1] == planned
    kept = set()
    for step in range(CALIBRATION_STEPS + 2, REPLAN_EVERY):
        clock.now += 1.0
        kept.add(pacing.plan(step, planned, 1.0, scoring_seconds=0.0))
    assert kept == {planned}  # not re-planned between the multiples of REPLAN_EVERY
    clock.now += 3.0
    # the first duration is left out: the mean of REPLAN_EVERY - 2 durations of 1 s and one of 3 s
    pace = (REPLAN_EVERY - 2 + 3.0) / (REPLAN_EVERY - 1)
    left = 100.0 - (REPLAN_EVERY - 1 + 3.0)
    assert pacing.plan(REPLAN_EVERY, planned, 3.0, scoring_seconds=0.0) == REPLAN_EVERY + int(left / pace)


def test_no_steps_are_planned_when_the_time_is_spent():
    clock = Clock()
    pacing = Pacing(1.0, validate_every=1, clock=clock)
    clock.now += 5.0
    for step in range(1, CALIBRATION_STEPS + 2):
        total = pacing.plan(step, None, 1.0, scoring_seconds=0.0)
    assert total == CALIBRATION_STEPS + 1


def paced_loop(budget: float, step_seconds: float, pause_every: float, pause: float, pausing=closing) -> float:
    """The seconds past ``budget`` at which a loop of ``step_seconds`` steps ends, that pauses
    ``pause`` s between steps (a checkpoint) once ``pause_every`` s have passed since the last,
    except where ``pausing`` says the plan is closing (as ``Fitter._loop`` does)."""
    clock = Clock()
    start = clock.now
    pacing = Pacing(budget, validate_every=25, clock=clock)
    step, total, last_pause = 0, None, clock.now
    while total is None or step < total:
        clock.now += step_seconds
        step += 1
        total = pacing.plan(step, total, step_seconds, scoring_seconds=0.0)
        if clock.now - last_pause >= pause_every and not pausing(step, total):
            clock.now += pause
            last_pause = clock.now
    return clock.now - start - budget


def test_a_loop_that_pauses_between_its_steps_ends_within_its_time():
    # checkpoints of a large model: 4.3 s every minute between steps of 0.45 s, over budgets
    # that put a pause anywhere near the end
    overruns = [paced_loop(budget, 0.45, 60.0, 4.3) for budget in range(300, 700, 7)]
    assert max(overruns) <= 0.0 and min(overruns) >= -1.0
    # a pause among the last steps (here allowed) is what ran a loop past its time
    assert max(paced_loop(budget, 0.45, 60.0, 4.3, pausing=lambda step, total: False)
               for budget in range(300, 700, 7)) > 3.0


def test_the_last_steps_of_a_plan_are_replanned_one_by_one():
    clock = Clock()
    pacing = Pacing(100.0, validate_every=10, clock=clock)
    total = None
    for step in range(1, CALIBRATION_STEPS + 2):
        clock.now += 1.0
        total = pacing.plan(step, total, 1.0, scoring_seconds=0.0)
    assert total == 100
    last = total - REPLAN_EVERY  # the first step among the plan's last
    assert closing(last, total) and not closing(last - 1, total) and not closing(5, None)
    clock.now += last - (CALIBRATION_STEPS + 1) + 10.0  # the steps up to it, and a pause of 10 s
    # not a multiple of REPLAN_EVERY, yet re-planned: 100 - 90 s left at 1 s per step
    assert pacing.plan(last, total, 1.0, scoring_seconds=0.0) == last + 10
