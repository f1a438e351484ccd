"""Runs that survive schedulers, signals and full disks (issue 17): each test reproduces one of
the ways a run used to go wrong around the job."""

from __future__ import annotations

import dataclasses
import errno
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
import torch

from lookalike import io, kernel_cache
from lookalike.cli import main
from lookalike.errors import ConfigError
from lookalike.fit.checkpoint import read_checkpoint
from lookalike.settings import config_from_dict
from lookalike.fit.loop import Fitter
from lookalike.jobs import outputs
from lookalike.jobs.simplify import simplify
from log_capture import expect_warning
from test_fit_simplify import TINY, bumpy_sphere

SMALL = {**TINY, "views": {"pool_size": 4, "heldout": 2, "batch_size": 1, "validation": 2}}


def interrupt_at(monkeypatch, iteration: int) -> None:
    """Make ``Fitter.step`` raise ``KeyboardInterrupt`` when it reaches ``iteration``."""
    step = Fitter.step

    def interrupted(self):
        if self.progress.iteration == iteration:
            raise KeyboardInterrupt
        return step(self)

    monkeypatch.setattr(Fitter, "step", interrupted)


def test_resume_refuses_a_different_input_and_names_both(tmp_path, monkeypatch):
    ball, other = tmp_path / "ball.glb", tmp_path / "other.glb"
    io.save(bumpy_sphere(), ball)
    different = bumpy_sphere()
    different.mesh.v_pos = different.mesh.v_pos * 1.5
    io.save(different, other)
    interrupt_at(monkeypatch, 2)
    simplify(ball, tmp_path / "out", triangles=100, iterations=6, config=config_from_dict(SMALL), progress=False)
    before = sorted(p.name for p in (tmp_path / "out").iterdir())
    with pytest.raises(ConfigError) as info:
        simplify(other, tmp_path / "out", resume=True, progress=False)
    assert str(ball) in str(info.value) and str(other) in str(info.value)
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == before


def test_resume_says_which_given_options_it_ignores(tmp_path, monkeypatch, caplog):
    interrupt_at(monkeypatch, 2)
    simplify(bumpy_sphere(), tmp_path / "out", triangles=100, iterations=4, config=config_from_dict(SMALL),
             progress=False)
    with expect_warning(caplog, "ignored: --triangles 60 (the run has 100), --seed 3 (the run has 0)"):
        resumed = simplify(bumpy_sphere(), tmp_path / "out", triangles=60, seed=3, iterations=4, resume=True,
                           progress=False)
    assert resumed.metrics["triangles"]["output"] == 100


def test_the_time_budget_is_a_total_across_resumes_unless_given_again(tmp_path, monkeypatch):
    granted = []
    run = Fitter.run

    def recording(self, seconds_available=None, progress=True):
        granted.append(seconds_available)
        return run(self, seconds_available=seconds_available, progress=progress)

    interrupt_at(monkeypatch, 6)
    monkeypatch.setattr(Fitter, "run", recording)
    cfg = config_from_dict({**SMALL, "optim": {**SMALL["optim"], "time_budget": 1000.0}})
    simplify(bumpy_sphere(), tmp_path / "out", triangles=100, config=cfg, progress=False)
    used = read_checkpoint(tmp_path / "out" / "checkpoint.pt")["seconds_used"]
    assert used > 0
    simplify(bumpy_sphere(), tmp_path / "out", resume=True, progress=False)
    assert granted[1] < 1000.0 - used and granted[1] > 900.0
    simplify(bumpy_sphere(), tmp_path / "out", resume=True, time_budget=40.0, progress=False)
    assert granted[2] < 40.0


def test_sigterm_saves_like_ctrl_c_and_exits_143(tmp_path):
    source = tmp_path / "ball.glb"
    io.save(bumpy_sphere(), source)
    (tmp_path / "run.toml").write_text("[views]\npool_size = 4\nheldout = 2\nvalidation = 2\n[render]\nresolution = 32\n"
                                       "[latent]\ntexture_size = 32\n")
    log = tmp_path / "stderr.txt"
    with open(log, "w") as stderr:
        process = subprocess.Popen([sys.executable, "-m", "lookalike.cli", "simplify", str(source), "-o",
                                    str(tmp_path / "out"), "--triangles", "100", "--iterations", "100000",
                                    "--config", str(tmp_path / "run.toml")], stderr=stderr, stdout=subprocess.PIPE)
        deadline = time.monotonic() + 300
        while "optimising" not in log.read_text() and time.monotonic() < deadline and process.poll() is None:
            time.sleep(0.2)
        time.sleep(1.0)
        process.send_signal(signal.SIGTERM)
        assert process.wait(timeout=300) == 143
    assert (tmp_path / "out" / "checkpoint.pt").is_file() and (tmp_path / "out" / "model.glb").is_file()
    assert json.loads((tmp_path / "out" / "metrics.json").read_text())["interrupted"]
    assert "--resume" in process.stdout.read().decode()


