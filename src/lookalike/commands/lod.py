"""``lookalike lod INPUT -o OUTDIR``: a chain of levels of detail, each prefiltered for its
screen size; a thin layer over ``lookalike.jobs.lod``."""

from __future__ import annotations

import argparse

from ._options import add_compress_argument, add_reference_arguments, add_run_arguments

HELP = "a chain of levels of detail, each fitted to how the input looks at the size it is drawn at"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..jobs.lod import CHAIN_BUDGET, LEVEL, MIN_TRIANGLES

    parser.add_argument("input", help="the asset (glTF/GLB, OBJ, PLY)")
    parser.add_argument("-o", "--output", metavar="OUTDIR", required=True, help="folder for lod0/, lod1/, ... and "
                        "lods.json")
    parser.add_argument("--levels", metavar="N@PX,...", help="triangles@pixels per level, e.g. 8000@512,2000@128,"
                        "500@32 (pixels: the bounding sphere's diameter on screen; default: "
                        f"{LEVEL.defaults.latent.ratio:g} of the input's triangles at 512 px, then a quarter of the "
                        f"triangles at half the size, down to about {MIN_TRIANGLES} triangles)")
    parser.add_argument("--time-budget", metavar="T", default=f"{CHAIN_BUDGET:g}",
                        help=f"wall time for the whole chain: 90s, 15m, 1h or seconds (default {CHAIN_BUDGET:g})")
    parser.add_argument("--config", metavar="RUN.toml", help="settings file for every level")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    add_compress_argument(parser)
    add_reference_arguments(parser, LEVEL.defaults)
    add_run_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from .. import io
    from ..jobs.lod import LEVEL, default_levels, lod, parse_levels
    from ..settings import parse_duration

    asset = io.load(args.input)
    levels = parse_levels(args.levels) if args.levels else default_levels(asset.mesh.num_triangles,
                                                                         LEVEL.defaults.latent.ratio)
    settings = {key: value for key, value in (("renderer", args.reference), ("lighting", args.lighting),
                                               ("spp", args.spp), ("unlit", args.unlit or None),
                                               ("compress", args.compress or None), ("device", args.device))
                if value is not None}
    rows = lod(asset, args.output, levels, config=args.config, time_budget=parse_duration(args.time_budget),
               resume=args.resume, force=args.force, progress=not args.quiet, profile=args.profile,
               threads=args.threads, **settings)
    for row in rows:
        print(f"lod{row['level']}: {row['triangles']:,} triangles at {row['pixels']} px, {row['texture_size']}^2 "
              f"textures: PSNR {row['psnr']:.2f} dB, FLIP {row['flip']:.4f}{_compressed(row)} "
              f"({row['folder']}/report.html)")
    return 130 if rows and rows[-1]["interrupted"] else 0


def _compressed(row: dict) -> str:
    """``"; N KB, compressed M KB: PSNR ..., FLIP ..."`` where the level was also written compressed."""
    if "compressed" not in row:
        return ""
    c = row["compressed"]
    return (f"; {row['file_bytes'] / 1024:,.0f} KB, compressed {c['file_bytes'] / 1024:,.0f} KB: PSNR "
            f"{c['psnr']:.2f} dB, FLIP {c['flip']:.4f}")
