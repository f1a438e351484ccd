"""No external tool can hang a run (``lookalike.external_tools``): stand-ins for basisu, gltfpack,
a Blender worker and node that never answer are killed at their deadline with everything they
started, tried once more, and end in one line; one that answers the second time is used; a
caller interrupted while it waits kills them; a compressed file whose tool hangs leaves nothing
half-written, and the job's other outputs stay. No npm package is needed."""

from __future__ import annotations

import json
import os
import pickle
import signal
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import torch

from io_factory import uv_sphere
from lookalike import io
from lookalike.asset import Asset, Material, Texture
from lookalike.errors import ConfigError, ExternalToolTimeout, OutputsIncomplete
from lookalike.shading.light import PointLight
from lookalike.shading.view_sampling import random_views
from test_io_gltf import quad_doc
from test_io_ktx2 import _one_level

pytestmark = pytest.mark.timeout(60)

if not sys.platform.startswith("linux"):
    pytest.skip("the stand-ins are shell scripts, and a process's end is read in /proc", allow_module_level=True)

DEADLINE = 0.5
"""The deadline the stand-ins are given, in seconds."""
INTERRUPTED_DEADLINE = 20.0
"""The deadline of a stand-in that Ctrl-C is to stop first."""

HANG = "sleep 1000"
HANG_WITH_A_CHILD = 'sleep 1000 &\necho $! >> "$0.pids"\nwait'
"""Hang, having started a process of its own (its pid appended to ``NAME.pids``)."""
HANG_WITH_A_CHILD_ELSEWHERE = 'setsid sleep 1000 &\necho $! >> "$0.pids"\nwait'
"""Hang, having started a process in a session of its own, as a browser does."""


def _fake(folder: Path, name: str, body: str) -> Path:
    """An executable shell script ``folder/name`` that appends a line to ``folder/name.runs`` on
    each run, then runs ``body`` (its arguments are ``$1 ...``)."""
    path = folder / name
    path.write_text(f'#!/bin/sh\necho "$$" >> "$0.runs"\n{body}\n')
    path.chmod(0o755)
    return path


def _lines(path: Path) -> list[str]:
    return path.read_text().split() if path.is_file() else []


def _gone(pid: int, wait: float = 5.0) -> bool:
    """Whether process ``pid`` has ended (reaped, or dead and awaiting its reaper), waiting up to
    ``wait`` seconds for it."""
    end = time.monotonic() + wait
    while True:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except (FileNotFoundError, ProcessLookupError):
            return True
        if state in ("Z", "X") or time.monotonic() > end:
            return state in ("Z", "X")
        time.sleep(0.05)


def _plain_asset() -> Asset:
    """A sphere with constant materials (no texture to encode)."""
    return Asset(mesh=uv_sphere(4, 8), materials=[Material(kd=Texture.constant([0.5, 0.4, 0.3, 1.0]),
                                                           ks=Texture.constant([0.0, 0.5, 0.0]))])


def _interrupt_when(ready) -> threading.Thread:
    """A thread that sends SIGINT (Ctrl-C) to the main thread once ``ready()`` holds (and never,
    where it does not within ``INTERRUPTED_DEADLINE``: the test then fails on the tool's error)."""
    def watch():
        end = time.monotonic() + INTERRUPTED_DEADLINE
        while not ready():
            if time.monotonic() > end:
                return
            time.sleep(0.05)
        signal.pthread_kill(threading.main_thread().ident, signal.SIGINT)

    thread = threading.Thread(target=watch, daemon=True)
    thread.start()
    return thread


