"""``lookalike batch``: many assets on a local Ray instance, a worker killed mid-run, and a
finished batch run again."""

from __future__ import annotations

import json
import os
import signal
import threading
import time
from pathlib import Path

import pytest
import torch

from lookalike import io
from lookalike.errors import ConfigError
from lookalike.jobs import batch as batch_job
from lookalike.jobs.batch import BatchItem, batch, batch_items, state_of
from lookalike.jobs.simplify import simplify
from lookalike.report.index import write_index
from test_fit_simplify import bumpy_sphere

RUN_TOML = ("[views]\npool_size = 4\nheldout = 2\nvalidation = 2\n[render]\nresolution = 32\n"
            "[latent]\ntexture_size = 32\n[optim]\ncheckpoint_seconds = 0.2\n")


def tiny_assets(folder: Path, count: int = 3) -> list[Path]:
    """``count`` bumpy spheres of different scales, as .glb files in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for k in range(count):
        asset = bumpy_sphere()
        asset.mesh.v_pos = asset.mesh.v_pos * (1 + 0.5 * k)
        paths.append(folder / f"ball{k}.glb")
        io.save(asset, paths[-1])
    return paths


def test_inputs_are_files_and_folders_with_unique_names(tmp_path):
    paths = tiny_assets(tmp_path / "a", 2)
    (tmp_path / "b").mkdir()
    io.save(bumpy_sphere(), tmp_path / "b" / "ball0.obj")
    (tmp_path / "b" / "notes.txt").write_text("not an asset")
    items = batch_items([tmp_path / "a", tmp_path / "b" / "ball0.obj"], tmp_path / "out")
    assert [i.name for i in items] == ["ball0", "ball1", "ball0-2"]
    assert items[0].input == paths[0].resolve() and items[2].outdir == tmp_path / "out" / "ball0-2"
    with pytest.raises(ConfigError, match="no such file or folder"):
        batch_items([tmp_path / "missing"], tmp_path / "out")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ConfigError, match="no readable assets"):
        batch_items([tmp_path / "empty"], tmp_path / "out")


def test_an_assets_state_is_read_off_its_folder(tmp_path):
    item = BatchItem(input=tmp_path / "a.glb", name="a", outdir=tmp_path / "a")
    assert state_of(item) == "new"
    item.outdir.mkdir()
    (item.outdir / "metrics.json").write_text(json.dumps({"interrupted": True}))
    assert state_of(item) == "new"
    (item.outdir / "checkpoint.pt").write_bytes(b"")
    assert state_of(item) == "partial"
    (item.outdir / "checkpoint.pt").unlink()
    (item.outdir / "metrics.json").write_text(json.dumps({"interrupted": False}))
    assert state_of(item) == "done"


def test_the_index_links_every_report_and_sorts(tmp_path):
    folder = tmp_path / "ball"
    folder.mkdir()
    metrics = {"triangles": {"input": 5120, "output": 100}, "seconds": {"total": 90.0}, "iterations": 40,
               "heldout": {"decimated": {"psnr": 25.0, "flip": 0.1}, "baked": {"psnr": 29.0, "flip": 0.05},
                           "ours": {"psnr": 30.5, "flip": 0.04}}}
    (folder / "metrics.json").write_text(json.dumps(metrics))
    page = write_index(tmp_path, [("ball", tmp_path / "ball.glb", folder, "done"),
                                  ("broken", tmp_path / "broken.glb", tmp_path / "broken", "failed")]).read_text()
    assert 'href="ball/report.html"' in page and "+1.50" in page and 'data-v="30.5"' in page
    assert "broken" in page and "failed" in page and "addEventListener" in page


def _kill_when_running(log_folder: Path, outdir: Path, killed: list[int]) -> None:
    """Kill (SIGKILL) the worker of ``outdir``'s asset once it has written a checkpoint of its loop."""
    deadline = time.monotonic() + 240
    stamps = set()
    while time.monotonic() < deadline:
        checkpoint, pid = outdir / "checkpoint.pt", log_folder / f"{outdir.name}.pid"
        if checkpoint.is_file() and pid.is_file():
            stamps.add(checkpoint.stat().st_mtime_ns)
            if len(stamps) >= 3:                      # periodic checkpoints: the loop is running
                killed.append(int(pid.read_text()))
                os.kill(killed[-1], signal.SIGKILL)
                return
        time.sleep(0.05)


@pytest.mark.slow
def test_a_batch_survives_a_killed_worker_matches_serial_runs_and_is_not_redone(tmp_path, monkeypatch):
    pytest.importorskip("ray")
    inputs = tiny_assets(tmp_path / "assets")
    (tmp_path / "run.toml").write_text(RUN_TOML)
    options = {"triangles": 100, "iterations": 400, "config": str(tmp_path / "run.toml")}
    out = tmp_path / "out"
    killed: list[int] = []
    killer = threading.Thread(target=_kill_when_running, args=(out / "logs", out / "ball1", killed), daemon=True)
    killer.start()
    result = batch([tmp_path / "assets"], out, workers=2, cpus_per_task=1, progress=False, **options)
    killer.join(timeout=1)
    assert killed, "the worker was never killed"
    assert result.statuses == {"ball0": "done", "ball1": "done", "ball2": "done"} and not result.errors
    assert "ball1" in (out / "logs" / "ball1.log").read_text() and "resuming" in (out / "logs" / "ball1.log").read_text()
    page = (out / "index.html").read_text()
    assert all(f'href="ball{k}/report.html"' in page for k in range(3))

    import numba

    threads = torch.get_num_threads(), numba.get_num_threads()
    torch.set_num_threads(1)
    numba.set_num_threads(1)
    try:
        serial = simplify(inputs[1], tmp_path / "serial", progress=False, **options)
    finally:
        torch.set_num_threads(threads[0])
        numba.set_num_threads(threads[1])
    batched = json.loads((out / "ball1" / "metrics.json").read_text())
    assert batched["heldout"]["ours"] == serial.metrics["heldout"]["ours"]
    assert (out / "ball1" / "model.glb").read_bytes() == serial.model.read_bytes()

    def no_work(*args, **kwargs):
        raise AssertionError("a finished batch must not run again")

    monkeypatch.setattr(batch_job, "_run_on_ray", no_work)
    again = batch([tmp_path / "assets"], out, workers=2, progress=False, **options)
    assert again.skipped == ["ball0", "ball1", "ball2"]
