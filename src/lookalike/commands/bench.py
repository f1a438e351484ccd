"""``lookalike bench NAME``: run a benchmark from ``lookalike.bench`` and print its table
(or one JSON object with ``--json``)."""

from __future__ import annotations

import argparse
import importlib
import inspect
import json

from ..bench import benchmark_modules
from ..bench.quality import ASSETS, JUDGES, select_assets
from ..bench.cards import ASSETS as CARDS_ASSETS
from ..bench.decimate import ASSETS as DECIMATE_ASSETS
from ..bench.pathtraced import ASSETS as PATHTRACED_ASSETS
from ..bench.skinned import ASSETS as SKINNED_ASSETS
from ..errors import ConfigError
from ..settings import DEVICES, parse_duration

HELP = "run a benchmark and print its figures"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("name", choices=sorted(benchmark_modules()), help="which benchmark")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    parser.add_argument("--repeats", type=int, default=None, help="timed repetitions (default: the benchmark's own)")
    parser.add_argument("--out", default=None, help="keep the outputs of benchmarks that write files in this folder")
    parser.add_argument("--asset", action="append", default=None, metavar="NAME",
                        help="run only this benchmark asset (repeatable; quality and warmstart: "
                             + ", ".join(case.name for case in ASSETS) + "; skinned: "
                             + ", ".join(case.name for case in SKINNED_ASSETS) + "; cards: "
                             + ", ".join(case.name for case in CARDS_ASSETS) + "; decimate: "
                             + ", ".join(case.name for case in DECIMATE_ASSETS) + "; pathtraced: "
                             + ", ".join(case.name for case in PATHTRACED_ASSETS) + ")")
    parser.add_argument("--assets-dir", default=None, metavar="DIR",
                        help="folder holding the benchmark assets (quality, warmstart, repair, contention, lod, decimate and pathtraced; default: "
                             "../shared/assets beside the source checkout)")
    parser.add_argument("--judge", choices=JUDGES, default=None,
                        help="blender (quality, skinned, cards, displace, implicit; decimate: Blender's Decimate "
                             "alone; pathtraced: Cycles under the sky; cards: Blender's Decimate, and three.js "
                             "with and without shadows too): also render every method in Blender "
                             "Cycles (shadows on and off) and run Blender's own decimate + bake; needs pip install -e "
                             "\".[judge]\"; three (lod): also draw every level of both chains in three.js (headless "
                             "Chromium, see the README)")
    parser.add_argument("--device", choices=DEVICES, default=None,
                        help="quality and render: where the tensors live and the kernels run (default: auto, the GPU "
                             "where torch sees one and numba-cuda is installed)")
    parser.add_argument("--time-budget", metavar="T", default=None,
                        help="benchmarks that run the tool (quality, cards, skinned, ...): wall time of each run, "
                             "90s, 10m or seconds (default: the benchmark's own, mostly 10 minutes)")
    parser.add_argument("--reuse", action="store_true",
                        help="quality and skinned: take the runs already in --out instead of simplifying again (with --judge: "
                             "judge earlier runs); lod: keep the levels already fitted in --out and score them again")


def run(args: argparse.Namespace) -> int:
    module = importlib.import_module(f"lookalike.bench.{benchmark_modules()[args.name]}")
    kwargs = {} if args.repeats is None else {"repeats": args.repeats}
    if args.out is not None:
        kwargs["out"] = args.out
    cases = getattr(module, "ASSETS", ASSETS)
    asset_options = {"--asset": ("assets", select_assets(args.asset, cases) if args.asset else None),
                     "--assets-dir": ("assets_dir", args.assets_dir), "--judge": ("judge", args.judge),
                     "--reuse": ("reuse", True if args.reuse else None), "--device": ("device", args.device),
                     "--time-budget": ("time_budget", None if args.time_budget is None else parse_duration(args.time_budget))}
    for flag, (parameter, value) in asset_options.items():
        if value is None:
            continue
        if parameter not in inspect.signature(module.run).parameters:
            raise ConfigError(f"{flag}: bench {args.name} does not take it")
        kwargs[parameter] = value
    result = module.run(**kwargs)
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print(module.format_table(result))
    return 0