@pytest.fixture
def ctrl_c_raises():
    """SIGINT raises ``KeyboardInterrupt`` for the test, as in a terminal: a process started in
    the background by a shell (``cmd &``) begins with SIGINT ignored."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


@pytest.fixture
def quick_basisu(monkeypatch):
    from lookalike.io import ktx2

    monkeypatch.setattr(ktx2, "BASISU_BASE_S", DEADLINE)
    monkeypatch.setattr(ktx2, "ENCODE_SECONDS_PER_PIXEL", 0.0)
    monkeypatch.setattr(ktx2, "DECODE_SECONDS_PER_PIXEL", 0.0)


@pytest.fixture
def quick_gltfpack(monkeypatch):
    from lookalike.io import meshopt

    monkeypatch.setattr(meshopt, "GLTFPACK_BASE_S", DEADLINE)
    monkeypatch.setattr(meshopt, "GLTFPACK_SECONDS_PER_TRIANGLE", 0.0)


def test_a_hanging_encoder_is_killed_at_its_deadline_tried_twice_and_named_in_one_line(tmp_path, quick_basisu):
    from lookalike.io.ktx2 import encode_mip_chain

    encoder = _fake(tmp_path, "basisu", HANG)
    started = time.monotonic()
    with pytest.raises(ExternalToolTimeout) as error:
        encode_mip_chain([np.full((4, 4, 4), 200, np.uint8)], linear=False, encoder=encoder)
    assert str(error.value) == f"basisu: no answer on level0.png after {DEADLINE:g} s (killed, tried twice)"
    assert len(_lines(tmp_path / "basisu.runs")) == 2 and time.monotonic() - started < 10 * DEADLINE


def test_a_hanging_transcoder_is_killed_and_named_too(tmp_path, quick_basisu):
    from lookalike.io.ktx2 import decode_mip_chain

    decoder = _fake(tmp_path, "basisu", HANG)
    with pytest.raises(ExternalToolTimeout, match=r"^basisu: no answer on chain\.ktx2 after 0\.5 s"):
        decode_mip_chain(_one_level(4, 4, bytes(64)), decoder)
    assert len(_lines(tmp_path / "basisu.runs")) == 2


def test_a_hanging_gltfpack_is_killed_with_the_processes_it_started(tmp_path, monkeypatch, quick_gltfpack):
    from lookalike.io.meshopt import compress_glb

    monkeypatch.setenv("LOOKALIKE_GLTFPACK", str(_fake(tmp_path, "gltfpack", HANG_WITH_A_CHILD)))
    io.save(_plain_asset(), tmp_path / "model.glb")
    with pytest.raises(ExternalToolTimeout) as error:
        compress_glb(tmp_path / "model.glb", tmp_path / "small.glb")
    assert str(error.value) == f"gltfpack: no answer on model.glb after {DEADLINE:g} s (killed, tried twice)"
    runs, children = _lines(tmp_path / "gltfpack.runs"), _lines(tmp_path / "gltfpack.pids")
    assert len(runs) == 2 and len(children) == 2
    assert all(_gone(int(pid)) for pid in runs + children)    # the tool and what it started: the whole group


def test_a_tool_that_hangs_once_answers_on_the_retry(tmp_path, monkeypatch, quick_gltfpack):
    from lookalike.io import meshopt

    monkeypatch.setattr(meshopt, "GLTFPACK_BASE_S", 2.0)
    once = f'if [ "$(wc -l < "$0.runs")" -lt 2 ]; then {HANG}; fi\ncp "$2" "$4"'   # gltfpack -i SOURCE -o TARGET
    monkeypatch.setenv("LOOKALIKE_GLTFPACK", str(_fake(tmp_path, "gltfpack", once)))
    io.save(_plain_asset(), tmp_path / "model.glb")
    meshopt.compress_glb(tmp_path / "model.glb", tmp_path / "small.glb")
    assert (tmp_path / "small.glb").read_bytes() == (tmp_path / "model.glb").read_bytes()
    assert len(_lines(tmp_path / "gltfpack.runs")) == 2


def test_a_tool_that_fails_is_still_a_one_line_error_of_its_own(tmp_path, monkeypatch, quick_gltfpack):
    from lookalike.io.meshopt import compress_glb

    monkeypatch.setenv("LOOKALIKE_GLTFPACK", str(_fake(tmp_path, "gltfpack", "echo 'Error: bad input' >&2; exit 1")))
    io.save(_plain_asset(), tmp_path / "model.glb")
    with pytest.raises(ConfigError, match=r"gltfpack failed \(Error: bad input\)$"):
        compress_glb(tmp_path / "model.glb", tmp_path / "small.glb")
    assert len(_lines(tmp_path / "gltfpack.runs")) == 1


def test_a_hanging_blender_worker_is_killed_at_the_deadline_its_caller_gives(tmp_path, monkeypatch):
    from lookalike.blender import cycles, process

    worker = _fake(tmp_path, "worker", HANG_WITH_A_CHILD)
    monkeypatch.setattr(process, "require_judge", lambda: None)
    monkeypatch.setattr(process, "worker_command", lambda module, job: [str(worker), str(job)])
    monkeypatch.setattr(process, "WORKER_BASE_S", DEADLINE)
    monkeypatch.setattr(process, "WORKER_SECONDS_PER_TRIANGLE", 0.0)
    monkeypatch.setattr(cycles, "SECONDS_PER_SAMPLE", 0.0)
    io.save(_plain_asset(), tmp_path / "model.glb")
    camera = random_views(torch.zeros(3), 1.0, 2, np.random.default_rng(1))
    light = PointLight(position=torch.tensor([[1.0, 2.0, 3.0]]), intensity=torch.tensor([[5.0, 5.0, 5.0]]))
    with pytest.raises(ExternalToolTimeout) as error:
        cycles.render_cycles_views(tmp_path / "model.glb", camera, light, 16, (True,), samples=1)
    assert str(error.value) == (f"Blender (cycles_worker): no answer on model.glb after {DEADLINE:g} s "
                                "(killed, tried twice)")
    assert len(_lines(tmp_path / "worker.runs")) == 2
    assert all(_gone(int(pid)) for pid in _lines(tmp_path / "worker.pids"))


def test_a_hanging_browser_is_killed_at_its_deadline_with_the_session_it_started(tmp_path, monkeypatch):
    from lookalike.webgl import three_views

    folder = tmp_path / "bin"
    folder.mkdir()
    _fake(folder, "node", HANG_WITH_A_CHILD_ELSEWHERE)
    for package in ("three", "puppeteer-core"):
        (tmp_path / "node_modules" / package).mkdir(parents=True)
    monkeypatch.setenv("PATH", f"{folder}{os.pathsep}{os.environ['PATH']}")
    monkeypatch.setenv("LOOKALIKE_CHROMIUM", str(folder / "node"))
    monkeypatch.setattr(three_views, "BASE_S", DEADLINE)
    monkeypatch.setattr(three_views, "SECONDS_PER_SAMPLE", 0.0)
    camera = random_views(torch.zeros(3), 1.0, 2, np.random.default_rng(1))
    with pytest.raises(ExternalToolTimeout, match=r"^three\.js: no answer on ball\.glb after 0\.5 s"):
        three_views.render_threejs(tmp_path / "ball.glb", camera, 16, modules=tmp_path / "node_modules")
    runs, browsers = _lines(folder / "node.runs"), _lines(folder / "node.pids")
    assert len(runs) == 2 and len(browsers) == 2 and all(_gone(int(pid)) for pid in runs + browsers)


def test_ctrl_c_while_a_tool_runs_kills_it_and_what_it_started(tmp_path, monkeypatch, quick_gltfpack, ctrl_c_raises):
    """A tool in a session of its own does not get the terminal's Ctrl-C: the caller kills it."""
    from lookalike.io import meshopt

    monkeypatch.setattr(meshopt, "GLTFPACK_BASE_S", INTERRUPTED_DEADLINE)
    monkeypatch.setenv("LOOKALIKE_GLTFPACK", str(_fake(tmp_path, "gltfpack", HANG_WITH_A_CHILD)))
    io.save(_plain_asset(), tmp_path / "model.glb")
    _interrupt_when(lambda: len(_lines(tmp_path / "gltfpack.pids")) == 1)
    with pytest.raises(KeyboardInterrupt):
        meshopt.compress_glb(tmp_path / "model.glb", tmp_path / "small.glb")
    runs, children = _lines(tmp_path / "gltfpack.runs"), _lines(tmp_path / "gltfpack.pids")
    assert len(runs) == 1 and all(_gone(int(pid)) for pid in runs + children)


