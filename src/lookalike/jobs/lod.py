"""``lod``: a chain of levels of detail, each prefiltered for the size it is drawn at (paper
Sec. 5.2): a level seen at 64 pixels is fitted to what the input looks like at 64 pixels.

A level is a triangle count and a screen size: the pixels that the bounding sphere's diameter
covers where the level is drawn. Each level is the shared run (``jobs.run``) of ``LEVEL``:
``simplify``'s initial guess (below the first level, the level above decimated where that scores
higher: ``level_guess``), with its defaults (the reference supersampled 8 x 8 per pixel, the
model drawn with one sample per pixel and mipmapped lookups, as an engine draws it) and the
settings of its size (``level_settings``: views that show the sphere at that size, textures
sized to the level). Each level runs in ``OUTDIR/lodK/`` with its own checkpoint and report; a
chain run again resumes an interrupted level and keeps the finished ones. The time budget is
the chain's, split over the levels by their sizes (``level_budgets``). ``lods.json`` lists the
levels; ``lods.glb`` holds them as engines load a chain (``MSFT_lod``, nodes ``NAME_LOD0 ...``),
``lodK.glb`` each alone (with ``io.compress``, ``lodK.compressed.glb`` and ``lods.compressed.glb``
too), and ``report.html``
compares each with the classic level its run started from (``jobs.lod_page``). A compressed file
that fails (a tool that failed or hung) stops nothing: the chain and its other files are written,
and the chain then ends with ``OutputsIncomplete`` naming it.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from pathlib import Path

from .. import io
from ..asset import Asset
from ..errors import ConfigError, OutputsIncomplete
from ..init import decimate
from ..init.initial_guess import InitialGuess, initial_guess_from_mesh
from ..io.atomic import copy_atomic, write_text_atomic
from ..io.gltf_lod_chain import write_lod_chain
from ..io.gpu_memory import gpu_bytes
from ..limits import MAX_TEXTURE_SIZE
from ..settings import WARM_START, Config, OptimConfig, RenderConfig, ViewsConfig, load_config
from ..shading.view_sampling import FRAMING
from .alpha_export import merged_opaque
from .compressed_model import COMPRESSED_NAME, write_compressed_chain
from .input_asset import prepare_input
from .lod_page import CLASSIC_NAME, write_chain_page
from .outdir import CHECKPOINT_NAME, check_outdir
from .outputs import CONFIG_NAME, METRICS_NAME, MODEL_NAME, OptionalOutputs
from .run import Application, run
from .simplify import build_initial_guess

TEXELS_PER_PIXEL = 4
"""Texture side per screen pixel of the level (a power of two, at least ``MIN_TEXTURE_SIZE``)."""

VIEWPORT_HEIGHT = 1080
"""The viewport height, in pixels, that ``lods.json``'s switch distances are given for."""

FOVY_DEGREES = 60.0
"""The vertical field of view that ``lods.json``'s switch distances are given for."""

MIN_TEXTURE_SIZE = 64
MIN_PIXELS = 8
"""The smallest screen size a level may be fitted for."""
MIN_TRIANGLES = 100
"""The default chain's coarsest level keeps at least this many triangles."""
CHAIN_NAME = "lods.glb"
"""The chain in one file, as ``MSFT_lod`` lays it out (``io.gltf_lod_chain``)."""
COMPRESSED_CHAIN_NAME = "lods.compressed.glb"
"""The chain as engines ship it (``jobs.compressed_model``), with ``io.compress``."""

STEP_PIXELS = 512
"""The screen size that a baked start's position learning rate (``settings.WARM_START``) suits."""

BUDGET_MIN_PIXELS = 64
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
        if not (count.isdigit() and pixels.isdigit() and int(count) > 0 and int(pixels) >= MIN_PIXELS):
            raise ConfigError(f"--levels: {part.strip()!r} is not TRIANGLES@PIXELS (e.g. 2000@128, pixels >= "
                              f"{MIN_PIXELS})")
        levels.append(Level(int(count), int(pixels)))
    levels.sort(key=lambda level: -level.pixels)
    if len({level.pixels for level in levels}) < len(levels):
        raise ConfigError(f"--levels: two levels of one size in {text!r}: each level needs a size of its own")
    return levels


