"""Image losses, schedules and the objective that combines them, against hand-computed values
(the tone map itself: ``test_colour``)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from lookalike.fit import losses, schedule
from lookalike.fit.objective import LAMBDA_HEURISTIC, Objective
from lookalike.fit.training_views import Batch
from lookalike.shading.camera import Camera
from lookalike.shading.light import PointLight


def _hand_srgb(x: float) -> float:
    return 12.92 * x if x <= 0.0031308 else 1.055 * x ** (1 / 2.4) - 0.055


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


# -- the objective --------------------------------------------------------------------------


class FlatLatent(torch.nn.Module):
    """A fake latent: every pixel has the colour ``value`` (grey) and coverage ``alpha``; its
    regularisers are ``(value - 1)^2`` and ``value^2``, with the given scales."""

    def __init__(self, value: float, scales: dict[str, float], alpha: float = 1.0):
        super().__init__()
        self.value = torch.nn.Parameter(torch.tensor(value, dtype=torch.float64))
        self.alpha = alpha
        self.scales = scales

    def parameter_groups(self):
        return {"all": [self.value]}

    def render(self, camera, light, resolution, pose=None):
        rgb = (self.value * self.alpha).expand(camera.batch_size, resolution, resolution, 3)
        return torch.cat([rgb, torch.full_like(rgb[..., :1], self.alpha)], dim=-1)

    def coverage(self, camera, resolution, pose=None):
        return torch.full((camera.batch_size, resolution, resolution), self.alpha, dtype=torch.float64)

    def clamp_(self):
        pass

    def regularizers(self):
        return {"smooth": (self.value - 1) ** 2, "small": self.value ** 2}

    def regularizer_scales(self):
        return dict(self.scales)


def black_batch(views: int, alpha: float = 1.0, size: int = 2) -> Batch:
    """``views`` views whose reference is black with coverage ``alpha``."""
    eye = torch.tensor([[0.0, 0.0, 3.0]]).expand(views, 3)
    camera = Camera.looking_at(eye, torch.zeros_like(eye))
    light = PointLight(position=eye.clone(), intensity=torch.ones(views, 3))
    target = torch.zeros(views, size, size, 4, dtype=torch.float64)
    target[..., 3] = alpha
    return Batch(camera, light, target)


def test_the_objective_sets_lambda_0_from_the_first_image_loss_then_follows_the_schedule():
    objective = Objective("l2", batch_size=2)
    latent = FlatLatent(0.5, {"smooth": 4.0, "small": 0.5})
    rng = np.random.default_rng(0)
    terms = objective(latent, black_batch(2), rng, 0, 100)
    image = 0.25  # (0.5 - 0)^2 on every pixel; full coverage hides the background
    lambda_0 = {"smooth": 0.25 * image / 4.0, "small": 0.25 * image / 0.5}
    assert LAMBDA_HEURISTIC == 0.25 and objective.lambda_0 == pytest.approx(lambda_0)
    assert terms.image == pytest.approx(image) and terms.regularizers == pytest.approx({"smooth": 0.25, "small": 0.25})
    assert float(terms.total.detach()) == pytest.approx(image + lambda_0["smooth"] * 0.25 + lambda_0["small"] * 0.25)

    with torch.no_grad():
        latent.value.fill_(2.0)  # a larger image loss no longer moves lambda_0
    terms = objective(latent, black_batch(2), rng, 30, 100)
    # k = 4 / (0.2 * 100)^2 = 0.01: lambda_t = lambda_0 * (0.02 + 0.98 * 10^(-0.01 * 30 * 31 / 2))
    decay = 0.02 + 0.98 * 10 ** (-0.01 * 30 * 31 / 2)
    assert objective.lambda_0 == pytest.approx(lambda_0)
    assert float(terms.total.detach()) == pytest.approx(4.0 + decay * (lambda_0["smooth"] * 1.0 + lambda_0["small"] * 4.0))
    assert objective.weights(latent, 123.0, 100, 100) == pytest.approx({k: 0.02 * v for k, v in lambda_0.items()},
                                                                       rel=1e-6)
    assert objective.weights(latent, 123.0, 50, None) == pytest.approx(lambda_0)  # no total: no decay yet


def test_a_configured_lambda_0_is_kept_and_the_schedule_takes_its_fractions():
    objective = Objective("l2", batch_size=1, regularizer_weight=3.0, min_fraction=0.1, decay_fraction=0.5)
    latent = FlatLatent(0.5, {"smooth": 4.0, "small": 0.5})
    objective(latent, black_batch(1), np.random.default_rng(0), 0, 100)
    assert objective.lambda_0 == {"smooth": 3.0, "small": 3.0}
    # k = 4 / (0.5 * 100)^2 = 0.0016
    expected = 3.0 * (0.1 + 0.9 * 10 ** (-0.0016 * 50 * 51 / 2))
    assert objective.weights(latent, 1.0, 50, 100) == pytest.approx({"smooth": expected, "small": expected})


def test_the_objective_state_carries_lambda_0():
    first = Objective("l2", batch_size=1)
    first(FlatLatent(0.5, {"smooth": 1.0, "small": 1.0}), black_batch(1), np.random.default_rng(0), 0, 10)
    resumed = Objective("l2", batch_size=1)
    resumed.load_state_dict(first.state_dict())
    resumed(FlatLatent(3.0, {"smooth": 1.0, "small": 1.0}), black_batch(1), np.random.default_rng(0), 5, 10)
    assert resumed.lambda_0 == first.lambda_0 == pytest.approx({"smooth": 0.0625, "small": 0.0625})


def test_the_objective_composites_over_backgrounds_drawn_from_the_rng_and_adds_the_outline_term():
    objective = Objective("l2", batch_size=2, outline_weight=2.0)
    latent = FlatLatent(0.0, {"smooth": 1.0, "small": 1.0}, alpha=0.0)  # empty: the background shows
    batch = black_batch(3, alpha=0.25)  # two shaded views and one outline view
    background = np.random.default_rng(7).uniform(0.0, 1.0, size=(2, 3))
    # composites: the background against 0.75 of it; outline: |0 - 0.25|
    image = float(np.mean((0.25 * background) ** 2))
    rng = np.random.default_rng(7)
    terms = objective(latent, batch, rng, 0, 10)
    assert terms.image == pytest.approx(image + 2.0 * 0.25, rel=1e-6)
    assert rng.uniform() == np.random.default_rng(7).uniform(size=7)[-1]  # drew the 2 x 3 colours, nothing more
