"""What a job leaves in its output folder: ``model.glb`` (+ ``model.obj`` with its ``.mtl`` and
PNG textures), ``config.toml``, ``report.html`` with ``report_files/``, and ``metrics.json``.

Outputs appear only when complete: a job writes them into ``staged_outputs``, a temporary
folder inside the output folder, which is moved into place entry by entry when every output
is written (``metrics.json`` last, so its presence means the rest is there) and removed
otherwise, leaving the folder as it was.
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
