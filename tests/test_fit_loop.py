"""The optimisation loop with a toy differentiable "renderer" (no rasterizer needed):
convergence, NaN rollback, checkpoints, Ctrl-C and resume, determinism, time-budget planning,
outline views; the rolling view pool."""

from __future__ import annotations

import dataclasses
import copy
import math
import signal

import numpy as np
import pytest
import torch
from test_fit_latent import make_latent

from lookalike.asset import Mesh
from lookalike.errors import ConfigError
from lookalike.fit.checkpoint import CHECKPOINT_VERSION, Checkpointer, read_checkpoint
from lookalike.fit.from_settings import loop_settings, objective
from lookalike.settings import (
    COLD_START,
    WARM_START,
    Config,
)
from lookalike.settings import config_from_dict, config_to_dict
from lookalike.fit.loop import SNAPSHOT_EVERY, Fitter
from lookalike.fit.pacing import REPLAN_EVERY
from lookalike.fit.objective import Objective
from lookalike.fit.textured_mesh import TexturedMesh
from lookalike.fit.training_views import Batch
from lookalike.shading.camera import Camera
from lookalike.shading.light import PointLight
from lookalike.shading.pipeline import render_coverage

SIZE = 4


def toy_render(asset, camera, light):
    """``[B, S, S, 4]``: texel colour times the light's intensity plus a term in the first
    vertex's position, alpha 1. Differentiable in the textures and the positions (moving one
    vertex alone, so that the Laplacian regulariser has something to hold back)."""
    kd = asset.materials[0].kd.data[..., :3]
    shift = 0.05 * asset.mesh.v_pos[0]
    rgb = kd[None] * light.intensity[:, None, None, :] + shift
    return torch.cat([rgb, torch.ones_like(rgb[..., :1])], dim=-1)


class ToyMesh(TexturedMesh):
    """A ``TexturedMesh`` that draws itself with ``draw`` (``toy_render`` unless a test swaps
    it); its coverage is the real one."""

    draw = staticmethod(toy_render)

    def render(self, camera, light, resolution, pose=None):
        return self.draw(self.as_asset(), camera, light)


def toy_latent() -> ToyMesh:
    return make_latent(SIZE, cls=ToyMesh)


class ToySource:
    def __init__(self, truth: TexturedMesh):
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


def fitter(cfg: Config, draw=None, checkpointer=None, validate=None) -> Fitter:
    torch.manual_seed(1)
    truth, start = toy_latent(), toy_latent()
    if draw is not None:
        start.draw = draw
    return Fitter(start, ToySource(truth), objective(cfg), loop_settings(cfg, outline=True), validate=validate,
                  checkpointer=checkpointer)


def test_loss_goes_down_and_the_best_state_is_kept():
    fit = fitter(config(iterations=60))
    result = fit.run(progress=False)
    assert result.iterations == 60 and len(result.losses) == 60
    assert np.mean(result.losses[-10:]) < 0.3 * np.mean(result.losses[:5])
    assert fit.best.score > -math.inf
    assert not torch.equal(result.best.kd(), make_latent(SIZE).kd())


def test_the_validator_scores_at_the_start_every_few_steps_and_at_the_end_and_picks_the_best():
    seen = {}

    def validate(asset):
        iteration = fit.progress.iteration
        seen[iteration] = fit.latent.kd().detach().clone()
        return 30.0 if iteration == 20 else 20.0 + iteration / 100

    fit = fitter(config(iterations=47, validate_every=10), validate=validate)
    result = fit.run(progress=False)
    assert [i for i, _ in result.validation] == [0, 10, 20, 30, 40, 47]
    assert result.validation[2] == (20, 30.0) and result.validation[-1] == (47, pytest.approx(20.47))
    assert torch.equal(result.best.kd(), seen[20])
    assert not torch.equal(result.best.kd(), fit.latent.kd())


def test_the_progress_bar_shows_the_loss_and_the_latest_and_best_validation_scores(capsys):
    fit = fitter(config(iterations=12, validate_every=5), validate=lambda asset: 30.0 - fit.progress.iteration / 10)
    fit.run(progress=True)
    last_line = capsys.readouterr().err.strip().split("\r")[-1]
    assert "12/12" in last_line and "loss=" in last_line
    assert "val=29.00" in last_line and "best=30.00" in last_line  # last scored at step 10; the start is the best


