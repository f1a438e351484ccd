"""One row of ``lookalike bench scaling``, in a process of its own (so that its peak memory is
its own): ``python -m lookalike.bench._scaling_worker TRIANGLES STEPS OUTDIR RESULT.json [CONFIG]``.

Generates the input (``lookalike.jobs.demo.demo_asset`` at ``TRIANGLES``), writes it to a glb
in ``OUTDIR`` (the run then loads it, as a user's file), simplifies it with a fixed step count
and ``profile=True`` (with the settings file ``CONFIG`` where given), and writes ``{"generate_s", "metrics"}`` to ``RESULT.json``.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from .. import heap, kernel_cache

OUTPUT_TRIANGLES = 2000


def main(argv: list[str]) -> None:
    """Run the row as ``lookalike simplify`` runs, with the command's process settings
    (``kernel_cache.choose``, ``heap.keep_freed_memory``) made before Numba is first imported."""
    kernel_cache.choose()
    heap.keep_freed_memory()
    from .. import io
    from ..jobs.demo import demo_asset
    from ..jobs.simplify import simplify

    triangles, steps, outdir, result = int(argv[0]), int(argv[1]), Path(argv[2]), Path(argv[3])
    outdir.mkdir(parents=True, exist_ok=True)
    clock = time.monotonic()
    source = outdir / f"knot-{triangles}.glb"
    io.save(demo_asset(triangles), source)
    generate = time.monotonic() - clock
    run = simplify(source, outdir / "run", triangles=OUTPUT_TRIANGLES, iterations=steps, force=True, progress=False,
                   profile=True, config=argv[4] if len(argv) > 4 else None)
    result.write_text(json.dumps({"generate_s": generate, "metrics": run.metrics}), encoding="utf-8")


if __name__ == "__main__":
    main(sys.argv[1:])
