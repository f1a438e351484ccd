"""Checkpoints of a run: written atomically, at most every so many seconds and on interruption,
and read back with a version check so that a resumed run continues exactly where it stopped."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import torch

from ..errors import ConfigError
from ..io.atomic import atomic_path

CHECKPOINT_VERSION = 5


class Checkpointer:
    """Writes a state dict to ``path``, on demand or when ``every_seconds`` have passed since
    the last write.

    Args:
        path: the checkpoint file.
        every_seconds: the least time between periodic writes.
        extra: called at each write for more entries to store beside the loop's state (what
            the job needs to resume without redoing its initial guess, the time it has used).
    """

    def __init__(self, path: Path, every_seconds: float, extra: Callable[[], dict] | None = None):
        self.path = Path(path)
        self.every_seconds = every_seconds
        self.extra = extra or dict
        self.last = time.monotonic()

    def due(self) -> bool:
        return time.monotonic() - self.last > self.every_seconds

    def save(self, state: dict) -> None:
        """Write ``state`` (and ``extra()``) with the version atomically."""
        with atomic_path(self.path) as temp:
            torch.save({"version": CHECKPOINT_VERSION, **self.extra(), **state}, temp)
        self.last = time.monotonic()


def read_checkpoint(path: Path) -> dict:
    """The dict a ``Checkpointer`` wrote to ``path``; ``ConfigError`` naming the file when it
    cannot be read or is not a checkpoint of this version."""
    try:
        state = torch.load(path, map_location="cpu", weights_only=False)
    except Exception as e:  # torch raises many kinds for a truncated or foreign file
        raise ConfigError(f"{path}: cannot read the checkpoint ({e})") from None
    if not isinstance(state, dict) or state.get("version") != CHECKPOINT_VERSION:
        raise ConfigError(f"{path}: not a lookalike checkpoint of version {CHECKPOINT_VERSION}")
    return state
