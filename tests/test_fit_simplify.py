"""``simplify`` end to end on a tiny generated asset, and its refusals."""

from __future__ import annotations

import dataclasses
import json
import signal
import subprocess
import sys
import time

import pytest
import torch

from lookalike import io
from lookalike.asset import Asset, Material, Texture
from lookalike.cli import main
from lookalike.errors import ConfigError
from lookalike.settings import config_from_dict, load_config
from lookalike.jobs import simplify as simplify_job
from lookalike.jobs.simplify import simplify
from interrupt_factory import ctrl_c_at
from mesh_factory import icosphere

TINY = {"views": {"pool_size": 16, "refresh_every": 2, "heldout": 16, "batch_size": 2},
        "render": {"resolution": 64}, "latent": {"texture_size": 64},
        "optim": {"checkpoint_seconds": 1e9}}


def bumpy_sphere() -> Asset:
    """A 5,120-triangle sphere with bumps of 8 % of its radius, one plain material."""
    mesh = icosphere(4)
    p = mesh.v_pos
    mesh.v_pos = p * (1 + 0.08 * torch.sin(6 * p[:, 0]) * torch.sin(6 * p[:, 1]) * torch.sin(6 * p[:, 2]))[:, None]
    material = Material(kd=Texture.constant([0.6, 0.5, 0.4, 1.0]), ks=Texture.constant([0.0, 0.4, 0.0]))
    return Asset(mesh=mesh, materials=[material])


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    outdir = tmp_path_factory.mktemp("run") / "out"
    result = simplify(bumpy_sphere(), outdir, triangles=300, iterations=60, config=config_from_dict(TINY),
                      progress=False)
    return outdir, result


def test_the_optimised_model_beats_plain_decimation_on_held_out_views(tiny_run):
    _, result = tiny_run
    heldout = result.metrics["heldout"]
    assert heldout["views"] == 16
    assert heldout["ours"]["psnr"] > heldout["decimated"]["psnr"] + 1.5
    assert heldout["ours"]["flip"] < heldout["decimated"]["flip"]
    assert 0 < heldout["silhouette_pixels"] < 0.5  # a band around the sphere's outline (few pixels: 64 px views)
    for method in ("decimated", "ours"):
        assert 0 < heldout[method]["silhouette_error"] < 1


def test_the_run_validates_its_states_and_keeps_the_best(tiny_run):
    _, result = tiny_run
    curve = result.metrics["validation"]
    assert curve["views"] == 4 and curve["iterations"] == [0, 25, 50, 60]
    assert max(curve["psnr"]) > curve["psnr"][0] + 0.1


def test_outputs_are_complete_and_nothing_temporary_is_left(tiny_run):
    outdir, result = tiny_run
    names = sorted(p.name for p in outdir.iterdir())
    assert names == ["config.toml", "metrics.json", "model.glb", "report.html", "report_files"]
    model = io.load(outdir / "model.glb")
    assert model.mesh.num_triangles == 300
    # an untextured input keeps one base colour; the relief goes into the normal map
    assert model.materials[0].kd.data.shape[:2] == (1, 1) and model.materials[0].normal.data.shape[:2] == (64, 64)
    assert json.loads((outdir / "metrics.json").read_text()) == result.metrics
    config = load_config(outdir / "config.toml")
    assert config.latent.triangles == 300 and config.optim.iterations == 60 and config.render.resolution == 64
    assert not result.interrupted and result.metrics["iterations"] == 60


def test_the_model_keeps_the_inputs_frame(tmp_path):
    asset = bumpy_sphere()
    asset.mesh.v_pos = asset.mesh.v_pos * 250.0 + torch.tensor([1000.0, -40.0, 7.0])
    cfg = config_from_dict({**TINY, "views": {"pool_size": 2, "heldout": 1, "batch_size": 1}})
    simplify(asset, tmp_path / "out", triangles=100, iterations=2, config=cfg, progress=False)
    model = io.load(tmp_path / "out" / "model.glb")
    lo, hi = model.mesh.bounds()
    want_lo, want_hi = asset.mesh.bounds()
    assert torch.allclose(lo, want_lo, atol=15.0) and torch.allclose(hi, want_hi, atol=15.0)


def test_profile_records_where_the_time_goes(tmp_path, capsys):
    source = tmp_path / "ball.glb"
    io.save(bumpy_sphere(), source)
    cfg = tmp_path / "tiny.toml"
    cfg.write_text("[views]\npool_size = 2\nheldout = 1\nbatch_size = 1\nvalidation = 1\n"
                   "[render]\nresolution = 64\n[latent]\ntexture_size = 64\n")
    assert main(["simplify", str(source), "-o", str(tmp_path / "out"), "--triangles", "100", "--iterations", "3",
                 "--config", str(cfg), "--quiet", "--profile"]) == 0
    profile = json.loads((tmp_path / "out" / "metrics.json").read_text())["profile"]
    for path in ("load and initial guess > load", "load and initial guess > decimation",
                 "load and initial guess > bake", "reference views", "optimisation > forward",
                 "optimisation > backward", "optimisation > update", "scoring ours"):
        assert profile[path]["wall_s"] > 0 and profile[path]["cpu_s"] >= 0, path
    assert profile["optimisation > forward"]["calls"] == 3
    assert profile["optimisation"]["wall_s"] >= profile["optimisation > backward"]["wall_s"]
    assert "where the time went" in capsys.readouterr().out


