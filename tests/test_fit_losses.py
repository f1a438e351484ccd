"""Image losses and schedules against hand-computed values."""

from __future__ import annotations

import math

import pytest
import torch

from lookalike.fit import losses, schedule


def _hand_srgb(x: float) -> float:
    return 12.92 * x if x <= 0.0031308 else 1.055 * x ** (1 / 2.4) - 0.055


def test_tonemap_matches_the_papers_formula():
    xs = [0.0, 0.001, 0.003, 0.01, 0.5, 1.0, 7.0, 1000.0]
    got = losses.tonemap(torch.tensor(xs, dtype=torch.float64))
    want = [_hand_srgb(math.log(x + 1)) for x in xs]
    assert got.tolist() == pytest.approx(want, rel=1e-12, abs=1e-15)


def test_srgb_is_continuous_at_the_knee():
    knee = torch.tensor([0.0031308 - 1e-9, 0.0031308 + 1e-9], dtype=torch.float64)
    low, high = losses.srgb(knee).tolist()
    assert abs(low - high) < 1e-6


@pytest.fixture
def pair():
    pred = torch.tensor([[[[0.5, 2.0, 0.0]]], [[[1.0, 0.25, 3.0]]]], dtype=torch.float64)  # [2, 1, 1, 3]
    target = torch.tensor([[[[0.25, 2.0, 1.0]]], [[[0.0, 0.5, 3.0]]]], dtype=torch.float64)
    return pred, target


def test_l1_tonemapped(pair):
    pred, target = pair
    p, t = pred.flatten().tolist(), target.flatten().tolist()
    want = sum(abs(_hand_srgb(math.log1p(a)) - _hand_srgb(math.log1p(b))) for a, b in zip(p, t)) / 6
    assert float(losses.l1_tonemapped(pred, target)) == pytest.approx(want, rel=1e-12)


def test_l2_smape_relative_l2(pair):
    pred, target = pair
    p, t = pred.flatten().tolist(), target.flatten().tolist()
    assert float(losses.l2(pred, target)) == pytest.approx(sum((a - b) ** 2 for a, b in zip(p, t)) / 6)
    assert float(losses.smape(pred, target)) == pytest.approx(
        sum(abs(a - b) / (abs(a) + abs(b) + 0.01) for a, b in zip(p, t)) / 6)
    assert float(losses.relative_l2(pred, target)) == pytest.approx(
        sum((a - b) ** 2 / (a * a + 0.01) for a, b in zip(p, t)) / 6)


def test_relative_l2_stops_the_gradient_through_its_denominator():
    pred = torch.tensor([2.0], dtype=torch.float64, requires_grad=True)
    losses.relative_l2(pred, torch.tensor([1.0], dtype=torch.float64)).backward()
    assert float(pred.grad) == pytest.approx(2 * (2 - 1) / (4 + 0.01))


@pytest.mark.parametrize("name", sorted(losses.IMAGE_LOSSES))
def test_every_loss_is_zero_on_equal_images_and_has_finite_gradients(name):
    x = torch.rand(2, 4, 4, 3, dtype=torch.float64) * 5
    x[0, 0, 0] = 0.0
    assert float(losses.image_loss(name)(x, x.clone())) == 0.0
    pred = (x + 0.1).requires_grad_()
    losses.image_loss(name)(pred, x).backward()
    assert torch.isfinite(pred.grad).all() and pred.grad.abs().sum() > 0


def test_composite_weights_background_by_uncovered_fraction():
    rgba = torch.tensor([[[[0.2, 0.3, 0.4, 0.5]]]])
    out = losses.composite(rgba, torch.tensor([[1.0, 0.0, 0.5]]))
    assert out.flatten().tolist() == pytest.approx([0.7, 0.3, 0.65])


def test_learning_rate_schedule():
    assert schedule.learning_rate(0.01, 0) == 0.01
    assert schedule.learning_rate(0.01, 5000) == pytest.approx(0.001)
    assert schedule.learning_rate(0.02, 2500, k=0.0004) == pytest.approx(0.002)


def test_the_stretched_learning_rate_falls_a_hundredfold_over_the_run():
    assert schedule.learning_rate_decay(10_000) == pytest.approx(0.0002)  # the paper's k on its runs
    k = schedule.learning_rate_decay(700)
    assert schedule.learning_rate(0.03, 700, k) == pytest.approx(0.0003)
    k = schedule.learning_rate_decay(700, decades=1.0)
    assert schedule.learning_rate(0.03, 700, k) == pytest.approx(0.003)


def test_laplacian_schedule_is_the_closed_form_of_the_papers_recursion():
    lam0, lam_min, k = 3.0, 0.06, 1e-4
    lam = lam0
    for t in range(1, 200):
        lam = (lam - lam_min) * 10 ** (-k * t) + lam_min
        assert schedule.laplacian_weight(lam0, t, k, 0.02) == pytest.approx(lam, rel=1e-12)


def test_laplacian_schedule_decays_to_two_percent_over_the_run():
    total = 800
    k = schedule.laplacian_decay_rate(total, decay_fraction=0.2)
    at = [schedule.laplacian_weight(1.0, t, k) for t in (0, 160, total)]
    assert at[0] == 1.0
    assert at[1] == pytest.approx(0.02 + 0.98 * 10 ** (-2 * 161 / 160), rel=1e-9)  # excess ~1 % at 20 % of the run
    assert at[2] == pytest.approx(0.02, abs=1e-9)
    assert schedule.laplacian_decay_rate(10_000, 0.2) == pytest.approx(1e-6)  # the paper's k on its runs
