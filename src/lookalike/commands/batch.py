"""``lookalike batch INPUTS... -o OUTROOT``: ``simplify`` over many assets on Ray, a thin layer
over ``lookalike.jobs.batch``."""

from __future__ import annotations

import argparse

from ..limits import MAX_WORKERS
from ._options import add_count_arguments, add_fit_arguments, settings_keywords

HELP = "simplify many assets (files or folders) on a local Ray instance or a Ray cluster"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("inputs", nargs="+", metavar="INPUT", help="asset files, or folders of them")
    parser.add_argument("-o", "--output", metavar="OUTROOT", required=True,
                        help="folder for one output folder per asset, logs/ and index.html")
    parser.add_argument("--workers", type=int, metavar="N",
                        help="assets at once on the local Ray instance (default: one per two cores)")
    parser.add_argument("--address", metavar="ray://HOST:PORT",
                        help="run on this Ray cluster instead of a local instance started for the batch")
    parser.add_argument("--cpus-per-task", type=int, metavar="C",
                        help="CPUs (and threads) per asset (default: the cores / --workers; 2 on a cluster)")
    from ..jobs.simplify import SIMPLIFY

    add_count_arguments(parser, SIMPLIFY.defaults)
    add_fit_arguments(parser, SIMPLIFY.defaults)


def run(args: argparse.Namespace) -> int:
    from ..errors import ConfigError
    from ..jobs.batch import batch

    for name in ("workers", "cpus_per_task"):
        value = getattr(args, name)
        if value is not None and not 1 <= value <= MAX_WORKERS:
            raise ConfigError(f"--{name.replace('_', '-')} must lie in [1, {MAX_WORKERS}], not {value}")
    result = batch(args.inputs, args.output, workers=args.workers, address=args.address,
                   cpus_per_task=args.cpus_per_task, progress=not args.quiet, **settings_keywords(args))
    print(result.summary())
    return 0 if all(status == "done" for status in result.statuses.values()) else 1
