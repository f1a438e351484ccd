"""The step count of a run under a time budget: planned from the pace of the steps so far and
re-planned as it changes, so that the loop ends in time even when the machine's load changes."""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

CALIBRATION_STEPS = 4
"""Steps timed (after the first, which pays one-off compilation) before the first plan."""

REPLAN_EVERY = 20
"""Steps between re-plannings of the step count (and the plan's last steps, re-planned one by
one: ``closing``)."""


class Pacing:
    """Plans the total step count N of a session that has ``seconds_available`` from its start.

    N = i + max(0, floor(left / pace)), where i is the steps taken, left = seconds_available -
    elapsed - v, and pace = mean(d[1:][-REPLAN_EVERY:]) + v / validate_every: d are this
    session's step durations (the first is left out: it pays one-off compilation), v /
    validate_every is each step's share of the mean scoring time v, and the v held back is the
    scoring after the last step, which the loop also owes. N is first set once 1 +
    ``CALIBRATION_STEPS`` steps are timed, then re-planned every ``REPLAN_EVERY`` steps, so it
    follows the pace (and what the loop spends between steps: checkpoints, seconds each for a
    large model), and after each of the plan's last ``REPLAN_EVERY`` steps (``closing``), where
    a slow step shortens it at once and no checkpoint is taken, so that the loop ends in time.

    Args:
        seconds_available: the session's time budget.
        validate_every: steps between scorings by the validator.
        clock: the time in seconds (a monotonic clock; tests give their own).
    """

    def __init__(self, seconds_available: float, validate_every: int, clock: Callable[[], float] = time.monotonic):
        self.seconds_available = seconds_available
        self.validate_every = validate_every
        self.clock = clock
        self.start = clock()
        self.durations: list[float] = []

    def plan(self, iteration: int, total: int | None, step_seconds: float, scoring_seconds: float) -> int | None:
        """N after a step of ``step_seconds`` that made the count ``iteration``; ``total`` (the
        current plan, ``None`` before the first) when no (re-)planning is due; ``scoring_seconds``
        is v."""
        self.durations.append(step_seconds)
        if not self._due(iteration, total):
            return total
        pace = float(np.mean(self.durations[1:][-REPLAN_EVERY:])) + scoring_seconds / self.validate_every
        left = self.seconds_available - (self.clock() - self.start) - scoring_seconds
        return iteration + max(0, int(left / pace))

    def _due(self, iteration: int, total: int | None) -> bool:
        """Whether the calibration is done and a plan is missing or due."""
        timed = len(self.durations)
        return timed > CALIBRATION_STEPS and (total is None or timed % REPLAN_EVERY == 0 or closing(iteration, total))


def closing(iteration: int, total: int | None) -> bool:
    """Whether the count ``iteration`` is within ``REPLAN_EVERY`` steps of the end of a plan of
    ``total`` (``None``: none yet). Each such step is re-planned, and the loop takes no periodic
    checkpoint there: a pause of seconds that the few steps left could not make up for, where
    the outputs follow within seconds and the checkpoint before stands for it."""
    return total is not None and total - iteration <= REPLAN_EVERY
