"""``BestState``: which state is kept (the higher finite score; the lowest loss average without
a validator), when the validator scores, and its checkpoint round trip."""

from __future__ import annotations

import math

import pytest
import torch

from lookalike.fit.best_state import LOSS_EMA, BestState


def weight(value: float) -> torch.nn.Linear:
    """A one-weight model whose state tells the states apart."""
    model = torch.nn.Linear(1, 1, bias=False)
    with torch.no_grad():
        model.weight.fill_(value)
    return model


def test_the_higher_finite_score_is_kept_and_a_losing_state_is_not_copied():
    best = BestState(None, validate_every=5, start={"w": 0})
    copies = []

    def state(name):
        return lambda: copies.append(name) or {"w": name}

    best.keep_if_best(2.0, state("a"))
    best.keep_if_best(1.0, state("lower"))
    best.keep_if_best(math.nan, state("nan"))
    best.keep_if_best(math.inf, state("inf"))
    best.keep_if_best(2.0, state("tie"))
    best.keep_if_best(3.0, state("b"))
    assert best.state == {"w": "b"} and best.score == 3.0 and copies == ["a", "b"]


def test_without_a_validator_a_snapshot_is_ranked_by_the_loss_average():
    best = BestState(None, validate_every=5, start={"w": "start"})
    best.offer({"w": "before any loss"})
    assert best.state == {"w": "start"} and best.score == -math.inf
    best.observe_loss(1.0)
    best.observe_loss(3.0)
    assert best.loss_ema == pytest.approx(LOSS_EMA * 1.0 + (1 - LOSS_EMA) * 3.0)
    best.offer({"w": "low"})
    assert best.state == {"w": "low"} and best.score == -best.loss_ema
    best.observe_loss(50.0)
    best.offer({"w": "high"})
    assert best.state == {"w": "low"}


def test_with_a_validator_the_loss_average_picks_nothing_and_the_scores_do():
    best = BestState(lambda model: float(model.weight), validate_every=5, start={})
    best.observe_loss(1.0)
    best.offer({"w": "snapshot"})
    assert best.state == {} and best.scores() is None
    best.validate(weight(2.0), iteration=3)
    best.validate(weight(9.0), iteration=3)  # already scored at this iteration
    best.validate(weight(1.0), iteration=4)
    assert best.validation == [(3, 2.0), (4, 1.0)] and best.scores() == (1.0, 2.0)
    assert float(best.model(weight(0.0)).weight) == 2.0 and not best.model(weight(0.0)).weight.requires_grad


def test_the_validator_scores_the_start_at_step_0_only_and_then_every_few_steps():
    best = BestState(lambda model: 1.0, validate_every=5, start={})
    best.at_start(weight(0.0), iteration=7)  # a resumed session does not score where it starts
    for iteration in range(1, 12):
        best.after_step(weight(0.0), iteration)
    best.at_start(weight(0.0), iteration=0)
    assert [i for i, _ in best.validation] == [5, 10, 0]
    assert best.seconds_per_scoring == pytest.approx(best.validation_seconds / 3)


def test_the_state_round_trips():
    best = BestState(lambda model: float(model.weight), validate_every=5, start={})
    best.observe_loss(2.0)
    best.validate(weight(4.0), iteration=0)
    restored = BestState(lambda model: float(model.weight), validate_every=5, start={})
    restored.load_state_dict(best.state_dict())
    assert restored.state_dict() == best.state_dict()
    restored.validate(weight(3.0), iteration=5)
    assert float(restored.model(weight(0.0)).weight) == 4.0 and len(best.validation) == 1
