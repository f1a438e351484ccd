"""Options shared by the commands that turn assets into low-poly models in folders
(``simplify``, ``bake``, ``batch``)."""

from __future__ import annotations

import argparse

from ..limits import MAX_RESOLUTION, MAX_TEXTURE_SIZE, MAX_WORKERS

INITS = ("bake", "source", "average", "random")   # lookalike.fit.config.INITS, without importing torch


def add_job_arguments(parser: argparse.ArgumentParser, verb: str, outdir_suffix: str) -> None:
    """``INPUT``, ``-o OUTDIR`` and the target count (``--triangles N`` or ``--ratio R``)."""
    parser.add_argument("input", help=f"the asset to {verb} (glTF/GLB, OBJ, PLY)")
    parser.add_argument("-o", "--output", metavar="OUTDIR", default=None,
                        help=f"output folder (default: INPUT's name + '{outdir_suffix}' in the current folder)")
    add_count_arguments(parser)


def add_count_arguments(parser: argparse.ArgumentParser) -> None:
    """The target count: ``--triangles N`` or ``--ratio R``."""
    count = parser.add_mutually_exclusive_group()
    count.add_argument("--triangles", type=int, metavar="N", help="target triangle count")
    count.add_argument("--ratio", type=float, metavar="R", help="target count as a fraction of the input's (default 0.02)")


def add_fit_arguments(parser: argparse.ArgumentParser, init: bool = True) -> None:
    """The settings of an optimisation run that a user sets on the command line (``--init``
    where ``init``: the jobs whose textures may start in several ways)."""
    parser.add_argument("--texture-size", type=int, metavar="S",
                        help=f"side of the square textures (default 1024, at most {MAX_TEXTURE_SIZE})")
    parser.add_argument("--resolution", type=int, metavar="PX",
                        help=f"side of the training images (default 512, at most {MAX_RESOLUTION})")
    length = parser.add_mutually_exclusive_group()
    length.add_argument("--time-budget", metavar="T",
                        help="wall time for the whole run: 90s, 10m, 1h or seconds (default 10m)")
    length.add_argument("--iterations", type=int, metavar="N", help="number of optimisation steps (overrides the budget)")
    if init:
        parser.add_argument("--init", choices=INITS, help="how the textures start: the classic projection bake "
                            "(default), the input's own maps, its mean material, or noise as in the paper")
    parser.add_argument("--seed", type=int, metavar="S", help="random seed (default 0): same seed, same result")
    parser.add_argument("--config", metavar="RUN.toml", help="settings file (e.g. a previous run's config.toml)")
    parser.add_argument("--obj", action="store_true", help="also write model.obj (+ .mtl and PNG textures)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def add_run_arguments(parser: argparse.ArgumentParser) -> None:
    """``--resume``, ``--force``, ``--threads`` and ``--profile``: how one run of a job goes."""
    parser.add_argument("--resume", action="store_true", help="continue the interrupted run in OUTDIR")
    parser.add_argument("--force", action="store_true", help="overwrite an existing OUTDIR")
    parser.add_argument("--threads", type=int, metavar="N", help="threads for torch, Numba and Embree, pinned "
                        "(default: the cores this process may use, less those other busy programs keep using while it "
                        "optimises)")
    parser.add_argument("--profile", action="store_true", help="record where the time goes: wall and CPU seconds of "
                        "each phase (load, decimation, bake, views, forward, backward, ...) in metrics.json, "
                        "\"profile\"")


def apply_threads(args: argparse.Namespace) -> None:
    """Pin the thread count ``--threads`` where given (``ConfigError`` outside [1, MAX_WORKERS])."""
    from ..errors import ConfigError
    from ..threads import set_threads

    if args.threads is not None:
        if not 1 <= args.threads <= MAX_WORKERS:
            raise ConfigError(f"--threads must lie in [1, {MAX_WORKERS}], not {args.threads}")
        set_threads(args.threads)


def fit_options(args: argparse.Namespace) -> dict:
    """The keyword arguments of ``lookalike.jobs.simplify.simplify`` (and ``cards``) that
    ``add_count_arguments`` and ``add_fit_arguments`` set (``None`` where not given; ``init``
    only where the command has it)."""
    from ..fit.config_file import parse_duration

    init = {"init": args.init} if hasattr(args, "init") else {}
    return {"triangles": args.triangles, "ratio": args.ratio, "texture_size": args.texture_size,
            "resolution": args.resolution,
            "time_budget": None if args.time_budget is None else parse_duration(args.time_budget),
            "iterations": args.iterations, "seed": args.seed, "config": args.config,
            "export_obj": True if args.obj else None, **init}