def test_ctrl_c_while_encoder_threads_wait_kills_every_encoder_at_once(tmp_path, monkeypatch, quick_basisu, ctrl_c_raises):
    """The levels' encoders wait in worker threads, which Ctrl-C does not reach: the main thread
    kills them all and waits for none."""
    from lookalike.io import ktx2

    monkeypatch.setattr(ktx2, "BASISU_BASE_S", INTERRUPTED_DEADLINE)
    monkeypatch.setattr(ktx2, "available_cores", lambda: 2)
    encoder = _fake(tmp_path, "basisu", HANG_WITH_A_CHILD)
    levels = [np.full((4 >> k, 4 >> k, 4), 200, np.uint8) for k in range(3)]
    _interrupt_when(lambda: len(_lines(tmp_path / "basisu.pids")) == 2)
    started = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        ktx2.encode_mip_chain(levels, linear=False, encoder=encoder)
    assert time.monotonic() - started < INTERRUPTED_DEADLINE / 2   # not a deadline: the interrupt
    runs, children = _lines(tmp_path / "basisu.runs"), _lines(tmp_path / "basisu.pids")
    assert len(runs) == 2 and all(_gone(int(pid)) for pid in runs + children)   # the third level never started


def test_the_command_line_ends_a_hanging_tool_in_one_line_and_status_2(tmp_path, monkeypatch, capsys,
                                                                        quick_gltfpack):
    from lookalike.cli import main

    monkeypatch.setenv("LOOKALIKE_GLTFPACK", str(_fake(tmp_path, "gltfpack", HANG)))
    doc, primitive = quad_doc()
    doc.mesh_node([primitive])
    doc.json["extensionsUsed"] = doc.json["extensionsRequired"] = ["EXT_meshopt_compression"]
    doc.write(tmp_path / "packed.gltf")                     # gltfpack is asked to decode it
    assert main(["convert", str(tmp_path / "packed.gltf"), str(tmp_path / "plain.glb")]) == 2
    assert capsys.readouterr().err == (f"lookalike convert: error: gltfpack: no answer on packed.gltf after "
                                       f"{DEADLINE:g} s (killed, tried twice)\n")
    assert not (tmp_path / "plain.glb").exists()