def test_the_start_is_kept_when_no_later_state_scores_better():
    fit = fitter(config(iterations=12, validate_every=5), validate=lambda asset: -float(fit.progress.iteration))
    start = fit.latent.kd().detach().clone()
    result = fit.run(progress=False)
    assert [i for i, _ in result.validation] == [0, 5, 10, 12]
    assert torch.equal(result.best.kd(), start)


def test_same_seed_same_result_and_another_seed_differs():
    a = fitter(config(iterations=25, seed=3)).run(progress=False)
    b = fitter(config(iterations=25, seed=3)).run(progress=False)
    c = fitter(config(iterations=25, seed=4)).run(progress=False)
    assert a.losses == b.losses
    assert torch.equal(a.best.kd(), b.best.kd()) and torch.equal(a.best.v_pos, b.best.v_pos)
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

    fit = fitter(config(iterations=30), draw=poisoned)
    for _ in range(poisoned_call - 1):
        fit.step()
    snapshot = copy.deepcopy(fit.latent)
    snapshot.load_state_dict(fit._good[0])
    good_kd = snapshot.kd().detach()
    assert not torch.equal(good_kd, fit.latent.kd())  # moved on since the snapshot
    assert math.isnan(fit.step())
    assert torch.equal(fit.latent.kd(), good_kd)  # rolled back
    assert fit.progress.lr_scale == 0.5 and fit.progress.rollbacks == 1
    result = fit.run(progress=False)
    assert result.iterations == 30 and all(math.isfinite(v) for v in result.losses[poisoned_call:])
    assert torch.isfinite(result.best.kd()).all()


def backing_off_fitter(second_score: float, backoff: float = 0.5):
    """A fitter validating every 10 steps (30 dB at step 10, ``second_score`` at step 20, 31
    later), stepped to step 20; and the states it scored, by step."""
    seen = {}

    def validate(asset):
        i = fit.progress.iteration
        seen[i] = {"kd": fit.latent.kd().detach().clone(), "v_pos": fit.latent.v_pos.detach().clone()}
        return {10: 30.0, 20: second_score}.get(i, 31.0)

    fit = fitter(config(iterations=40, validate_every=10, position_backoff=backoff), validate=validate)
    for _ in range(20):
        fit.step()
    return fit, seen


def test_a_validation_far_below_the_best_returns_to_it_and_halves_the_position_rate():
    fit, seen = backing_off_fitter(29.4)
    assert fit.progress.position_scale == 0.5 and fit.progress.backoffs == 1
    assert torch.equal(fit.latent.kd(), seen[10]["kd"]) and torch.equal(fit.latent.v_pos, seen[10]["v_pos"])
    assert not torch.equal(seen[20]["v_pos"], seen[10]["v_pos"])
    assert not fit.optimizer.state[fit.latent.v_pos]  # the positions' moments forgotten
    fit.step()
    lr = {group["name"]: group["lr"] for group in fit.optimizer.param_groups}
    assert lr["positions"] / lr["textures"] == pytest.approx(0.5 * 0.01 / 0.05)
    result = fit.run(progress=False)
    assert result.backoffs == 1 and result.iterations == 40


@pytest.mark.parametrize("second_score, backoff", [(29.6, 0.5), (20.0, 0.0)])
def test_a_validation_within_the_margin_or_without_backoffs_keeps_the_rate_and_the_state(second_score, backoff):
    fit, seen = backing_off_fitter(second_score, backoff)
    assert fit.progress.position_scale == 1.0 and fit.progress.backoffs == 0
    assert torch.equal(fit.latent.v_pos, seen[20]["v_pos"])


