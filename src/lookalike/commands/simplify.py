"""``lookalike simplify INPUT``: the whole job, a thin layer over ``lookalike.jobs.simplify``."""

from __future__ import annotations

import argparse

from ._options import add_fit_arguments, add_job_arguments, add_reference_arguments, add_run_arguments, run_keywords

HELP = "simplify an asset: a low-poly model with textures that renders like the input"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..jobs.simplify import SIMPLIFY

    add_job_arguments(parser, "simplify", SIMPLIFY.outdir_suffix, SIMPLIFY.defaults)
    add_fit_arguments(parser, SIMPLIFY.defaults)
    parser.add_argument("--init-mesh", metavar="LOD", help="start from this low-poly mesh (e.g. an existing LOD that "
                        "looks wrong) instead of our decimation; its UVs and textures are kept where they form an atlas")
    parser.add_argument("--screen-size", type=int, metavar="PX", help="prefilter for this size on screen (the "
                        "bounding sphere's diameter in pixels), as each level of lookalike lod is: views at that size, "
                        "the reference supersampled, the model drawn with one sample per pixel, textures sized to it "
                        "(unless --resolution or --texture-size say otherwise)")
    pose = parser.add_mutually_exclusive_group()
    pose.add_argument("--static", action="store_true", help="for a skinned, animated input: simplify its bind "
                        "pose into a still model (without this, the model and its skinning weights are fitted over the "
                        "animations and model.glb keeps the skeleton and clips)")
    pose.add_argument("--compare-static", action="store_true", help="for a skinned, animated input: also run the "
                        "bind-pose fit (--static, its own time budget) into OUTDIR/bind-pose-fit/ and score it, with "
                        "the input's weights transferred, beside ours in the report (twice the time)")
    add_reference_arguments(parser, SIMPLIFY.defaults)
    add_run_arguments(parser)
    parser.add_argument("--judge", choices=("blender",), default=None,
                        help="afterwards, also render the input, plain decimation, our classic bake, Blender's own "
                             "decimate + bake and ours in Blender Cycles on the held-out views and score them "
                             "(OUTDIR/judge/, and \"judge\" in metrics.json; minutes more; needs "
                             "pip install -e \".[judge]\")")


def run(args: argparse.Namespace) -> int:
    from ..jobs.simplify import simplify

    if args.judge is not None:
        from ..blender import require_judge

        require_judge()
    keywords = run_keywords(args)
    if args.screen_size is not None:
        from ..jobs.lod import screen_size_settings

        keywords = {**screen_size_settings(args.screen_size), **{k: v for k, v in keywords.items() if v is not None}}
    result = simplify(args.input, args.output, init_mesh=args.init_mesh, static=True if args.static else None,
                      compare_static=args.compare_static, **keywords)
    print(result.summary())
    if args.judge is not None and not result.interrupted:
        from ..jobs.judge import judge_run, judge_summary, reference_of_run

        judged = judge_run(result.outdir, reference_of_run(result.outdir, input_path=args.input), result.baselines)
        print(judge_summary(judged))
    return 130 if result.interrupted else 0
