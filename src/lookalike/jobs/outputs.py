"""What a job leaves in its output folder: ``model.glb`` (+ ``model.obj`` with its ``.mtl`` and
PNG textures), ``config.toml``, ``report.html`` with ``report_files/``, and ``metrics.json``.

Outputs appear only when complete: a job writes them into ``staged_outputs``, a temporary
folder inside the output folder, which is moved into place entry by entry when every output
is written (``metrics.json`` last, so its presence means the rest is there) and removed
otherwise, leaving the folder as it was. An output that needs an external tool
(``model.compressed.glb``) is optional (``OptionalOutputs``): where it fails or hangs the others
are written all the same, and the job then ends with ``OutputsIncomplete``.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
import time
from pathlib import Path
from typing import Iterator

from .. import io
from ..asset import Asset
from ..errors import LookalikeError, OutputsIncomplete
from ..io.atomic import TEMP_PREFIX, write_text_atomic
from ..report.html import write_report
from ..report.record import RunRecord

MODEL_NAME = "model.glb"
REPORT_NAME = "report.html"
CONFIG_NAME = "config.toml"
METRICS_NAME = "metrics.json"


@contextlib.contextmanager
def staged_outputs(outdir: Path) -> Iterator[Path]:
    """Yield an empty temporary folder inside ``outdir``; on normal exit move each of its
    entries into ``outdir`` (replacing one of the same name), ``metrics.json`` last; on error
    (or after the move) remove what is left of it."""
    staging = Path(tempfile.mkdtemp(dir=outdir, prefix=f"{TEMP_PREFIX}outputs-"))
    try:
        yield staging
        entries = sorted(staging.iterdir(), key=lambda p: p.name == METRICS_NAME)
        for entry in entries:
            target = outdir / entry.name
            if target.is_dir() and not target.is_symlink():
                shutil.rmtree(target)
            os.replace(entry, target)
    finally:
        shutil.rmtree(staging, ignore_errors=True)


class OptionalOutputs:
    """The outputs of a job that it writes where it can: a ``LookalikeError`` in one (a tool that
    failed or hung) skips the rest of its block and is noted, so that the other outputs are still
    written; ``check()``, once they are in place, raises ``OutputsIncomplete`` for it."""

    def __init__(self, outdir: Path):
        self.outdir = outdir
        self.failed: list[tuple[str, str]] = []

    @contextlib.contextmanager
    def attempt(self, name: str, notes: list[str] | None = None) -> Iterator[None]:
        """Run the block that writes output ``name``; where it raises a ``LookalikeError``, note
        it (and, given ``notes``, say so there: the report's notes) and go on."""
        try:
            yield
        except LookalikeError as e:
            self.add(name, str(e))
            if notes is not None:
                notes.append(f"{name} was not written: {e}")

    def add(self, name: str, cause: str) -> None:
        """Note that output ``name`` was not written, for the reason ``cause``."""
        self.failed.append((name, cause))

    def check(self) -> None:
        """``OutputsIncomplete`` naming the first output that failed, if any did."""
        if self.failed:
            raise OutputsIncomplete(self.outdir, *self.failed[0])


def write_model(asset: Asset, folder: Path, obj: bool) -> Path:
    """Write ``folder/model.glb`` (and, with ``obj``, ``model.obj`` and its companions);
    returns the glTF's path."""
    model = folder / MODEL_NAME
    io.save(asset, model)
    if obj:
        io.save(asset, folder / "model.obj")
    return model


def write_record(folder: Path, record: RunRecord, started: float) -> dict:
    """Write ``report.html`` and then ``metrics.json`` from ``record`` into ``folder``; the wall
    time in the metrics counts from ``started`` (``time.monotonic()``) to after the report.
    Returns the metrics."""
    write_report(folder, record)
    record.wall_time = time.monotonic() - started
    metrics = record.metrics()
    write_text_atomic(folder / METRICS_NAME, json.dumps(metrics, indent=2))
    return metrics
