"""The optimisation loop with a toy differentiable "renderer" (no rasterizer needed):
convergence, NaN rollback, Ctrl-C checkpoint and resume, determinism, time-budget planning."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from lookalike.fit.config import COLD_START, WARM_START, Config, config_from_dict
from lookalike.fit.latent import Latent
from lookalike.fit.optimize import SNAPSHOT_EVERY, Batch, Fitter, read_checkpoint
from lookalike.shading.camera import Camera
from lookalike.shading.light import PointLight
from lookalike.shading.pipeline import render_coverage

from test_fit_latent import make_latent

SIZE = 4


def toy_render(asset, camera, light):
    """``[B, S, S, 4]``: texel colour times the light's intensity plus a term in the mean
    vertex position, alpha 1. Differentiable in the textures and the positions."""
    kd = asset.materials[0].kd.data[..., :3]
    shift = 0.05 * asset.mesh.v_pos.mean(dim=0)
    rgb = kd[None] * light.intensity[:, None, None, :] + shift
    return torch.cat([rgb, torch.ones_like(rgb[..., :1])], dim=-1)


class ToySource:
    def __init__(self, truth: Latent):
        self.truth = truth

    def sample(self, rng: np.random.Generator, batch_size: int) -> Batch:
        eye = torch.from_numpy(rng.normal(size=(batch_size, 3)).astype(np.float32)) + 3
        camera = Camera.looking_at(eye, torch.zeros_like(eye))
        light = PointLight(position=eye, intensity=torch.from_numpy(rng.uniform(0.5, 2, (batch_size, 3)).astype(np.float32)))
        with torch.no_grad():
            return Batch(camera, light, toy_render(self.truth.as_asset(), camera, light))

    def state_dict(self) -> dict:
        return {}

    def load_state_dict(self, state: dict) -> None:
        pass


def config(**optim) -> Config:
    return config_from_dict({"optim": {"lr_textures": 0.05, "lr_positions": 0.01, "outline_views": 0, **optim},
                             "views": {"batch_size": 2}})


def fitter(cfg: Config, render=toy_render, checkpoint=None, validate=None) -> Fitter:
    torch.manual_seed(1)
    truth, start = make_latent(SIZE), make_latent(SIZE)
    return Fitter(start, ToySource(truth), render, cfg, checkpoint=checkpoint, validate=validate)


def test_loss_goes_down_and_the_best_state_is_kept():
    fit = fitter(config(iterations=60))
    result = fit.run(progress=False)
    assert result.iterations == 60 and len(result.losses) == 60
    assert np.mean(result.losses[-10:]) < 0.3 * np.mean(result.losses[:5])
    assert fit.progress.best_score > -math.inf
    assert not torch.equal(result.best.kd, make_latent(SIZE).kd)


def test_the_validator_scores_at_the_start_every_few_steps_and_at_the_end_and_picks_the_best():
    seen = {}

    def validate(asset):
        iteration = fit.progress.iteration
        seen[iteration] = fit.latent.kd.detach().clone()
        return 30.0 if iteration == 20 else 20.0 + iteration / 100

    fit = fitter(config(iterations=47, validate_every=10), validate=validate)
    result = fit.run(progress=False)
    assert [i for i, _ in result.validation] == [0, 10, 20, 30, 40, 47]
    assert result.validation[2] == (20, 30.0) and result.validation[-1] == (47, pytest.approx(20.47))
    assert torch.equal(result.best.kd, seen[20])
    assert not torch.equal(result.best.kd, fit.latent.kd)


def test_the_progress_bar_shows_the_loss_and_the_latest_and_best_validation_scores(capsys):
    fit = fitter(config(iterations=12, validate_every=5), validate=lambda asset: 30.0 - fit.progress.iteration / 10)
    fit.run(progress=True)
    last_line = capsys.readouterr().err.strip().split("\r")[-1]
    assert "12/12" in last_line and "loss=" in last_line
    assert "val=29.00" in last_line and "best=30.00" in last_line  # last scored at step 10; the start is the best


def test_the_start_is_kept_when_no_later_state_scores_better():
    fit = fitter(config(iterations=12, validate_every=5), validate=lambda asset: -float(fit.progress.iteration))
    start = fit.latent.kd.clone()
    result = fit.run(progress=False)
    assert [i for i, _ in result.validation] == [0, 5, 10, 12]
    assert torch.equal(result.best.kd, start)


def test_same_seed_same_result_and_another_seed_differs():
    a = fitter(config(iterations=25, seed=3)).run(progress=False)
    b = fitter(config(iterations=25, seed=3)).run(progress=False)
    c = fitter(config(iterations=25, seed=4)).run(progress=False)
    assert a.losses == b.losses
    assert torch.equal(a.best.kd, b.best.kd) and torch.equal(a.best.v_pos, b.best.v_pos)
    assert a.losses != c.losses


@pytest.mark.parametrize("init, decades", [("bake", WARM_START.lr_decades), ("random", COLD_START.lr_decades)])
def test_the_learning_rates_fall_over_the_run_by_the_decades_of_the_start(init, decades):
    cfg = config(iterations=100)
    cfg.latent.init = init
    fit = fitter(cfg)
    for _ in range(51):
        fit.step()
    scale = 10 ** (-decades * 50 / 100)
    assert [group["lr"] for group in fit.optimizer.param_groups] == pytest.approx([0.01 * scale, 0.05 * scale])
    assert WARM_START.lr_decades < COLD_START.lr_decades


def test_a_nan_step_rolls_back_lowers_the_learning_rate_and_carries_on():
    calls = {"n": 0}
    poisoned_call = SNAPSHOT_EVERY + 4  # a few steps after the first snapshot

    def poisoned(asset, camera, light):
        calls["n"] += 1
        image = toy_render(asset, camera, light)
        return image * math.nan if calls["n"] == poisoned_call else image

    fit = fitter(config(iterations=30), render=poisoned)
    for _ in range(poisoned_call - 1):
        fit.step()
    good_kd = fit._good[0]["kd"].clone()
    assert not torch.equal(good_kd, fit.latent.kd)  # moved on since the snapshot
    assert math.isnan(fit.step())
    assert torch.equal(fit.latent.kd, good_kd)  # rolled back
    assert fit.progress.lr_scale == 0.5 and fit.progress.rollbacks == 1
    result = fit.run(progress=False)
    assert result.iterations == 30 and all(math.isfinite(v) for v in result.losses[poisoned_call:])
    assert torch.isfinite(result.best.kd).all()


def test_too_many_failures_in_a_row_stop_the_loop():
    fit = fitter(config(iterations=50, max_rollbacks=3), render=lambda *a: toy_render(*a) * math.nan)
    result = fit.run(progress=False)
    assert result.iterations == 3 and result.rollbacks == 3


def test_ctrl_c_writes_a_checkpoint_and_resume_continues_exactly(tmp_path):
    straight_fit = fitter(config(iterations=24))
    straight = straight_fit.run(progress=False)

    calls = {"n": 0}

    def interrupting(asset, camera, light):
        calls["n"] += 1
        if calls["n"] == 14:
            raise KeyboardInterrupt
        return toy_render(asset, camera, light)

    path = tmp_path / "checkpoint.pt"
    first = fitter(config(iterations=24), render=interrupting, checkpoint=path)
    result = first.run(progress=False)
    assert result.interrupted and result.iterations == 13 and path.exists()

    state, cfg, latent = read_checkpoint(path)
    assert cfg == config(iterations=24) and state["progress"]["iteration"] == 13
    torch.manual_seed(1)
    second = Fitter(latent, ToySource(make_latent(SIZE)), toy_render, cfg, checkpoint=path)
    second.load_state_dict(state)
    assert second.progress.iteration == 13
    resumed = second.run(progress=False)
    assert resumed.iterations == 24 and resumed.losses == straight.losses
    assert torch.equal(second.latent.kd, straight_fit.latent.kd)
    assert torch.equal(second.latent.v_pos, straight_fit.latent.v_pos)


def test_the_time_budget_fixes_the_iteration_count():
    fit = fitter(config())
    result = fit.run(seconds_available=0.5, progress=False)
    assert fit.progress.total == result.iterations
    assert 5 < result.iterations
    assert result.seconds < 1.5


class PositionTarget:
    """A fake reference renderer: each image is filled with its camera's position."""

    def render(self, camera, light):
        return torch.cat([camera.position, light.position[:, :1]], dim=-1)[:, None, None, :].expand(-1, 2, 2, 4)


