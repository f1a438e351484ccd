"""``lookalike cards INPUT``: foliage as alpha-textured cards, a thin layer over
``lookalike.jobs.cards``."""

from __future__ import annotations

import argparse

from ._options import add_fit_arguments, add_job_arguments, add_run_arguments, apply_threads, fit_options

HELP = "approximate foliage and other aggregate geometry with alpha-textured cards fitted by appearance"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_job_arguments(parser, verb="approximate with cards", outdir_suffix="-cards")
    add_fit_arguments(parser, init=False)
    parser.add_argument("--alpha", choices=("mask", "blend"), default=None,
                        help="how model.glb draws alpha: mask (default: alpha-tested at a cutoff the fit chooses, "
                             "drawn without sorting by every engine) or blend")
    add_run_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from ..jobs.cards import cards

    apply_threads(args)
    result = cards(args.input, args.output, alpha=args.alpha, resume=args.resume, force=args.force,
                   progress=not args.quiet, profile=args.profile, **fit_options(args))
    print(result.summary())
    return 130 if result.interrupted else 0
