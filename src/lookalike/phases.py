"""Where a run's time goes: named phases, with the wall and CPU seconds spent in each.

Code marks its phases with ``with phase("bake"):``; that costs nothing unless a ``Profile`` is
recording (``with recording(profile):``, as ``simplify --profile`` does). Phases nest: a phase
entered inside another is recorded under the path ``"outer > inner"``, and the outer's time
includes the inner's. CPU seconds are the process's (``time.process_time``, every thread), so
``cpu_s / wall_s`` is how many cores the phase kept busy on average.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator
from contextvars import ContextVar
from dataclasses import dataclass, field

SEPARATOR = " > "


@dataclass
class PhaseTime:
    """Seconds spent in one phase over all its calls."""

    wall: float = 0.0
    cpu: float = 0.0
    calls: int = 0


@dataclass
class Profile:
    """The phases recorded so far, by path, in the order first entered."""

    phases: dict[str, PhaseTime] = field(default_factory=dict)
    stack: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, dict]:
        """``{path: {"wall_s", "cpu_s", "cpu_per_wall", "calls"}}`` (JSON-ready)."""
        return {path: {"wall_s": t.wall, "cpu_s": t.cpu, "cpu_per_wall": t.cpu / t.wall if t.wall > 0 else 0.0,
                       "calls": t.calls} for path, t in self.phases.items()}


_ACTIVE: ContextVar[Profile | None] = ContextVar("lookalike_profile", default=None)


@contextlib.contextmanager
def recording(profile: Profile) -> Iterator[Profile]:
    """Record the phases entered in the ``with`` block (in this thread or task) into ``profile``."""
    token = _ACTIVE.set(profile)
    try:
        yield profile
    finally:
        _ACTIVE.reset(token)


@contextlib.contextmanager
def phase(name: str) -> Iterator[None]:
    """Add the ``with`` block's wall and CPU seconds to phase ``name`` of the recording profile
    (nested under the phases it runs in); nothing when none records."""
    profile = _ACTIVE.get()
    if profile is None:
        yield
        return
    profile.stack.append(name)
    spent = profile.phases.setdefault(SEPARATOR.join(profile.stack), PhaseTime())
    wall, cpu = time.perf_counter(), time.process_time()
    try:
        yield
    finally:
        spent.wall += time.perf_counter() - wall
        spent.cpu += time.process_time() - cpu
        spent.calls += 1
        profile.stack.pop()
