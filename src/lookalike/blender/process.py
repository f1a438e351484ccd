"""Running Blender (the ``bpy`` module) in a child process.

``bpy`` keeps global state (one scene, one set of data blocks), starts threads of its own and
bundles libraries of its own; none of that belongs in the lookalike process. A worker module
(``lookalike.blender.cycles_worker``, ``lookalike.blender.decimate_bake_worker``) is run as
``python -m lookalike.blender.<worker> JOB.json`` with the same interpreter; the job file says
what to do and where to write the results. The worker imports only ``bpy``, NumPy, ``xatlas``
and the standard library. A worker runs with a deadline its caller scales to the work
(``worker_deadline``), and is killed where it runs past it (``lookalike.external_tools``).
"""

from __future__ import annotations

import importlib.util
import json
import os
import sys
import tempfile
import time
from pathlib import Path

from ..errors import ConfigError, LookalikeError
from ..external_tools import run_tool

INSTALL_HINT = 'the Blender judge needs `pip install -e ".[judge]"` (the bpy package, Python 3.11)'

WORKER_BASE_S = 120.0
"""Seconds any worker may take besides its work: starting Python and Blender and reading its
files, on a busy machine."""

WORKER_SECONDS_PER_TRIANGLE = 1e-4
"""Seconds a worker may take per triangle it imports, poses, decimates or subdivides: a generous
margin over Blender's own speed (the timings in ``docs/judge.md``)."""

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


def worker_deadline(triangles: int = 0, seconds: float = 0.0) -> float:
    """``WORKER_BASE_S + WORKER_SECONDS_PER_TRIANGLE * triangles + seconds``: the deadline of a
    worker that handles ``triangles`` and whose own work (its samples, say) may take ``seconds``."""
    return WORKER_BASE_S + WORKER_SECONDS_PER_TRIANGLE * triangles + seconds


def worker_command(module: str, job_path: Path) -> list[str]:
    """The command that runs ``lookalike.blender.<module>`` on the job file ``job_path`` (with
    this interpreter)."""
    return [sys.executable, "-m", f"lookalike.blender.{module}", str(job_path)]


def run_worker(module: str, job: dict, deadline: float, subject: str) -> float:
    """Run ``python -m lookalike.blender.<module> JOB.json`` on ``job`` (JSON-serialisable) and
    wait for it up to ``deadline`` seconds (``worker_deadline``), once more where it ran past
    them; returns its wall seconds. ``subject``: the file it works on, for the error.

    Raises:
        ConfigError: ``bpy`` is not installed.
        JudgeError: the worker failed (its output tail quoted).
        ExternalToolTimeout: the worker ran past ``deadline`` twice.
    """
    require_judge()
    with tempfile.TemporaryDirectory(prefix="lookalike-judge-") as scratch:
        job_path = Path(scratch) / "job.json"
        job_path.write_text(json.dumps(job))
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        started = time.monotonic()
        done = run_tool(worker_command(module, job_path), tool=f"Blender ({module})", subject=subject,
                        deadline=deadline, env=env, cwd=scratch)
        seconds = time.monotonic() - started
    if done.returncode != 0:
        tail = "\n".join((done.stdout + done.stderr).strip().splitlines()[-STDERR_LINES:])
        if "No module named 'bpy'" in tail:
            raise ConfigError(INSTALL_HINT)
        raise JudgeError(f"Blender ({module}) failed with exit status {done.returncode}:\n{tail}")
    return seconds
