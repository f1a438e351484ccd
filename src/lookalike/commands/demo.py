"""``lookalike demo``: the whole job on the bundled default asset (a generated, painted,
bumpy torus knot of 100k triangles) in a few minutes, then where to look; a thin layer over
``lookalike.jobs.demo``."""

from __future__ import annotations

import argparse

HELP = ("simplify the bundled default asset (100k-triangle painted knot -> 2,000 triangles) in ~4 minutes; "
        "--cards: a generated shrub as alpha-textured cards")

DEMO_TIME_BUDGET = "4m"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("-o", "--output", metavar="OUTDIR", default=None,
                        help="output folder (default: ./lookalike-demo, with --cards ./lookalike-cards-demo)")
    parser.add_argument("--cards", action="store_true", help="approximate a generated shrub (thousands of "
                        "alpha-textured leaves) with 0.5 %% of its triangles as cards instead (lookalike cards)")
    parser.add_argument("--time-budget", metavar="T", default=DEMO_TIME_BUDGET,
                        help=f"wall time for the whole run (default {DEMO_TIME_BUDGET})")
    parser.add_argument("--force", action="store_true", help="overwrite an existing OUTDIR")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    from ..settings import parse_duration
    from ..jobs.demo import DEMO_CARDS_SHARE, DEMO_TRIANGLES, demo, demo_cards

    time_budget = parse_duration(args.time_budget)
    options = {"time_budget": time_budget, "force": args.force, "progress": not args.quiet}
    if args.cards:
        print(f"lookalike demo --cards: a generated shrub as cards ({100 * DEMO_CARDS_SHARE:.1f} % of its triangles) "
              f"in {args.time_budget} ...")
        result = demo_cards(args.output or "lookalike-cards-demo", **options)
        compared = "plain decimation, the billboard cloud we start from"
    else:
        print(f"lookalike demo: simplifying a generated 100,000-triangle painted knot to {DEMO_TRIANGLES:,} "
              f"triangles in {args.time_budget} ...")
        result = demo(args.output or "lookalike-demo", **options)
        compared = "plain decimation, the classic bake"
    print(result.summary())
    print(f"\nOpen {result.report} in a browser to compare the reference, {compared} and ours.")
    return 130 if result.interrupted else 0