def test_too_many_failures_in_a_row_stop_the_loop():
    fit = fitter(config(iterations=50, max_rollbacks=3), draw=lambda *a: toy_render(*a) * math.nan)
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
    cfg = config(iterations=24)
    first = fitter(cfg, draw=interrupting,
                   checkpointer=Checkpointer(path, every_seconds=3600, extra=lambda: {"config": config_to_dict(cfg)}))
    result = first.run(progress=False)
    assert result.interrupted and result.iterations == 13 and path.exists()

    state = read_checkpoint(path)
    cfg = config_from_dict(state["config"])
    assert cfg == config(iterations=24) and state["progress"]["iteration"] == 13
    torch.manual_seed(1)
    truth = toy_latent()  # the same reference as above
    latent = toy_latent()  # another start: the checkpoint replaces its state
    assert not torch.equal(latent.kd(), first.latent.kd())
    second = Fitter(latent, ToySource(truth), objective(cfg), loop_settings(cfg, outline=True),
                    checkpointer=Checkpointer(path, every_seconds=3600))
    second.load_state_dict(state)
    assert second.progress.iteration == 13
    assert second.objective.lambda_0 == straight_fit.objective.lambda_0  # set at step 0, not again now
    resumed = second.run(progress=False)
    assert resumed.iterations == 24 and resumed.losses == straight.losses
    assert torch.equal(second.latent.kd(), straight_fit.latent.kd())
    assert torch.equal(second.latent.v_pos, straight_fit.latent.v_pos)


def test_ctrl_c_during_a_step_stops_the_loop_after_that_step():
    """A SIGINT that arrives inside a step (here: while drawing the 14th view; its handler is
    called as Python would call it) lets the step finish, then stops the loop as Ctrl-C does."""
    calls = {"n": 0}

    def signalling(asset, camera, light):
        calls["n"] += 1
        if calls["n"] == 14:
            signal.getsignal(signal.SIGINT)(signal.SIGINT, None)
        return toy_render(asset, camera, light)

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        result = fitter(config(iterations=24), draw=signalling).run(progress=False)
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, previous)
    assert result.interrupted and result.iterations == 14 and len(result.losses) == 14


STEPS = REPLAN_EVERY + 16


def test_a_resume_from_a_periodic_checkpoint_continues_like_the_uninterrupted_run(tmp_path):
    """Written between steps (not on Ctrl-C), here after 10 of ``STEPS`` (none is written among
    the last ``REPLAN_EVERY``), with a validator's scores and the best state so far in it; the
    uninterrupted run is unaffected by writing it."""

    class AfterTenSteps(Checkpointer):
        asked = 0

        def due(self):
            self.asked += 1
            return self.asked == 10

    straight_fit = fitter(config(iterations=STEPS, validate_every=4), validate=lambda model: -float(model.kd().mean()))
    straight = straight_fit.run(progress=False)

    path = tmp_path / "checkpoint.pt"
    first = fitter(config(iterations=STEPS, validate_every=4), validate=lambda model: -float(model.kd().mean()),
                   checkpointer=AfterTenSteps(path, every_seconds=3600))
    assert first.run(progress=False).losses == straight.losses
    state = read_checkpoint(path)
    assert state["progress"]["iteration"] == 10 and len(state["best"]["validation"]) == 3

    torch.manual_seed(1)
    truth, latent = toy_latent(), toy_latent()
    cfg = config(iterations=STEPS, validate_every=4)
    second = Fitter(latent, ToySource(truth), objective(cfg), loop_settings(cfg, outline=True),
                    validate=lambda model: -float(model.kd().mean()))
    second.load_state_dict(state)
    resumed = second.run(progress=False)
    assert resumed.losses == straight.losses
    # the same scores: a resumed session does not score where it starts, so it keeps the same best
    assert resumed.validation == straight.validation
    assert torch.equal(resumed.best.kd(), straight.best.kd()) and torch.equal(second.latent.kd(), straight_fit.latent.kd())


