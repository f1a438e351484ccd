"""Running Blender (the ``bpy`` module) in a child process.

``bpy`` keeps global state (one scene, one set of data blocks), starts threads of its own and
bundles libraries of its own; none of that belongs in the lookalike process. A worker module
(``lookalike.blender.cycles_worker``, ``lookalike.blender.decimate_bake_worker``) is run as
``python -m lookalike.blender.<worker> JOB.json`` with the same interpreter; the job file says
what to do and where to write the results. The worker imports only ``bpy``, NumPy, ``xatlas``
and the standard library.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from ..errors import ConfigError, LookalikeError

INSTALL_HINT = 'the Blender judge needs `pip install -e ".[judge]"` (the bpy package, Python 3.11)'

TIMEOUT_S = 3600.0
"""Longest a worker may run before it is stopped."""

STDERR_LINES = 20
"""Lines of a failed worker's output quoted in the error."""


class JudgeError(LookalikeError):
    """Blender failed on a job (its last lines of output are in the message)."""


def judge_available() -> bool:
    """Whether ``bpy`` (Blender as a Python module) can be imported by this interpreter."""
    return importlib.util.find_spec("bpy") is not None


def require_judge() -> None:
    """``ConfigError`` with the install line unless ``judge_available()``."""
    if not judge_available():
        raise ConfigError(INSTALL_HINT)


def run_worker(module: str, job: dict, timeout: float = TIMEOUT_S) -> float:
    """Run ``python -m lookalike.blender.<module> JOB.json`` on ``job`` (JSON-serialisable) and
    wait for it; returns its wall seconds.

    Raises:
        ConfigError: ``bpy`` is not installed.
        JudgeError: the worker failed or ran past ``timeout`` seconds (its output tail quoted).
    """
    require_judge()
    with tempfile.TemporaryDirectory(prefix="lookalike-judge-") as scratch:
        job_path = Path(scratch) / "job.json"
        job_path.write_text(json.dumps(job))
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        started = time.monotonic()
        try:
            done = subprocess.run([sys.executable, "-m", f"lookalike.blender.{module}", str(job_path)],
                                  capture_output=True, text=True, timeout=timeout, env=env, cwd=scratch)
        except subprocess.TimeoutExpired as e:
            raise JudgeError(f"Blender ({module}) ran past {timeout:g} s") from e
        seconds = time.monotonic() - started
    if done.returncode != 0:
        tail = "\n".join((done.stdout + done.stderr).strip().splitlines()[-STDERR_LINES:])
        if "No module named 'bpy'" in tail:
            raise ConfigError(INSTALL_HINT)
        raise JudgeError(f"Blender ({module}) failed with exit status {done.returncode}:\n{tail}")
    return seconds
