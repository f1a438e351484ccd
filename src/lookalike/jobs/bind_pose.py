"""The bind-pose fit of an animated run (``compare_static``): the same run with
``latent.static``, a budget, checkpoint and report of its own, in ``OUTDIR/bind-pose-fit/``;
what fitting the animations gains is ours against it."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

from .. import io
from ..asset import Asset
from ..settings import Config
from .outdir import CHECKPOINT_NAME
from .outputs import METRICS_NAME, MODEL_NAME

BIND_POSE_FOLDER = "bind-pose-fit"
"""Where ``compare_static`` runs the bind-pose fit, inside the output folder."""
BIND_POSE_STAGE = "bind-pose fit (a run of its own)"
"""The stage of the timings that holds it."""


def bind_pose_fit(run: Callable, input, outdir: Path, cfg: Config, options) -> tuple[Asset | None, bool]:
    """``run(input, outdir/BIND_POSE_FOLDER, ...)`` with ``cfg``'s settings and
    ``latent.static`` (``run``: the application's run), and its model. Where the animated run
    is resumed, a finished bind-pose fit is taken as it is and an interrupted one resumed; a
    fresh run makes it afresh.

    Returns:
        ``(model, interrupted)``: the still model (``None`` if it was interrupted) and whether
        it was.
    """
    folder = outdir / BIND_POSE_FOLDER
    resume = options.resume
    if resume and (folder / METRICS_NAME).is_file() and not (folder / CHECKPOINT_NAME).exists():
        return io.load(folder / MODEL_NAME), False
    static = dataclasses.replace(cfg, latent=dataclasses.replace(cfg.latent, static=True))
    result = run(input, folder, config=static, resume=resume and (folder / CHECKPOINT_NAME).is_file(), force=True,
                 material_override=options.material_override, progress=options.progress)
    return (None, True) if result.interrupted else (io.load(result.model), False)