def test_checkpoints_round_trip_with_their_extras_and_refuse_other_versions(tmp_path):
    path = tmp_path / "checkpoint.pt"
    checkpointer = Checkpointer(path, every_seconds=3600, extra=lambda: {"config": {"optim": {"seed": 3}}})
    assert not checkpointer.due()
    fit = fitter(config(iterations=3))
    fit.run(progress=False)
    checkpointer.save(fit.state_dict())
    state = read_checkpoint(path)
    assert state["version"] == CHECKPOINT_VERSION and state["config"] == {"optim": {"seed": 3}}
    assert state["progress"] == fit.progress.__dict__ and state["objective"] == fit.objective.state_dict()
    for name, value in fit.latent.state_dict().items():
        if isinstance(value, torch.Tensor):
            assert torch.equal(state["latent"][name], value), name
    assert [p.name for p in tmp_path.iterdir()] == ["checkpoint.pt"]  # no temporary left behind

    torch.save({**state, "version": CHECKPOINT_VERSION - 1}, path)
    with pytest.raises(ConfigError, match=f"not a lookalike checkpoint of version {CHECKPOINT_VERSION}"):
        read_checkpoint(path)
    torch.save([1, 2, 3], path)
    with pytest.raises(ConfigError, match="not a lookalike checkpoint"):
        read_checkpoint(path)
    path.write_bytes(b"not a checkpoint")
    with pytest.raises(ConfigError, match="cannot read the checkpoint"):
        read_checkpoint(path)


def test_a_checkpoint_is_written_when_due_and_not_before(tmp_path):
    """Nor among the plan's last ``REPLAN_EVERY`` steps (a pause there that the steps left
    could not make up for; ``pacing.closing``): a checkpoint due after every step is written
    after the steps that leave more to go."""

    class Counting(Checkpointer):
        def save(self, state):
            self.saves = getattr(self, "saves", 0) + 1
            super().save(state)

    never, always = Counting(tmp_path / "a.pt", every_seconds=3600), Counting(tmp_path / "b.pt", every_seconds=0.0)
    fitter(config(iterations=REPLAN_EVERY + 5), checkpointer=never).run(progress=False)
    fitter(config(iterations=REPLAN_EVERY + 5), checkpointer=always).run(progress=False)
    assert not hasattr(never, "saves") and not (tmp_path / "a.pt").exists()
    assert always.saves == 4 and read_checkpoint(tmp_path / "b.pt")["progress"]["iteration"] == 4


def test_under_a_time_budget_the_bar_counts_the_budgets_seconds_and_its_eta_only_counts_down(capsys):
    import re
    fit = fitter(config())
    fit.run(seconds_available=2.0, progress=True)
    pattern = re.compile(r"(\d+)/(\d+) s \[\d\d:\d\d<(\d\d):(\d\d)")
    lines = [line for line in capsys.readouterr().err.split("\r") if pattern.search(line)]
    shown = [pattern.search(line).groups() for line in lines]
    assert len(shown) >= 3 and {total for _, total, _, _ in shown} == {"2"}
    remaining = [60 * int(m) + int(s) for _, _, m, s in shown]
    assert remaining == sorted(remaining, reverse=True) and remaining[-1] == 0
    assert f"step={fit.progress.iteration}/{fit.progress.total}" in lines[-1]


def test_the_time_budget_fixes_the_iteration_count():
    fit = fitter(config())
    result = fit.run(seconds_available=1.0, progress=False)
    assert fit.progress.total == result.iterations
    assert 5 < result.iterations
    assert result.seconds < 2.0


class PositionTarget:
    """A fake reference renderer: each image is filled with its camera's position."""

    def render(self, camera, light, resolution, spp, pose=None):
        image = torch.cat([camera.position, light.position[:, :1]], dim=-1)[:, None, None, :]
        return image.expand(-1, resolution, resolution, 4)


def test_the_rolling_pool_refreshes_and_rebuilds_from_its_state():
    from mesh_factory import icosphere

    from lookalike.fit.training_views import ViewPool, view_sampler

    sampler = view_sampler(*icosphere(1).bounding_sphere())
    pool = ViewPool(PositionTarget(), sampler, size=4, seed=(7, 1), refresh_every=2, resolution=2)
    first = pool.images.clone()
    rng = np.random.default_rng(0)
    for _ in range(7):
        batch = pool.sample(rng, 2)
        assert torch.equal(batch.target[:, 0, 0, :3], batch.camera.position.half().float())
    assert pool.drawn == 4 + 3 and (pool.images != first).any(dim=(1, 2, 3)).sum() == 3
    rebuilt = ViewPool(PositionTarget(), sampler, size=4, seed=(7, 1), refresh_every=2, resolution=2)
    rebuilt.load_state_dict(pool.state_dict())
    assert torch.equal(rebuilt.images, pool.images) and torch.equal(rebuilt.camera.mv, pool.camera.mv)
    assert torch.equal(rebuilt.light.position, pool.light.position)
    assert torch.equal(rebuilt.sample(np.random.default_rng(1), 2).target, pool.sample(np.random.default_rng(1), 2).target)