@pytest.mark.parametrize("kwargs, words", [
    ({"triangles": 0}, "must be positive"),
    ({"triangles": -3}, "must be positive"),
    ({"triangles": 5120}, "not below the input's 5,120 triangles"),
    ({"triangles": 9000}, "not below"),
    ({"ratio": 1.5}, "latent.ratio must lie in (0, 1)"),
    ({"ratio": 1e-6}, "leaves no triangles"),
])
def test_bad_triangle_counts_are_refused_before_anything_is_written(tmp_path, kwargs, words):
    with pytest.raises(ConfigError) as info:
        simplify(bumpy_sphere(), tmp_path / "out", progress=False, **kwargs)
    assert words in str(info.value)
    assert not (tmp_path / "out").exists()


def test_an_existing_outdir_is_never_overwritten_without_force(tmp_path):
    (tmp_path / "keep.txt").write_text("mine")
    with pytest.raises(ConfigError, match="--force"):
        simplify(bumpy_sphere(), tmp_path, triangles=100, progress=False)
    with pytest.raises(ConfigError, match="nothing to resume"):
        simplify(bumpy_sphere(), tmp_path, triangles=100, resume=True, progress=False)
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]


def test_ctrl_c_leaves_the_best_result_and_a_checkpoint_that_resume_finishes(tmp_path, monkeypatch):
    outdir = tmp_path / "out"
    cfg = config_from_dict({**TINY, "views": {"pool_size": 4, "heldout": 2, "batch_size": 1}})
    ctrl_c_at(monkeypatch, 5)
    first = simplify(bumpy_sphere(), outdir, triangles=100, iterations=8, config=cfg, progress=False)
    assert first.interrupted and first.metrics["iterations"] == 5
    assert (outdir / "checkpoint.pt").exists() and (outdir / "model.glb").exists()
    monkeypatch.undo()
    with pytest.raises(ConfigError, match="--force"):
        simplify(bumpy_sphere(), outdir, triangles=100, progress=False)
    whole = simplify(bumpy_sphere(), tmp_path / "whole", triangles=100, iterations=8, config=cfg, progress=False)
    monkeypatch.setattr(simplify_job, "SIMPLIFY", dataclasses.replace(simplify_job.SIMPLIFY, initial_guess=_no_second_initial_guess))
    second = simplify(bumpy_sphere(), outdir, resume=True, progress=False)
    assert not second.interrupted and second.metrics["iterations"] == 8
    assert not (outdir / "checkpoint.pt").exists()
    assert second.metrics["validation"]["psnr"][-1] == whole.metrics["validation"]["psnr"][-1]
    assert second.metrics["heldout"]["ours"] == whole.metrics["heldout"]["ours"]
    resumed, uninterrupted = io.load(second.model), io.load(whole.model)
    assert torch.equal(resumed.mesh.v_pos, uninterrupted.mesh.v_pos)
    assert torch.equal(resumed.materials[0].kd.data, uninterrupted.materials[0].kd.data)


def _no_second_initial_guess(*args, **kwargs):
    raise AssertionError("a resumed run must take its initial guess from the checkpoint")


def test_a_killed_run_can_resume_from_the_checkpoint_written_after_the_initial_guess(tmp_path, monkeypatch):
    """SIGKILL as soon as the first checkpoint exists (before any step): the resumed run takes
    the initial guess from it and finishes."""
    source = tmp_path / "ball.glb"
    io.save(bumpy_sphere(), source)
    (tmp_path / "run.toml").write_text("[views]\npool_size = 4\nheldout = 2\nbatch_size = 1\n[render]\n"
                                       "resolution = 64\n[latent]\ntexture_size = 64\n")
    outdir = tmp_path / "out"
    process = subprocess.Popen([sys.executable, "-m", "lookalike.cli", "simplify", str(source), "-o", str(outdir),
                                "--triangles", "100", "--iterations", "4", "--config", str(tmp_path / "run.toml"),
                                "--quiet"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 300
    while not (outdir / "checkpoint.pt").exists() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    process.send_signal(signal.SIGKILL)
    process.wait(timeout=60)
    assert (outdir / "checkpoint.pt").exists() and not (outdir / "model.glb").exists()
    monkeypatch.setattr(simplify_job, "SIMPLIFY", dataclasses.replace(simplify_job.SIMPLIFY, initial_guess=_no_second_initial_guess))
    resumed = simplify(source, outdir, resume=True, progress=False)
    assert resumed.metrics["iterations"] == 4 and (outdir / "model.glb").exists()


def test_the_command_line_reports_bad_input_without_a_traceback(tmp_path, capsys):
    path = tmp_path / "ball.obj"
    io.save(bumpy_sphere(), path)
    assert main(["simplify", str(path), "-o", str(tmp_path / "out"), "--triangles", "0"]) == 2
    assert "target triangle count must be positive" in capsys.readouterr().err
    assert main(["simplify", str(path), "--time-budget", "soon"]) == 2
    assert "cannot read the duration" in capsys.readouterr().err


def test_same_seed_same_model(tmp_path):
    cfg = config_from_dict({**TINY, "views": {"pool_size": 4, "heldout": 1, "batch_size": 2}})
    runs = [simplify(bumpy_sphere(), tmp_path / name, triangles=100, iterations=6, seed=seed, config=cfg, progress=False)
            for name, seed in (("a", 5), ("b", 5), ("c", 6))]
    models = [io.load(run.model) for run in runs]
    assert torch.equal(models[0].mesh.v_pos, models[1].mesh.v_pos)
    assert torch.equal(models[0].materials[0].kd.data, models[1].materials[0].kd.data)
    assert runs[0].metrics["heldout"]["ours"] == runs[1].metrics["heldout"]["ours"]
    assert not torch.equal(models[0].mesh.v_pos, models[2].mesh.v_pos)
