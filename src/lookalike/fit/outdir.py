"""The output folder of a run: who may write into it, and atomic writes.

Every file appears complete or not at all: it is written under a temporary name in the same
folder and moved into place with ``os.replace`` (atomic on POSIX and Windows).
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path
from typing import Iterator

from ..errors import ConfigError

CHECKPOINT_NAME = "checkpoint.pt"
TEMP_PREFIX = ".tmp-"


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path next to ``path`` (same suffix, so writers that choose the format by
    extension still work); on normal exit move it onto ``path``, on error delete it."""
    path = Path(path)
    temp = path.with_name(f"{TEMP_PREFIX}{os.getpid()}-{path.name}")
    try:
        yield temp
        os.replace(temp, path)
    finally:
        temp.unlink(missing_ok=True)


def write_text_atomic(path: str | Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    with atomic_path(path) as temp:
        temp.write_text(text, encoding="utf-8")


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