def test_the_rolling_pool_refreshes_and_rebuilds_from_its_state():
    from lookalike.fit.targets import ViewPool
    from lookalike.fit.views import view_sampler
    from mesh_factory import icosphere

    sampler = view_sampler(icosphere(1))
    pool = ViewPool(PositionTarget(), sampler, size=4, seed=(7, 1), refresh_every=2)
    first = pool.images.clone()
    rng = np.random.default_rng(0)
    for _ in range(7):
        batch = pool.sample(rng, 2)
        assert torch.equal(batch.target[:, 0, 0, :3], batch.camera.position.half().float())
    assert pool.drawn == 4 + 3 and (pool.images != first).any(dim=(1, 2, 3)).sum() == 3
    rebuilt = ViewPool(PositionTarget(), sampler, size=4, seed=(7, 1), refresh_every=2)
    rebuilt.load_state_dict(pool.state_dict())
    assert torch.equal(rebuilt.images, pool.images) and torch.equal(rebuilt.camera.mv, pool.camera.mv)
    assert torch.equal(rebuilt.light.position, pool.light.position)
    assert torch.equal(rebuilt.sample(np.random.default_rng(1), 2).target, pool.sample(np.random.default_rng(1), 2).target)


class CountingSource(ToySource):
    """``ToySource`` that records how many views each step asks for."""

    def __init__(self, truth: Latent):
        super().__init__(truth)
        self.sizes = []

    def sample(self, rng: np.random.Generator, batch_size: int) -> Batch:
        self.sizes.append(batch_size)
        return super().sample(rng, batch_size)