def test_a_compressed_model_whose_gltfpack_hangs_leaves_nothing_half_written(tmp_path, monkeypatch, quick_gltfpack):
    from lookalike.jobs.compressed_model import write_compressed

    monkeypatch.setenv("LOOKALIKE_BASISU", str(_fake(tmp_path, "basisu", "exit 1")))   # found, never needed
    monkeypatch.setenv("LOOKALIKE_GLTFPACK", str(_fake(tmp_path, "gltfpack", f'echo partial > "$4"\n{HANG}')))
    out = tmp_path / "out"
    out.mkdir()
    io.save(_plain_asset(), out / "model.glb")
    with pytest.raises(ExternalToolTimeout, match="^gltfpack: no answer on model.compressed.glb"):
        write_compressed(out / "model.glb", out / "model.compressed.glb")
    assert sorted(p.name for p in out.iterdir()) == ["model.glb"]


def test_outputs_written_but_one_stay_with_the_checkpoint_and_end_in_one_line(tmp_path):
    from lookalike.jobs.outdir import CHECKPOINT_NAME, left_as_found
    from lookalike.jobs.outputs import OptionalOutputs

    out, notes = tmp_path / "out", []
    with pytest.raises(OutputsIncomplete) as error, left_as_found(out):
        out.mkdir()
        (out / CHECKPOINT_NAME).write_bytes(b"state")
        optional = OptionalOutputs(out)
        with optional.attempt("model.compressed.glb", notes):
            raise ExternalToolTimeout("gltfpack", "model.compressed.glb", 30.0)
        (out / "model.glb").write_bytes(b"glb")
        optional.check()
    cause = "gltfpack: no answer on model.compressed.glb after 30 s (killed, tried twice)"
    assert str(error.value) == f"{out}: model.compressed.glb was not written ({cause}); the other outputs were"
    assert notes == [f"model.compressed.glb was not written: {cause}"]
    assert sorted(p.name for p in out.iterdir()) == [CHECKPOINT_NAME, "model.glb"]
    with pytest.raises(ConfigError), left_as_found(tmp_path / "other"):     # any other failure: as it was found
        (tmp_path / "other").mkdir()
        raise ConfigError("no")
    assert not (tmp_path / "other").exists()


