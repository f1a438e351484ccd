"""``lookalike bake INPUT``: the classic pipeline (decimate, unwrap, projection-bake the input's
normals and materials), a thin layer over ``lookalike.init.bake_job.bake_asset``."""

from __future__ import annotations

import argparse

HELP = "decimate, unwrap and bake an asset the classic way (the baseline simplify beats)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("input", help="the asset to bake (glTF/GLB, OBJ, PLY)")
    parser.add_argument("-o", "--output", metavar="OUTDIR", default=None,
                        help="output folder (default: INPUT's name + '-baked' in the current folder)")
    count = parser.add_mutually_exclusive_group()
    count.add_argument("--triangles", type=int, metavar="N", help="target triangle count")
    count.add_argument("--ratio", type=float, metavar="R", help="target count as a fraction of the input's (default 0.02)")
    parser.add_argument("--texture-size", type=int, default=1024, metavar="S",
                        help="side of the square baked textures (default 1024)")
    parser.add_argument("--cage", type=float, metavar="D",
                        help="ray reach on each side of the low-poly surface, in the asset's units "
                             "(default 2%% of the bounding-box diagonal)")
    parser.add_argument("--force", action="store_true", help="overwrite an existing OUTDIR")


def run(args: argparse.Namespace) -> int:
    from ..init.bake_job import bake_asset

    result = bake_asset(args.input, args.output, triangles=args.triangles, ratio=args.ratio,
                        texture_size=args.texture_size, cage=args.cage, force=args.force)
    print(result.summary())
    return 0