def test_outline_views_come_with_the_batch_and_add_a_coverage_term():
    cfg = config(outline_views=3, outline_weight=2.0)
    torch.manual_seed(1)
    start = make_latent(SIZE)
    source = CountingSource(make_latent(SIZE))
    fit = Fitter(start, source, toy_render, cfg)
    fit.step()
    assert source.sizes == [2 + 3]
    batch = source.sample(np.random.default_rng(0), 5)
    background = torch.zeros(2, 3)
    shaded, outline = batch.split(2)
    with torch.no_grad():
        with_outline, _ = fit.loss(batch, background)
        plain, _ = fit.loss(shaded, background)
        coverage = render_coverage(start.as_asset().mesh, outline.camera, outline.target.shape[1:3],
                                   cfg.render.latent_msaa)
    assert outline.camera.batch_size == 3 and coverage.mean() < 1
    assert torch.allclose(with_outline, plain + 2.0 * (1 - coverage).mean())  # the toy targets are opaque


@pytest.mark.parametrize("pool, alpha_mode, expected", [(0, "OPAQUE", 3), (16, "OPAQUE", 3), (4, "OPAQUE", 2),
                                                        (16, "BLEND", 0)])
def test_outline_views_fit_the_pool_and_skip_latents_with_alpha(pool, alpha_mode, expected):
    cfg = config_from_dict({"optim": {"outline_views": 3}, "views": {"batch_size": 2, "pool_size": pool}})
    latent = make_latent(SIZE)
    latent.alpha_mode = alpha_mode
    assert Fitter(latent, ToySource(make_latent(SIZE)), toy_render, cfg).outline_count == expected