class CountingSource(ToySource):
    """``ToySource`` that records how many views each step asks for."""

    def __init__(self, truth: TexturedMesh):
        super().__init__(truth)
        self.sizes = []

    def sample(self, rng: np.random.Generator, batch_size: int) -> Batch:
        self.sizes.append(batch_size)
        return super().sample(rng, batch_size)


def test_outline_views_come_with_the_batch_and_add_a_coverage_term():
    cfg = config(outline_views=3, outline_weight=2.0)
    torch.manual_seed(1)
    start = make_latent(SIZE, cls=ToyMesh, msaa=cfg.render.latent_msaa)
    source = CountingSource(toy_latent())
    fit = Fitter(start, source, objective(cfg), loop_settings(cfg, outline=True))
    fit.step()
    assert source.sizes == [2 + 3]
    batch = source.sample(np.random.default_rng(0), 5)
    background = torch.zeros(2, 3)
    shaded, outline = batch.split(2)
    with torch.no_grad():
        with_outline = fit.objective.image_loss(start, batch, background)
        plain = fit.objective.image_loss(start, shaded, background)
        coverage = render_coverage(Mesh(v_pos=start.world_positions(), t_pos_idx=start.t_pos_idx), outline.camera,
                                   outline.target.shape[1:3], cfg.render.latent_msaa)
    assert outline.camera.batch_size == 3 and coverage.mean() < 1
    assert torch.allclose(with_outline, plain + 2.0 * (1 - coverage).mean())  # the toy targets are opaque


class FlatLatent(torch.nn.Module):
    """The smallest ``Latent``: one grey colour ``value`` at full coverage, regularised towards 0."""

    def __init__(self):
        super().__init__()
        self.value = torch.nn.Parameter(torch.tensor(0.9))
        self.fractions = []

    def parameter_groups(self):
        return {"colour": [self.value]}

    def render(self, camera, light, resolution, pose=None):
        rgb = self.value.expand(camera.batch_size, resolution, resolution, 3)
        return torch.cat([rgb, torch.ones_like(rgb[..., :1])], dim=-1)

    def coverage(self, camera, resolution, pose=None):
        return None

    def clamp_(self):
        with torch.no_grad():
            self.value.clamp_(0.0, 0.6)

    def at_progress(self, fraction):
        self.fractions.append(fraction)

    def regularizers(self):
        return {"size": self.value ** 2}

    def regularizer_scales(self):
        return {"size": 1.0}


class GreySource(ToySource):
    """References of grey 0.25 at full coverage."""

    def __init__(self):
        pass

    def sample(self, rng, batch_size):
        eye = torch.from_numpy(rng.normal(size=(batch_size, 3)).astype(np.float32)) + 3
        camera = Camera.looking_at(eye, torch.zeros_like(eye))
        light = PointLight(position=eye, intensity=torch.ones(batch_size, 3))
        target = torch.full((batch_size, 2, 2, 4), 0.25)
        target[..., 3] = 1
        return Batch(camera, light, target)


def test_the_loop_optimises_any_latent_by_its_own_groups_and_clamps():
    latent = FlatLatent()
    settings = dataclasses.replace(loop_settings(Config(), outline=False), learning_rates={"colour": 0.02},
                                   iterations=150, lr_decades=0.0)
    fit = Fitter(latent, GreySource(), Objective("l2", batch_size=1, regularizer_weight=0.0), settings)
    assert [group["lr"] for group in fit.optimizer.param_groups] == [0.02]
    fit.step()
    assert latent.value.item() == pytest.approx(0.6)  # clamped after the first step
    result = fit.run(progress=False)
    assert float(result.best.value) == pytest.approx(0.25, abs=0.03) and not result.best.value.requires_grad
    assert result.losses[-1] < 1e-3 < result.losses[0]
    assert latent.fractions == [k / 150 for k in range(150)]   # the latent follows the run's schedule, step by step