def default_levels(input_triangles: int, ratio: float) -> list[Level]:
    """A chain for an input of ``input_triangles``: ``ratio`` of them at 512 pixels, then a
    quarter of the triangles at half the size, while a level keeps at least ``MIN_TRIANGLES``."""
    levels = [Level(max(MIN_TRIANGLES, round(input_triangles * ratio)), 512)]
    while levels[-1].triangles // 4 >= MIN_TRIANGLES and levels[-1].pixels >= 32:
        levels.append(Level(levels[-1].triangles // 4, levels[-1].pixels // 2))
    return levels


def switch_coverages(levels: list[Level]) -> list[float]:
    """``MSFT_screencoverage`` of the chain (``io.gltf_lod_chain``): level ``k`` gives way to
    level ``k + 1`` where the sphere covers the geometric mean of their sizes, the last level to
    nothing at half its size; as fractions of ``VIEWPORT_HEIGHT`` (at most 1)."""
    sizes = [level.pixels for level in levels]
    bounds = [math.sqrt(a * b) for a, b in zip(sizes, sizes[1:])] + [sizes[-1] / 2]
    return [min(1.0, bound / VIEWPORT_HEIGHT) for bound in bounds]


def switch_distance(radius: float, pixels: float, fovy_degrees: float = FOVY_DEGREES,
                    viewport_height: int = VIEWPORT_HEIGHT) -> float:
    """The camera distance at which a sphere of ``radius`` covers ``pixels`` of a viewport
    ``viewport_height`` pixels high under the vertical field of view ``fovy``:
    ``d = viewport_height * radius / (pixels * tan(fovy / 2))`` (the sphere's diameter ``2 r``
    spans ``2 d tan(fovy / 2)`` world units of height at that distance); a level is drawn from
    there on out, until the next level's distance."""
    return viewport_height * radius / (pixels * math.tan(math.radians(fovy_degrees) / 2))


def classic_level(model: Asset, guess: InitialGuess, cfg: Config, folder: Path, methods: list) -> None:
    """Write the level's classic bake (decimation, atlas and projection bake at the level's count
    and texture size: its start, or a comparison where it started from the level above) as
    ``classic.glb``, which the chain's page draws beside ours."""
    compared = [asset for key, _, asset in guess.comparisons if key == "baked"]
    baked = guess.baked if guess.baked is not None else next(iter(compared), None)
    if baked is not None:
        io.save(baked, folder / CLASSIC_NAME)


def level_guess(asset: Asset, cfg: Config, count: int | None) -> InitialGuess:
    """``simplify``'s start (``build_initial_guess``: decimation and the classic bake) and, where
    ``cfg.io.level_above`` names the fitted model of the level above, that model decimated to
    ``count`` with its maps resampled to the level's size (``initial_guess_from_mesh``) as an
    alternative: the run starts from whichever scores higher on its validation views, since a
    fitted level may already hold what the next one needs (its silhouette, its prefiltered maps).
    Where that start cannot be built (no atlas of the level's size fits it), the note says so.
    The level above is decimated by the same guarded decimation as the input, and settled onto
    the input's surface through the same guard (``initial_guess_from_mesh``); how far it then
    strays is the alternative's distance, which becomes the start's if the run takes it."""
    guess = build_initial_guess(asset, cfg, count)
    if cfg.io.level_above and count is not None:
        above = merged_opaque(io.load(cfg.io.level_above))
        decimated = dataclasses.replace(above, mesh=decimate(above.mesh, count))
        try:
            settled = initial_guess_from_mesh(asset, decimated, "the level above", cfg.latent.texture_size,
                                              on_surface=True)
        except ConfigError as e:  # e.g. its charts, decimated, fit no atlas of the level's size
            guess.notes.append(f"the level above was not offered as a start: {e}")
            return guess
        label = f"the level above ({above.mesh.num_triangles} triangles) decimated"
        guess.alternatives.append((label, settled.start))
        guess.alternative_distances[label] = settled.start_distance
    return guess


LEVEL = Application(command="lod", outdir_suffix="-lods", initial_guess=level_guess,
                    defaults=Config(render=RenderConfig(target_spp=8, latent_msaa=1, mip_footprint="engine"),
                                    views=ViewsConfig(distance_spread=1.0), optim=OptimConfig(position_backoff=0.5)),
                    files=classic_level)
"""One level of the chain: ``simplify``'s start, fitted against a reference supersampled 8 x 8
per pixel (enough that a small level's target is free of aliasing), the model drawn with one
sample per pixel and the GPU's mip levels, as an engine draws it; training views put the object at its size times
0.71 to 1.41 (one octave), so that the mip levels on either side of its own are fitted too; a validation 0.5 dB
below the best halves the position rate, since a smooth surface wants smaller vertex steps than thin parts do."""


def screen_size_settings(pixels: int) -> dict:
    """The settings that fit a model for ``pixels`` across, as ``LEVEL`` does: the picture
    framing the sphere at that size (``FRAMING``), textures of ``TEXELS_PER_PIXEL`` texels per
    pixel (a power of two), the reference supersampled, the model drawn with one sample per
    pixel at the GPU's mip levels, the training distances spread around the size and the position rate backing off
    (``LEVEL.defaults``),
    and below ``STEP_PIXELS`` the baked start's position learning rate times ``STEP_PIXELS /
    pixels``, so that a vertex steps the same share of a pixel at every size: with the default
    a 32-pixel level's silhouette hardly moves in its share of the budget; and as many more
    validation and held-out views, which cost little at that size, so that the state kept is one
    whose gain of a fraction of a dB holds beyond a few views, and the scores reported are not
    those of a few views either. ``ConfigError`` below ``MIN_PIXELS``."""
    if pixels < MIN_PIXELS:
        raise ConfigError(f"a screen size must be at least {MIN_PIXELS} pixels, not {pixels}")
    texture = max(MIN_TEXTURE_SIZE, 2 ** math.ceil(math.log2(pixels * TEXELS_PER_PIXEL)))
    settings = {"resolution": max(16, math.ceil(pixels * FRAMING)), "texture_size": min(texture, MAX_TEXTURE_SIZE),
                "target_spp": LEVEL.defaults.render.target_spp, "latent_msaa": LEVEL.defaults.render.latent_msaa,
                "mip_footprint": LEVEL.defaults.render.mip_footprint,
                "distance_spread": LEVEL.defaults.views.distance_spread,
                "position_backoff": LEVEL.defaults.optim.position_backoff}
    if pixels < STEP_PIXELS:
        scale = STEP_PIXELS / pixels
        settings.update(lr_positions=WARM_START.lr_positions * scale,
                        validation=math.ceil(LEVEL.defaults.views.validation * scale),
                        heldout=math.ceil(LEVEL.defaults.views.heldout * scale))
    return settings


def level_budgets(levels: list[Level], seconds: float) -> list[float]:
    """``seconds`` split over ``levels`` in proportion to their sizes in pixels (at least
    ``BUDGET_MIN_PIXELS``): a small level's step is cheap, but its fit needs about as many
    steps as a large one's and starts further from its target, so it gets more than its share
    of pixels (a 32-pixel level of 8000@512, 2000@128, 500@32 gets 9 %, not 1.5 %)."""
    weights = [max(level.pixels, BUDGET_MIN_PIXELS) for level in levels]
    return [seconds * weight / sum(weights) for weight in weights]


def level_settings(level: Level, seconds: float) -> dict:
    """The settings of ``level``'s run: those of its size (``screen_size_settings``), its
    triangles and ``seconds`` of budget."""
    return {**screen_size_settings(level.pixels), "triangles": level.triangles, "time_budget": seconds}


def lod(input: str | Path | Asset, outdir: str | Path, levels: list[Level], *, config: Config | str | Path | None = None,
        time_budget: float = CHAIN_BUDGET, **options) -> list[dict]:
    """Fit the chain ``levels`` of ``input`` into ``outdir/lod0 ...``; returns ``lods.json``'s
    levels (each: triangles, pixels, texture size, whether its mips were fitted, the switch
    distance, the run's folder and seconds, its model's file bytes and GPU memory
    (``io.gpu_memory.gpu_bytes``) and held-out scores).
    ``options``: the run options (``jobs.run.RunOptions``) and settings every level shares by
    name (e.g. ``renderer="mitsuba"``: each level fitted to path-traced views); with ``resume``, finished levels are
    kept and an interrupted one resumed, else ``outdir`` is refused where it holds anything,
    unless ``force``. ``OutputsIncomplete`` at the end where a compressed file was not written
    (a level whose was not keeps its checkpoint: ``resume`` writes its outputs again)."""
    outdir = Path(outdir)
    asset = input if isinstance(input, Asset) else io.load(input)
    radius = float(asset.mesh.bounding_sphere()[1])
    resume = options.pop("resume", False)
    if not resume:
        check_outdir(outdir, force=options.get("force", False), resume=False)
    budgets = level_budgets(levels, time_budget)
    starts = [0.0] + [switch_distance(radius, c * VIEWPORT_HEIGHT) for c in switch_coverages(levels)[:-1]]
    rows, optional = [], OptionalOutputs(outdir)
    for k, (level, seconds) in enumerate(zip(levels, budgets)):
        folder = outdir / f"lod{k}"
        settings = {**level_settings(level, seconds),
                    **({"level_above": str(outdir / f"lod{k - 1}" / MODEL_NAME)} if k else {})}
        if not (resume and _finished(folder)):
            try:
                run(LEVEL, asset, folder, config=config, **settings,
                    **{**options, "resume": resume and (folder / CHECKPOINT_NAME).is_file(), "force": True})
            except OutputsIncomplete as e:  # the level's model, report and metrics are written: go on
                optional.add(f"{folder.name}/{e.missing}", e.cause)
        metrics = json.loads((folder / METRICS_NAME).read_text())
        if metrics["interrupted"]:
            rows.append(level_row(k, level, settings, starts[k], folder, metrics))
            break
        for name in (MODEL_NAME, COMPRESSED_NAME):  # lodK.glb (and lodK.compressed.glb) beside the chain
            if (folder / name).is_file():
                copy_atomic(folder / name, outdir / f"{folder.name}{name.removeprefix('model')}")
        rows.append(level_row(k, level, settings, starts[k], folder, metrics))
    else:
        write_lod_chain([io.load(outdir / row["folder"] / MODEL_NAME) for row in rows], outdir / CHAIN_NAME,
                        asset.name, switch_coverages(levels))
        if all("compressed" in row for row in rows):
            with optional.attempt(COMPRESSED_CHAIN_NAME):
                write_compressed_chain([outdir / row["folder"] / MODEL_NAME for row in rows],
                                       outdir / COMPRESSED_CHAIN_NAME, asset.name, switch_coverages(levels))
        if all("classic" in row for row in rows):
            cfg = load_config(outdir / rows[0]["folder"] / CONFIG_NAME)
            write_chain_page(outdir, prepare_input(asset, options.get("material_override"))[0], rows,
                             [level_settings(level, 0.0)["resolution"] for level in levels], cfg.reference.path_traced)
    chain = {"switch_distance": f"where a level starts to be drawn: viewport_height * radius / (pixels * "
                                f"tan(fovy / 2)) for a viewport {VIEWPORT_HEIGHT} pixels high and fovy "
                                f"{FOVY_DEGREES:g} degrees, pixels the coverage where the level above gives way",
             "radius": radius, "coverages": switch_coverages(levels), "levels": rows}
    write_text_atomic(outdir / "lods.json", json.dumps(chain, indent=2))
    optional.check()
    return rows


def level_row(k: int, level: Level, settings: dict, switch: float, folder: Path, metrics: dict) -> dict:
    """``lods.json``'s row of level ``k`` run in ``folder`` (its ``metrics``): triangles,
    pixels, texture size, whether its mips were fitted, the ``switch`` distance, the run's
    folder and seconds, ``model.glb``'s file bytes, GPU memory (``io.gpu_memory.gpu_bytes``)
    and held-out scores, the held-out scores of its classic bake, and the file bytes, GPU memory
    and scores of ``model.compressed.glb`` where the run wrote one."""
    model = folder / MODEL_NAME
    ours = metrics["heldout"]["ours"]
    row = {"level": k, "triangles": metrics["triangles"]["output"], "pixels": level.pixels,
           "texture_size": settings["texture_size"], "fitted_mips": load_config(folder / CONFIG_NAME).latent.fitted_mips,
           "switch_distance": switch, "folder": folder.name, "seconds": metrics["seconds"]["total"],
           "file_bytes": model.stat().st_size, "gpu_bytes": gpu_bytes(model),
           "psnr": ours["psnr"], "flip": ours["flip"], "interrupted": metrics["interrupted"]}
    classic = metrics["heldout"].get("baked")
    if classic is not None:
        row["classic"] = {"psnr": classic["psnr"], "flip": classic["flip"]}
    compressed = metrics["heldout"].get("compressed")
    if compressed is not None:
        row["compressed"] = {"file_bytes": (folder / COMPRESSED_NAME).stat().st_size,
                             "gpu_bytes": gpu_bytes(folder / COMPRESSED_NAME),
                             "psnr": compressed["psnr"], "flip": compressed["flip"]}
    return row


def _finished(folder: Path) -> bool:
    """A level's run wrote its outputs and left no checkpoint to resume."""
    return (folder / METRICS_NAME).is_file() and not (folder / CHECKPOINT_NAME).exists()
