"""``lookalike demo``: the whole job on the bundled default asset (a generated, painted,
bumpy torus knot of 100k triangles) in a few minutes, then where to look."""

from __future__ import annotations

import argparse

HELP = "simplify the bundled default asset (100k-triangle painted knot -> 2,000 triangles) in ~4 minutes"

DEMO_TRIANGLES = 2000
DEMO_TEXTURE_SIZE = 512
DEMO_RESOLUTION = 256
DEMO_TIME_BUDGET = "4m"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("-o", "--output", metavar="OUTDIR", default="lookalike-demo",
                        help="output folder (default: ./lookalike-demo)")
    parser.add_argument("--time-budget", metavar="T", default=DEMO_TIME_BUDGET,
                        help=f"wall time for the whole run (default {DEMO_TIME_BUDGET})")
    parser.add_argument("--force", action="store_true", help="overwrite an existing OUTDIR")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    import tempfile
    from pathlib import Path

    from .. import io
    from ..fit.config import parse_duration
    from ..fit.demo_asset import demo_asset
    from ..fit.simplify import simplify

    time_budget = parse_duration(args.time_budget)
    print(f"lookalike demo: simplifying a generated 100,000-triangle painted knot to {DEMO_TRIANGLES:,} "
          f"triangles in {args.time_budget} ...")
    with tempfile.TemporaryDirectory(prefix="lookalike-demo-") as folder:
        source = Path(folder) / "painted-knot.glb"
        io.save(demo_asset(), source)
        result = simplify(source, args.output, triangles=DEMO_TRIANGLES, texture_size=DEMO_TEXTURE_SIZE,
                          resolution=DEMO_RESOLUTION, time_budget=time_budget, force=args.force,
                          progress=not args.quiet)
    print(result.summary())
    print(f"\nOpen {result.report} in a browser to compare the reference, plain decimation, the classic bake and ours.")
    return 130 if result.interrupted else 0
