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


class ReferenceCoverageError(LookalikeError):
    """The reference does not show the input (its views cover far less than the input's own
    outline), so a fit to it would mean nothing."""


class ExternalToolTimeout(LookalikeError):
    """An external program (an encoder, Blender, a browser) gave no answer within its deadline,
    twice (``lookalike.external_tools``).

    ``ExternalToolTimeout("basisu", "level1.png", 45)`` reads
    ``"basisu: no answer on level1.png after 45 s (killed, tried twice)"``.
    """

    def __init__(self, tool: str, subject: str, seconds: float):
        self.tool, self.subject, self.seconds = tool, subject, seconds
        super().__init__(f"{tool}: no answer on {subject} after {round(seconds, 1):g} s (killed, tried twice)")

    def __reduce__(self):
        return type(self), (self.tool, self.subject, self.seconds)


class OutputsIncomplete(LookalikeError):
    """A job wrote its outputs except one, which failed; what was written stays in the output
    folder (with the checkpoint), where a failed job otherwise leaves the folder as it found it.

    ``OutputsIncomplete("out", "model.compressed.glb", "gltfpack: ...")`` reads
    ``"out: model.compressed.glb was not written (gltfpack: ...); the other outputs were"``.
    """

    def __init__(self, outdir: str | Path, missing: str, cause: str | BaseException):
        self.outdir, self.missing, self.cause = Path(outdir), missing, str(cause)
        super().__init__(f"{self.outdir}: {missing} was not written ({self.cause}); the other outputs were")

    def __reduce__(self):
        return type(self), (self.outdir, self.missing, self.cause)


class DeviceError(LookalikeError):
    """The chosen device cannot run: CUDA was asked for where torch sees no GPU or numba-cuda
    is not installed, or the GPU failed (out of memory, a driver error).

    ``DeviceError("torch sees no CUDA GPU")`` reads ``"CUDA: torch sees no CUDA GPU (--device
    cpu runs on the CPU)"``.
    """

    def __init__(self, problem: str):
        self.problem = problem
        super().__init__(f"CUDA: {problem} (--device cpu runs on the CPU)")

    def __reduce__(self):
        return type(self), (self.problem,)
