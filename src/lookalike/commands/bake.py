"""``lookalike bake INPUT``: the classic pipeline (decimate, unwrap, projection-bake the input's
normals and materials), a thin layer over ``lookalike.jobs.bake.bake_asset``."""

from __future__ import annotations

import argparse

from ..limits import MAX_BAKE_TEXTURE_SIZE
from ..settings import Config
from ._options import add_job_arguments, default_text

HELP = "decimate, unwrap and bake an asset the classic way (the baseline simplify beats)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..init.projection_bake import DEFAULT_CAGE_FRACTION
    from ..jobs.bake import OUTDIR_SUFFIX

    add_job_arguments(parser, "bake", OUTDIR_SUFFIX, Config())
    parser.add_argument("--texture-size", type=int, metavar="S", help="side of the square baked textures "
                        f"{default_text(Config(), 'texture_size')}, at most {MAX_BAKE_TEXTURE_SIZE}")
    parser.add_argument("--cage", type=float, metavar="D",
                        help="ray reach on each side of the low-poly surface, in the asset's units "
                             f"(default: {100 * DEFAULT_CAGE_FRACTION:g}%% of the bounding-box diagonal)")
    parser.add_argument("--force", action="store_true", help="overwrite an existing OUTDIR")


def run(args: argparse.Namespace) -> int:
    from ..jobs.bake import bake_asset

    result = bake_asset(args.input, args.output, triangles=args.triangles, ratio=args.ratio,
                        texture_size=args.texture_size, cage=args.cage, force=args.force)
    print(result.summary())
    return 0
