"""External programs (encoders, Blender, a browser) run with a deadline.

A tool can hang rather than fail: a lost wakeup in its thread pool, or a browser waiting on a
page that never answers, leaves it asleep at no CPU with no end, and the run waiting on it
with it. ``run_tool`` starts the tool in a session of its own (its own process group, so that
the tool and every process it started can be killed at once, with those below it that started
a session of their own, as a browser does), waits up to a deadline, and where none came kills
them and tries once more, since such a hang is seldom repeated; a second silence is an
``ExternalToolTimeout`` naming the tool, its file and the seconds waited. A tool in a session
of its own does not get the terminal's Ctrl-C, so a caller interrupted while it waits kills
it before it stops (``RunningTools`` does so for tools that worker threads wait on, since only
the main thread is interrupted).
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import threading
from collections.abc import Mapping, Sequence
from pathlib import Path

from .errors import ExternalToolTimeout

ATTEMPTS = 2
"""Runs of a tool before its silence is an error: the first, and one retry."""


class RunningTools:
    """The tools that ``run_tool`` runs under it, from any thread: ``stop()`` kills each one
    still running (its process group and what is below it), and any started after it."""

    def __init__(self):
        self._lock = threading.Lock()
        self._running: set[subprocess.Popen] = set()
        self._stopped = False

    def add(self, process: subprocess.Popen) -> None:
        with self._lock:
            self._running.add(process)
            if self._stopped:
                _kill_tree(process)

    def discard(self, process: subprocess.Popen) -> None:
        with self._lock:
            self._running.discard(process)

    def stop(self) -> None:
        """Kill every tool running under it now and every one started under it later."""
        with self._lock:
            self._stopped = True
            for process in self._running:
                _kill_tree(process)


def run_tool(command: Sequence[str], *, tool: str, subject: str, deadline: float, cwd: str | Path | None = None,
             env: Mapping[str, str] | None = None, running: RunningTools | None = None) -> subprocess.CompletedProcess:
    """Run ``command`` (its standard input empty, its output captured as text) and return what
    it did, whatever its exit status (the caller judges that); where it has not ended after
    ``deadline`` seconds, kill it (its process group and what is below it) and run it again,
    ``ATTEMPTS`` runs in all.

    Args:
        tool, subject: the tool's name and the file it works on, for the error.
        cwd, env: as ``subprocess.Popen``'s.
        running: where a thread other than the caller's may have to stop it (``RunningTools``).
    Raises:
        ExternalToolTimeout: no run ended within ``deadline``.
    """
    for _ in range(ATTEMPTS):
        done = _attempt(list(command), deadline, cwd, env, running)
        if done is not None:
            return done
    raise ExternalToolTimeout(tool, subject, deadline)


def _attempt(command: list[str], deadline: float, cwd, env, running: RunningTools | None
             ) -> subprocess.CompletedProcess | None:
    """One run of ``command``; ``None`` where it ran past ``deadline`` (killed and reaped). Any
    exception while it waits (Ctrl-C) kills it before it propagates."""
    process = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True, cwd=cwd, env=env, start_new_session=True)
    if running is not None:
        running.add(process)
    try:
        stdout, stderr = process.communicate(timeout=deadline)
    except subprocess.TimeoutExpired:
        _kill_and_reap(process, running)
        return None
    except BaseException:
        _kill_and_reap(process, running)
        raise
    if running is not None:
        running.discard(process)
    return subprocess.CompletedProcess(command, process.returncode, stdout, stderr)


def _descendants(pid: int) -> list[int]:
    """The pids of the processes below ``pid`` (its children, theirs, ...), whatever their group
    or session, as ``/proc`` lists them now (none where there is no ``/proc``)."""
    children: dict[int, list[int]] = {}
    with contextlib.suppress(OSError):
        for entry in os.scandir("/proc"):
            if entry.name.isdigit():
                try:
                    parent = int(Path(entry.path, "stat").read_text().rsplit(")", 1)[1].split()[1])
                except (OSError, ValueError, IndexError):
                    continue  # it ended meanwhile
                children.setdefault(parent, []).append(int(entry.name))
    found, todo = [], [pid]
    while todo:
        below = children.get(todo.pop(), [])
        found += below
        todo += below
    return found


def _kill_tree(process: subprocess.Popen) -> None:
    """SIGKILL to the process group that ``process`` leads and to every process below it (one
    that left the group, as a browser does, included), unless it has been reaped."""
    if process.returncode is None:
        below = _descendants(process.pid)
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(process.pid, signal.SIGKILL)
        for pid in below:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.kill(pid, signal.SIGKILL)


def _kill_and_reap(process: subprocess.Popen, running: RunningTools | None) -> None:
    """``_kill_tree(process)``, then reap it and close its pipes unread (a process that escaped
    may still hold them open)."""
    _kill_tree(process)
    if running is not None:
        running.discard(process)
    process.wait()
    for pipe in (process.stdout, process.stderr):
        if pipe is not None:
            pipe.close()
