"""``lookalike simplify INPUT``: the whole job, a thin layer over ``lookalike.jobs.simplify``."""

from __future__ import annotations

import argparse

from ._options import add_job_arguments

INITS = ("bake", "source", "average", "random")   # lookalike.fit.config.INITS, without importing torch

HELP = "simplify an asset: a low-poly model with textures that renders like the input"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_job_arguments(parser, verb="simplify", outdir_suffix="-lookalike")
    parser.add_argument("--texture-size", type=int, metavar="S", help="side of the square textures (default 1024)")
    parser.add_argument("--resolution", type=int, metavar="PX", help="side of the training images (default 512)")
    length = parser.add_mutually_exclusive_group()
    length.add_argument("--time-budget", metavar="T",
                        help="wall time for the whole run: 90s, 10m, 1h or seconds (default 10m)")
    length.add_argument("--iterations", type=int, metavar="N", help="number of optimisation steps (overrides the budget)")
    parser.add_argument("--init", choices=INITS, help="how the textures start: the classic projection bake (default), "
                        "the input's own maps, its mean material, or noise as in the paper")
    parser.add_argument("--init-mesh", metavar="LOD", help="start from this low-poly mesh (e.g. an existing LOD that "
                        "looks wrong) instead of our decimation; its UVs and textures are kept where they form an atlas")
    parser.add_argument("--seed", type=int, metavar="S", help="random seed (default 0): same seed, same result")
    parser.add_argument("--config", metavar="RUN.toml", help="settings file (e.g. a previous run's config.toml)")
    parser.add_argument("--resume", action="store_true", help="continue the interrupted run in OUTDIR")
    parser.add_argument("--force", action="store_true", help="overwrite an existing OUTDIR")
    parser.add_argument("--obj", action="store_true", help="also write model.obj (+ .mtl and PNG textures)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args: argparse.Namespace) -> int:
    from ..fit.config_file import parse_duration
    from ..jobs.simplify import simplify

    result = simplify(
        args.input, args.output,
        triangles=args.triangles, ratio=args.ratio, texture_size=args.texture_size, resolution=args.resolution,
        time_budget=None if args.time_budget is None else parse_duration(args.time_budget),
        iterations=args.iterations, init=args.init, init_mesh=args.init_mesh, seed=args.seed, config=args.config, resume=args.resume, force=args.force,
        export_obj=True if args.obj else None, progress=not args.quiet,
    )
    print(result.summary())
    return 130 if result.interrupted else 0
