"""The output folder of a job: who may write into it. Files go in atomically
(``lookalike.io.atomic``)."""

from __future__ import annotations

import contextlib
import shutil
from pathlib import Path
from typing import Iterator

from ..errors import ConfigError, OutputsIncomplete

CHECKPOINT_NAME = "checkpoint.pt"


def check_outdir(outdir: str | Path, *, force: bool, resume: bool) -> None:
    """Raise ``ConfigError`` unless this run may write into ``outdir``.

    An absent or empty folder is always fine. With ``resume`` the folder must hold our
    ``checkpoint.pt``. Otherwise a non-empty folder is refused unless ``force``.
    """
    outdir = Path(outdir)
    if outdir.exists() and not outdir.is_dir():
        raise ConfigError(f"{outdir}: the output path exists and is not a folder")
    if resume:
        if not (outdir / CHECKPOINT_NAME).is_file():
            raise ConfigError(f"{outdir}: nothing to resume (no {CHECKPOINT_NAME} in it)")
    elif outdir.is_dir() and any(outdir.iterdir()) and not force:
        raise ConfigError(f"{outdir}: the output folder exists and is not empty; "
                          "pass --force to overwrite it or --resume to continue its run")


def prepare_outdir(outdir: str | Path, *, force: bool, resume: bool) -> Path:
    """``check_outdir``, then create the folder; a fresh (not resumed) run removes a stale
    checkpoint (``force`` lets it overwrite our other files in place)."""
    check_outdir(outdir, force=force, resume=resume)
    outdir = Path(outdir)
    if not resume:
        (outdir / CHECKPOINT_NAME).unlink(missing_ok=True)
    outdir.mkdir(parents=True, exist_ok=True)
    return outdir


@contextlib.contextmanager
def left_as_found(outdir: Path) -> Iterator[None]:
    """Run the block; if it fails, and ``outdir`` did not exist before it, remove ``outdir``,
    unless an interruption (Ctrl-C, SIGTERM) left a checkpoint in it to resume from, or the
    block wrote its outputs but one (``OutputsIncomplete``: they, and the checkpoint, stay)."""
    created = not Path(outdir).exists()
    try:
        yield
    except OutputsIncomplete:
        raise
    except KeyboardInterrupt:
        if created and not (Path(outdir) / CHECKPOINT_NAME).exists():
            shutil.rmtree(outdir, ignore_errors=True)
        raise
    except BaseException:
        if created:
            shutil.rmtree(outdir, ignore_errors=True)
        raise
