"""Importing lookalike leaves the host process as it was; the ``lookalike`` command sets its own
process up (``lookalike.heap``, ``lookalike.kernel_cache``)."""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from lookalike import cli, heap, kernel_cache

_IMPORT = """
import json, os
before = dict(os.environ)
import lookalike
import lookalike.jobs.simplify
import lookalike.heap
print(json.dumps({"environ_kept": dict(os.environ) == before, "heap_set": lookalike.heap._applied}))
"""

_UNCACHED_KERNELS = """
import torch
import lookalike.kernel_cache
lookalike.kernel_cache.CACHE = False  # as where no folder Numba would use can be written
import lookalike.render as dr
pos = torch.tensor([[[-1.0, -1.0, 0.0, 1.0], [1.0, -1.0, 0.0, 1.0], [0.0, 1.0, 0.0, 1.0]]])
rast, _ = dr.rasterize(None, pos, torch.tensor([[0, 1, 2]], dtype=torch.int32), (8, 8))
print(int((rast[..., 3] > 0).sum()))
"""


def _python(script: str, **env: str) -> str:
    done = subprocess.run([sys.executable, "-c", script], env={**os.environ, **env}, capture_output=True, text=True,
                          check=True)
    return done.stdout.strip().splitlines()[-1]


def test_importing_lookalike_leaves_the_environment_and_the_heap_alone():
    assert json.loads(_python(_IMPORT)) == {"environ_kept": True, "heap_set": False}


def test_the_command_sets_up_its_process_before_it_parses(monkeypatch):
    calls = []
    monkeypatch.setattr(kernel_cache, "choose", lambda: calls.append("kernel_cache"))
    monkeypatch.setattr(heap, "keep_freed_memory", lambda: calls.append("heap"))
    with pytest.raises(SystemExit):
        cli.main(["--version"])
    assert calls == ["kernel_cache", "heap"]


def test_the_command_keeps_freed_memory_and_a_writable_kernel_cache():
    """Where only the private temporary folder can be written (not the install, wherever the
    checkout lies, nor the user's cache), ``main`` points Numba's cache there."""
    script = ("import json, os, lookalike.cli, lookalike.heap, lookalike.kernel_cache as k\n"
              "private = k.Path(k.tempfile.gettempdir()) / f'lookalike-kernels-{os.getuid()}'\n"
              "k._writable = lambda folder: folder.is_relative_to(private)\n"
              "try:\n    lookalike.cli.main(['--version'])\nexcept SystemExit:\n    pass\n"
              "print(json.dumps([lookalike.heap._applied, os.environ.get('NUMBA_CACHE_DIR'), k.CACHE]))")
    environ = {key: value for key, value in os.environ.items() if key not in ("NUMBA_CACHE_DIR", "LOOKALIKE_HEAP")}
    environ["XDG_CACHE_HOME"] = "/nonexistent-cache"
    done = subprocess.run([sys.executable, "-c", script], env=environ, capture_output=True, text=True, check=True)
    applied, folder, cache = json.loads(done.stdout.strip().splitlines()[-1])
    assert applied == (platform.libc_ver()[0] == "glibc")
    assert folder == str(Path(tempfile.gettempdir()) / f"lookalike-kernels-{os.getuid()}") and cache


def test_kernels_compile_without_a_cache_where_none_can_be_written(tmp_path):
    cache = tmp_path / "numba-cache"
    assert int(_python(_UNCACHED_KERNELS, NUMBA_CACHE_DIR=str(cache))) > 0
    assert not cache.exists() or not any(cache.rglob("*.nbi"))


def test_caching_needs_one_writable_place(tmp_path, monkeypatch):
    packages = [tmp_path / "render", tmp_path / "fit"]
    assert kernel_cache.cache_writable(packages, tmp_path / "cache", {})
    writable: set[Path] = set()
    monkeypatch.setattr(kernel_cache, "_writable", lambda folder: folder in writable)
    assert not kernel_cache.cache_writable(packages, tmp_path / "cache", {})
    assert not kernel_cache.cache_writable(packages, tmp_path / "cache", {"NUMBA_CACHE_DIR": str(tmp_path / "x")})
    writable.add(tmp_path / "x")
    assert kernel_cache.cache_writable(packages, tmp_path / "cache", {"NUMBA_CACHE_DIR": str(tmp_path / "x")})
    writable.clear()
    writable.add(tmp_path / "render" / "__pycache__")
    assert not kernel_cache.cache_writable(packages, tmp_path / "cache", {})  # every package's, not one
    writable.add(tmp_path / "fit" / "__pycache__")
    assert kernel_cache.cache_writable(packages, tmp_path / "cache", {})
    writable.clear()
    writable.add(tmp_path / "cache" / "numba")
    assert kernel_cache.cache_writable(packages, tmp_path / "cache", {})
