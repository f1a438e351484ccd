"""``lookalike displace INPUT``: a base mesh with displacement, normal and PBR maps that looks
right at every tessellation level, a thin layer over ``lookalike.jobs.displace``."""

from __future__ import annotations

import argparse

from ..errors import ConfigError
from ..settings import SHADING_CONVENTIONS
from ._options import add_fit_arguments, add_job_arguments, add_run_arguments, default_text, run_keywords

HELP = "fit a base mesh with displacement and normal maps that looks like the input at every tessellation level"


def parse_tessellation_levels(text: str) -> tuple[int, ...]:
    """``"0,1,2,3"`` as levels; ``ConfigError`` naming the bad part."""
    parts = [part.strip() for part in text.split(",")]
    if not all(part.isdigit() for part in parts):
        raise ConfigError(f"--levels: {text!r} is not a list of levels such as 0,1,2,3")
    return tuple(int(part) for part in parts)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..jobs.displace import DISPLACE

    add_job_arguments(parser, "displace", DISPLACE.outdir_suffix, DISPLACE.defaults, base=True)
    parser.add_argument("--levels", metavar="L,L,...", default=None,
                        help="the tessellation levels (each subdivides every triangle into 4) the result must look "
                             "right at " + default_text(DISPLACE.defaults, "tessellation_levels",
                                                        lambda levels: ",".join(map(str, levels))))
    parser.add_argument("--shading", choices=SHADING_CONVENTIONS, default=None,
                        help="engine: vertices move along the base's interpolated normals, which also shade them "
                             "(tessellating engines: Unreal, Unity, DX11/Vulkan hull and domain shaders; lodK.glb "
                             "carries those normals); recomputed: shading follows the displaced geometry (Blender's "
                             "Displace modifier, Cycles' true displacement) "
                             + default_text(DISPLACE.defaults, "displacement_shading", str))
    add_fit_arguments(parser, DISPLACE.defaults, init=False)
    add_run_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from ..jobs.displace import displace

    levels = None if args.levels is None else parse_tessellation_levels(args.levels)
    result = displace(args.input, args.output, tessellation_levels=levels, displacement_shading=args.shading,
                      **run_keywords(args))
    print(result.summary())
    return 130 if result.interrupted else 0
