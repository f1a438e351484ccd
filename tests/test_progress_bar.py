"""The loop's bar: its postfix and what it counts with and without a time budget."""

from __future__ import annotations

from lookalike.fit.progress_bar import ProgressBar, postfix


def test_the_postfix_shows_the_step_the_loss_and_once_scored_the_latest_and_best_scores():
    assert postfix(3, None, 0.123456, None) == {"step": "3/?", "loss": "0.1235"}
    assert postfix(3, 10, 0.5, (21.456, 30.0)) == {"step": "3/10", "loss": "0.5000", "val": "21.46", "best": "30.00"}


def test_without_a_budget_the_bar_counts_steps_from_where_the_run_stands(capsys):
    bar = ProgressBar(iteration=4, total=10, seconds_available=None, show=True)
    bar.step(5, 10, 0.5, None)
    bar.step(6, 10, 0.4, (1.0, 2.0))
    assert bar.bar.n == 6 and bar.bar.total == 10
    assert bar.bar.postfix == "step=6/10, loss=0.4000, val=1.00, best=2.00"
    bar.close()


def test_under_a_budget_the_bar_counts_the_seconds_and_stops_at_the_budget(capsys):
    now = [50.0]
    bar = ProgressBar(iteration=0, total=None, seconds_available=8.04, show=True, clock=lambda: now[0])
    now[0] += 3.0
    bar.step(1, None, 0.5, None)
    assert bar.bar.n == 3.0 and bar.bar.total == 8.0
    now[0] += 20.0
    bar.step(2, 40, 0.5, None)
    assert bar.bar.n == 8.0  # the budget as shown: never past the bar's end (tqdm warns there)
    bar.close()
