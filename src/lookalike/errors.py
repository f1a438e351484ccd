"""Typed exceptions. The command line prints their message and exits with status 2;
anything else is a bug and shows a traceback."""

from __future__ import annotations

from pathlib import Path


class LookalikeError(Exception):
    """Base class of every error that is the user's input, not our bug."""


class AssetError(LookalikeError):
    """An asset file cannot be read or written.

    The message always names the file: ``AssetError(path, "texture 'a.png' is missing")``
    reads ``"model.gltf: texture 'a.png' is missing"``.
    """

    def __init__(self, path: str | Path, problem: str):
        self.path = Path(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")


class ConfigError(LookalikeError):
    """A configuration value or command-line option is invalid."""
