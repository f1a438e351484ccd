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


class UserCodeError(LookalikeError):
    """The user's own code (a field in a ``.py`` file) raised, or a shader of theirs did not
    compile: the message is their file, line and error, not ours.

    ``UserCodeError("field.py", 7, "ZeroDivisionError: division by zero", "sdf")`` reads
    ``"field.py, line 7, in sdf: ZeroDivisionError: division by zero"``.
    """

    def __init__(self, path: str | Path, line: int | None, problem: str, function: str | None = None):
        self.path, self.line, self.problem = Path(path), line, problem
        where = "".join([f", line {line}" if line else "", f", in {function}" if function else ""])
        super().__init__(f"{self.path}{where}: {problem}")
