"""``lookalike cards INPUT``: foliage as alpha-textured cards, a thin layer over
``lookalike.jobs.cards``."""

from __future__ import annotations

import argparse

from ._options import add_fit_arguments, add_job_arguments, add_run_arguments, default_text, run_keywords

HELP = "approximate foliage and other aggregate geometry with alpha-textured cards fitted by appearance"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..jobs.cards import CARDS

    add_job_arguments(parser, "approximate with cards", CARDS.outdir_suffix, CARDS.defaults)
    add_fit_arguments(parser, CARDS.defaults, init=False)
    parser.add_argument("--alpha", choices=("mask", "blend"), default=None,
                        help="how model.glb draws alpha: mask (alpha-tested at a cutoff the fit chooses, drawn "
                             f"without sorting by every engine) or blend {default_text(CARDS.defaults, 'alpha_mode')}")
    add_run_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from ..jobs.cards import cards

    result = cards(args.input, args.output, alpha_mode=args.alpha, **run_keywords(args))
    print(result.summary())
    return 130 if result.interrupted else 0