@pytest.mark.parametrize("argv, words", [
    (["simplify", "IN", "--texture-size", "65536"], "must lie in [4, 4096]"),
    (["simplify", "IN", "--resolution", "100000"], "must lie in [16, 2048]"),
    (["bake", "IN", "--texture-size", "65536"], "must lie in [4, 8192]"),
    (["render", "IN", "-o", "OUT", "--views", "5000"], "--views must lie in [1, 1024]"),
])
def test_options_that_allocate_have_limits(tmp_path, capsys, argv, words):
    source = tmp_path / "ball.obj"
    io.save(bumpy_sphere(), source)
    argv = [str(source) if a == "IN" else str(tmp_path / "pictures") if a == "OUT" else a for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert words in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "ball-lookalike").exists() and not (tmp_path / "ball-baked").exists()


def test_os_errors_on_output_paths_are_one_line_errors(tmp_path, capsys):
    source = tmp_path / "ball.obj"
    io.save(bumpy_sphere(), source)
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    assert main(["render", str(source), "-o", str(blocker)]) == 2
    assert "is not a folder" in capsys.readouterr().err
    assert main(["simplify", str(source), "-o", str(blocker / "out"), "--iterations", "1"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("lookalike simplify: error: ") and len(err.strip().splitlines()) == 1
    assert "Traceback" not in err


def test_a_full_disk_while_writing_outputs_leaves_the_folder_as_it_was(tmp_path, monkeypatch, capsys):
    source = tmp_path / "ball.obj"
    io.save(bumpy_sphere(), source)
    (tmp_path / "run.toml").write_text("[views]\npool_size = 4\nheldout = 2\n[render]\nresolution = 32\n"
                                       "[latent]\ntexture_size = 32\n")

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device", str(tmp_path / "out" / "report.html"))

    monkeypatch.setattr(outputs, "write_report", full)
    argv = ["simplify", str(source), "-o", str(tmp_path / "out"), "--triangles", "100", "--iterations", "2",
            "--config", str(tmp_path / "run.toml"), "--quiet"]
    assert main(argv) == 2
    assert "No space left on device" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()                     # a fresh run's folder is gone again
    monkeypatch.undo()
    assert main(argv) == 0                                     # and the retry needs no --force


def test_force_then_an_early_interrupt_keeps_the_old_outputs_together(tmp_path, monkeypatch):
    cfg = config_from_dict(SMALL)
    first = simplify(bumpy_sphere(), tmp_path / "out", triangles=100, iterations=2, config=cfg, progress=False)
    old = {name: (tmp_path / "out" / name).read_bytes() for name in ("config.toml", "metrics.json", "model.glb")}

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    from lookalike.jobs import simplify as simplify_job

    monkeypatch.setattr(simplify_job, "SIMPLIFY", dataclasses.replace(simplify_job.SIMPLIFY, initial_guess=interrupted))
    with pytest.raises(KeyboardInterrupt):
        simplify(bumpy_sphere(), tmp_path / "out", triangles=60, iterations=2, config=cfg, force=True, progress=False)
    assert {name: (tmp_path / "out" / name).read_bytes() for name in old} == old
    assert not first.interrupted
    assert not [p for p in (tmp_path / "out").iterdir() if p.name.startswith(".tmp-")]


def test_outputs_appear_only_when_every_one_is_written(tmp_path):
    (tmp_path / "metrics.json").write_text("old")
    with pytest.raises(RuntimeError):
        with outputs.staged_outputs(tmp_path) as staging:
            (staging / "model.glb").write_text("new")
            raise RuntimeError("the report failed")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["metrics.json"]
    with outputs.staged_outputs(tmp_path) as staging:
        (staging / "model.glb").write_text("new")
        (staging / "metrics.json").write_text("new")
        (staging / "report_files").mkdir()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["metrics.json", "model.glb", "report_files"]
    assert (tmp_path / "metrics.json").read_text() == "new"


def test_the_kernel_cache_falls_back_to_a_private_temporary_folder(tmp_path, monkeypatch):
    assert kernel_cache.fallback_folder(tmp_path, tmp_path, {}) is None
    monkeypatch.setattr(kernel_cache, "_writable", lambda folder: False)
    assert kernel_cache.fallback_folder(tmp_path, tmp_path, {"NUMBA_CACHE_DIR": "/x"}) is None
    folder = kernel_cache.fallback_folder(tmp_path, tmp_path, {})
    assert folder == str(Path(tempfile.gettempdir()) / f"lookalike-kernels-{os.getuid()}")


def test_warnings_are_one_line(tmp_path, capsys):
    (tmp_path / "a.obj").write_text("mtllib missing.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n")
    assert main(["convert", str(tmp_path / "a.obj"), str(tmp_path / "a.glb")]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err and all(line.startswith("lookalike convert: warning: ") for line in err)
    assert not any("UserWarning" in line or "warn(" in line for line in err)
    assert torch.is_tensor(io.load(tmp_path / "a.glb").mesh.v_pos)
