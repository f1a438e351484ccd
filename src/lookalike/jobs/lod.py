"""``lod``: a chain of levels of detail, each prefiltered for the size it is drawn at (paper
Sec. 5.2): a level seen at 64 pixels is fitted to what the input looks like at 64 pixels.

A level is a triangle count and a screen size: the pixels that the bounding sphere's diameter
covers where the level is drawn. Each level is the shared run (``jobs.run``) of ``simplify``'s
application with the settings of its size (``level_settings``): views that show the sphere at
that size, the reference supersampled ``SUPERSAMPLING`` x ``SUPERSAMPLING`` per pixel, the model
drawn with one sample per pixel and mipmapped lookups, as an engine draws it, and textures
sized to the level. Each level runs in ``OUTDIR/lodK/`` with its own checkpoint and report; a
chain run again resumes an interrupted level and keeps the finished ones. The time budget is
the chain's, split over the levels by their pixel counts. ``lods.json`` lists the levels.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

from ..asset import Asset
from ..errors import ConfigError
from ..io.atomic import write_text_atomic
from ..settings import Config, with_overrides
from ..shading.view_sampling import FRAMING
from .outdir import CHECKPOINT_NAME, check_outdir
from .outputs import METRICS_NAME
from .run import run
from .simplify import SIMPLIFY

SUPERSAMPLING = 8
"""Reference samples per pixel and axis: enough that a small level's target is free of aliasing."""

TEXELS_PER_PIXEL = 4
"""Texture side per screen pixel of the level (a power of two, at least ``MIN_TEXTURE_SIZE``)."""

MIN_TEXTURE_SIZE = 64
MIN_TRIANGLES = 100
"""The default chain's coarsest level keeps at least this many triangles."""
CHAIN_BUDGET = 900.0
"""The whole chain's default time budget, in seconds."""


@dataclass(frozen=True)
class Level:
    """One level of the chain: ``triangles``, drawn where the bounding sphere covers
    ``pixels`` pixels across."""

    triangles: int
    pixels: int


def parse_levels(text: str) -> list[Level]:
    """``"8000@512,2000@128"`` as levels, finest first; ``ConfigError`` naming the bad part."""
    levels = []
    for part in text.split(","):
        count, _, pixels = part.strip().partition("@")
        if not (count.isdigit() and pixels.isdigit() and int(count) > 0 and int(pixels) >= 8):
            raise ConfigError(f"--levels: {part.strip()!r} is not TRIANGLES@PIXELS (e.g. 2000@128, pixels >= 8)")
        levels.append(Level(int(count), int(pixels)))
    return sorted(levels, key=lambda level: -level.pixels)


def default_levels(input_triangles: int, ratio: float) -> list[Level]:
    """A chain for an input of ``input_triangles``: ``ratio`` of them at 512 pixels, then a
    quarter of the triangles at half the size, while a level keeps at least ``MIN_TRIANGLES``."""
    levels = [Level(max(MIN_TRIANGLES, round(input_triangles * ratio)), 512)]
    while levels[-1].triangles // 4 >= MIN_TRIANGLES and levels[-1].pixels >= 32:
        levels.append(Level(levels[-1].triangles // 4, levels[-1].pixels // 2))
    return levels


def level_settings(level: Level, seconds: float) -> dict:
    """The settings of ``level``'s run: the picture framing the sphere at ``level.pixels``
    across (``FRAMING``), supersampled reference, one sample per pixel for the model, textures
    of ``TEXELS_PER_PIXEL`` texels per pixel, ``seconds`` of budget."""
    texture = max(MIN_TEXTURE_SIZE, 2 ** math.ceil(math.log2(level.pixels * TEXELS_PER_PIXEL)))
    return {"triangles": level.triangles, "resolution": max(16, math.ceil(level.pixels * FRAMING)),
            "target_spp": SUPERSAMPLING, "latent_msaa": 1, "texture_size": min(texture, 4096),
            "time_budget": seconds}


def lod(input: str | Path | Asset, outdir: str | Path, levels: list[Level], *, config: Config | str | Path | None = None,
        time_budget: float = CHAIN_BUDGET, **options) -> list[dict]:
    """Fit the chain ``levels`` of ``input`` into ``outdir/lod0 ...``; returns ``lods.json``'s
    levels (each: triangles, pixels, texture size, the run's folder and held-out scores).
    ``options``: the run options (``jobs.run.RunOptions``); with ``resume``, finished levels are
    kept and an interrupted one resumed, else ``outdir`` is refused where it holds anything,
    unless ``force``."""
    outdir = Path(outdir)
    resume = options.pop("resume", False)
    if not resume:
        check_outdir(outdir, force=options.get("force", False), resume=False)
    weights = [max(level.pixels, 64) ** 2 for level in levels]
    rows = []
    for k, (level, weight) in enumerate(zip(levels, weights)):
        folder = outdir / f"lod{k}"
        settings = level_settings(level, time_budget * weight / sum(weights))
        if not (resume and _finished(folder)):
            run(SIMPLIFY, input, folder, config=config, **settings,
                **{**options, "resume": resume and (folder / CHECKPOINT_NAME).is_file(), "force": True})
        metrics = json.loads((folder / METRICS_NAME).read_text())
        rows.append({"level": k, "triangles": metrics["triangles"]["output"], "pixels": level.pixels,
                     "texture_size": with_overrides(config, defaults=SIMPLIFY.defaults, **settings).latent.texture_size,
                     "folder": folder.name, "psnr": metrics["heldout"]["ours"]["psnr"],
                     "flip": metrics["heldout"]["ours"]["flip"], "interrupted": metrics["interrupted"]})
        if metrics["interrupted"]:
            break
    write_text_atomic(outdir / "lods.json", json.dumps({"levels": rows}, indent=2))
    return rows


def _finished(folder: Path) -> bool:
    """A level's run wrote its outputs and left no checkpoint to resume."""
    return (folder / METRICS_NAME).is_file() and not (folder / CHECKPOINT_NAME).exists()
