"""``lookalike bench NAME``: run a benchmark from ``lookalike.bench`` and print its table
(or one JSON object with ``--json``)."""

from __future__ import annotations

import argparse
import importlib
import json

from ..bench import benchmark_modules

HELP = "run a benchmark and print its figures"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("name", choices=sorted(benchmark_modules()), help="which benchmark")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    parser.add_argument("--repeats", type=int, default=None, help="timed repetitions (default: the benchmark's own)")
    parser.add_argument("--out", default=None, help="keep the outputs of benchmarks that write files in this folder")


def run(args: argparse.Namespace) -> int:
    module = importlib.import_module(f"lookalike.bench.{benchmark_modules()[args.name]}")
    kwargs = {} if args.repeats is None else {"repeats": args.repeats}
    if args.out is not None:
        kwargs["out"] = args.out
    result = module.run(**kwargs)
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print(module.format_table(result))
    return 0
