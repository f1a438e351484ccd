"""What a job leaves in its output folder: ``model.glb`` (+ ``model.obj`` with its ``.mtl`` and
PNG textures), ``report.html`` and, last, ``metrics.json``, each written atomically."""

from __future__ import annotations

import json
import shutil
import tempfile
import time
from pathlib import Path

from .. import io
from ..asset import Asset
from ..io.atomic import atomic_path, write_text_atomic
from ..report.html import write_report
from ..report.record import RunRecord


def write_model(asset: Asset, outdir: Path, obj: bool) -> Path:
    """Write ``outdir/model.glb`` (and, with ``obj``, ``model.obj`` and its companions, staged
    in a temporary folder and moved in one by one); returns the glTF's path."""
    model = outdir / "model.glb"
    with atomic_path(model) as temp:
        io.save(asset, temp)
    if obj:
        with tempfile.TemporaryDirectory(dir=outdir, prefix=".tmp-obj-") as staging:
            io.save(asset, Path(staging) / "model.obj")
            for written in sorted(Path(staging).iterdir()):
                shutil.move(str(written), str(outdir / written.name))
    return model


def write_record(outdir: Path, record: RunRecord, started: float) -> tuple[Path, dict]:
    """Write ``report.html`` and then ``metrics.json`` from ``record``; the wall time in the
    metrics counts from ``started`` (``time.monotonic()``) to after the report. Returns the
    report's path and the metrics."""
    report = write_report(outdir, record)
    record.wall_time = time.monotonic() - started
    metrics = record.metrics()
    write_text_atomic(outdir / "metrics.json", json.dumps(metrics, indent=2))
    return Path(report), metrics