def test_the_new_errors_survive_pickling_as_worker_processes_send_them():
    for error in (ExternalToolTimeout("basisu", "level1.png", 45.0),
                  OutputsIncomplete("out", "model.compressed.glb", ExternalToolTimeout("gltfpack", "a.glb", 30.0))):
        again = pickle.loads(pickle.dumps(error))
        assert type(again) is type(error) and str(again) == str(error)


def _stand_in_level(folder: Path, compressed: bool) -> None:
    """What a level's run leaves in ``folder`` (``jobs.lod``): its model, settings and metrics,
    and with ``compressed`` its compressed model (here a copy) and scores."""
    from lookalike.settings import Config, to_toml

    folder.mkdir(parents=True, exist_ok=True)
    io.save(_plain_asset(), folder / "model.glb")
    (folder / "config.toml").write_text(to_toml(Config()))
    scores = {"psnr": 30.0, "flip": 0.1}
    heldout = {"ours": scores, **({"compressed": scores} if compressed else {})}
    if compressed:
        (folder / "model.compressed.glb").write_bytes((folder / "model.glb").read_bytes())
    (folder / "metrics.json").write_text(json.dumps({"interrupted": False, "triangles": {"output": 64},
                                                     "seconds": {"total": 1.0}, "heldout": heldout}))


def test_a_chain_goes_on_past_a_level_whose_compressed_model_failed_and_then_says_so(tmp_path, monkeypatch):
    from lookalike.jobs import lod

    def level_run(app, asset, folder, **keywords):  # level 0 writes all but its compressed model
        _stand_in_level(folder, compressed=folder.name != "lod0")
        if folder.name == "lod0":
            raise OutputsIncomplete(folder, "model.compressed.glb", "basisu: no answer on level0.png after 30 s")

    monkeypatch.setattr(lod, "run", level_run)
    with pytest.raises(OutputsIncomplete) as error:
        lod.lod(_plain_asset(), tmp_path / "chain", [lod.Level(100, 24), lod.Level(60, 12)])
    assert str(error.value) == (f"{tmp_path / 'chain'}: lod0/model.compressed.glb was not written (basisu: no answer "
                                "on level0.png after 30 s); the other outputs were")
    assert len(json.loads((tmp_path / "chain" / "lods.json").read_text())["levels"]) == 2
    assert (tmp_path / "chain" / "lods.glb").is_file() and (tmp_path / "chain" / "lod1.compressed.glb").is_file()


def test_a_chain_whose_compressed_chain_hangs_writes_the_rest_and_nothing_half_written(tmp_path, monkeypatch,
                                                                                      quick_gltfpack):
    from lookalike.jobs import lod

    monkeypatch.setattr(lod, "run", lambda app, asset, folder, **keywords: _stand_in_level(folder, compressed=True))
    monkeypatch.setenv("LOOKALIKE_BASISU", str(_fake(tmp_path, "basisu", "exit 1")))   # found, never needed
    monkeypatch.setenv("LOOKALIKE_GLTFPACK", str(_fake(tmp_path, "gltfpack", f'echo partial > "$4"\n{HANG}')))
    with pytest.raises(OutputsIncomplete, match="lods.compressed.glb was not written .gltfpack: no answer on "
                                                "lods.compressed.glb after 0.5 s"):
        lod.lod(_plain_asset(), tmp_path / "chain", [lod.Level(100, 24), lod.Level(60, 12)])
    assert sorted(p.name for p in (tmp_path / "chain").iterdir() if p.is_file()) == [
        "lod0.compressed.glb", "lod0.glb", "lod1.compressed.glb", "lod1.glb", "lods.glb", "lods.json"]
