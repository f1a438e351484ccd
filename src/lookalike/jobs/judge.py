"""Judge a ``simplify`` run in Blender: ``lookalike simplify --judge blender`` and
``lookalike bench quality --judge blender``.

For a run folder (``simplify``'s OUTDIR: ``model.glb``, ``config.toml``, ``metrics.json``) this
writes into ``RUN/judge/``:

- ``reference.glb``: the input as the run saw it (the bench's scan material on scans);
- ``decimated.glb`` and ``baked.glb``: the run's plain decimation and our classic bake (taken
  from the simplify result where given, else read back from an earlier judging, else built
  again from the run's settings and seed with the current code);
- ``blender.glb`` and ``blender_by_angle.glb``: Blender's own pipeline
  (``lookalike.blender.decimate_bake``) with the run's triangle target and texture size, its
  decimated mesh shaded smooth and smooth by angle (not in an animated run, below). A Blender
  user keeps the one that looks better: the one Cycles with shadows scores higher is the
  ``"chosen"`` one in ``judge.json``'s ``"blender_bake"`` (``users_blender``), the one the
  benchmarks hold ours against. Why both: shaded smooth across a hard edge, the baked normal map
  turns each face's normals by up to 45°, which Cycles draws dark;
- ``judge.json``: the scores (``lookalike.jobs.judge_scores.judge_models``), the noise of each
  textured model's maps as written (``lookalike.report.map_noise``) and timings;
- ``views.png``: the first views of every model in every renderer;

and adds the mean scores to the run's ``metrics.json`` as ``"judge"`` and a table of them to its
``report.html`` (``lookalike.report.html.judge_section``).

Every model is scored on the run's own held-out views (same sphere, sampler, seed and count), in
our renderer and in Cycles with and without shadows, at ``JUDGE_RESOLUTION``.

An animated run (a skinned input with clips, not ``--static``: ``lookalike.jobs.animated.
is_animated`` on the input and the run's config) is judged in motion: the held-out views carry
the run's poses, ``reference.glb`` is the skinned input with its clips, the baselines are the
skinned ones the run scored, and ``bind_pose.glb`` is the run's bind-pose fit
(``--compare-static``: ``bind-pose-fit/model.glb`` given the input's weights by
``transfer_skin``, as the run scored it), where the run has one. Blender's decimate + bake makes
a still model (its steps know no skeleton), so it is left out there (``"blender_bake"`` says so
in ``judge.json``).
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from .. import io
from ..asset import Asset
from ..fit.reference import MeshReference, SkinnedReference
from ..init.initial_guess import target_triangle_count
from ..init.skin_weights import transfer_skin
from ..io.atomic import write_text_atomic
from ..blender import require_judge
from ..blender.decimate_bake import SHARP_ANGLE, blender_classic_bake
from ..report.html import add_judge_section, judge_section
from .judge_scores import (
    JUDGE_RESOLUTION,
    RENDERERS,
    JudgedModel,
    heldout_views,
    judge_models,
)
from ..report.map_noise import map_noise
from ..settings import Config, load_config
from . import animated
from .outputs import METRICS_NAME, MODEL_NAME, REPORT_NAME
from .bind_pose import BIND_POSE_FOLDER
from .input_asset import prepare_input
from .simplify import build_initial_guess

JUDGE_FOLDER = "judge"
RESULT_NAME = "judge.json"
LABELS = {"decimated": "Plain decimation", "baked": "Our classic bake",
          "blender": "Blender's decimate + bake, shaded smooth",
          "blender_by_angle": "Blender's decimate + bake, smooth by angle", "bind_pose": "Bind-pose fit", "ours": "Ours"}
"""The judged methods, in table order."""
BLENDER_SHADINGS = {"blender": None, "blender_by_angle": SHARP_ANGLE}
"""Blender's pipeline's models by key, and the angle above which each makes an edge sharp
(``None``: shaded smooth everywhere, as Blender's Shade Smooth)."""

BLENDER_BAKE_SKIPPED = ("not run: an animated run's models keep the input's skeleton and clips, and Blender's bake "
                        "makes a still model")
"""``judge.json``'s ``"blender_bake"`` in an animated run."""


def judge_run(run_dir: str | Path, input_asset: Asset, baselines: dict[str, Asset] | None = None,
              resolution: int = JUDGE_RESOLUTION, views: int | None = None) -> dict:
    """Judge the simplify run in ``run_dir`` in Blender (module docstring; an animated run in
    motion, without Blender's bake).

    Args:
        run_dir: the run's OUTDIR.
        input_asset: the input as the run saw it (material override applied).
        baselines: ``{"decimated": Asset, "baked": Asset}`` from the simplify result, if at hand.
        resolution: side of the judged pictures; views: judge only the first ``views`` held-out
            views (default: all of them).

    Returns:
        The content of ``judge.json``: ``lookalike.jobs.judge_scores.judge_models``' result plus
        ``"blender_bake"`` (triangles, seconds per step; or why it was not run), ``"poses"``
        (an animated run's: what each view shows) and ``"seconds"`` per stage.
    """
    require_judge()
    run_dir = Path(run_dir)
    folder = run_dir / JUDGE_FOLDER
    folder.mkdir(exist_ok=True)
    cfg = load_config(run_dir / "config.toml")
    moving = animated.is_animated(input_asset, cfg.latent.static)
    seconds = {}
    started = time.monotonic()
    reference_glb = folder / "reference.glb"
    io.save(input_asset, reference_glb)
    count = target_triangle_count(cfg.latent.triangles, cfg.latent.ratio, input_asset.mesh.num_triangles)
    paths = write_baselines(folder, input_asset, cfg, count, moving, baselines or {})
    bind_pose = run_dir / BIND_POSE_FOLDER / MODEL_NAME
    if moving and bind_pose.is_file():
        io.save(transfer_skin(input_asset, io.load(bind_pose)), folder / "bind_pose.glb")
        paths["bind_pose"] = folder / "bind_pose.glb"
    seconds["baselines"] = time.monotonic() - started
    blender_bake = {"skipped": BLENDER_BAKE_SKIPPED} if moving else \
        blenders_bake(reference_glb, folder, count, cfg.latent.texture_size, paths, seconds)
    paths["ours"] = run_dir / MODEL_NAME
    models = [JudgedModel(key, LABELS[key], paths[key], io.load(paths[key])) for key in LABELS
              if key in paths and paths[key].exists()]
    reference = SkinnedReference(input_asset) if moving else MeshReference(input_asset, cfg.render.reference_layers)
    heldout = heldout_views(reference, cfg.views.heldout, cfg.views.heldout_seed,
                            animated.heldout_poses(input_asset) if moving else None)
    if views is not None:
        heldout = heldout[:views]
    started = time.monotonic()
    result = judge_models(reference, reference_glb, models, heldout, resolution, cfg.render.target_spp,
                          cfg.render.latent_msaa, contact_sheet_path=folder / "views.png", layers=cfg.render.layers)
    seconds["judging"] = time.monotonic() - started
    if not moving:
        blender_bake["chosen"] = users_blender(result["scores"]["cycles"])
    result["blender_bake"] = blender_bake
    if moving:
        result["poses"] = animated.pose_labels(input_asset, heldout.pose)
    result["triangles"] = {m.key: m.asset.mesh.num_triangles for m in models}
    result["map_noise"] = {m.key: map_noise(m.asset) for m in models if m.key != "decimated"}
    result["seconds"] = {**result["seconds"], **seconds}
    write_text_atomic(folder / RESULT_NAME, json.dumps(result, indent=2))
    add_to_metrics(run_dir / METRICS_NAME, result)
    add_judge_section(run_dir / REPORT_NAME, judge_section(result, RENDERERS, f"{JUDGE_FOLDER}/views.png"))
    return result


def blenders_bake(reference_glb: Path, folder: Path, count: int, texture_size: int, paths: dict[str, Path],
                  seconds: dict[str, float]) -> dict:
    """Blender's own decimate + bake of ``reference_glb`` in each of ``BLENDER_SHADINGS`` into
    ``folder/KEY.glb`` (added to ``paths``, their seconds to ``seconds``); ``judge.json``'s
    ``"blender_bake"``: the shaded-smooth model's triangles and seconds per step, and
    ``"by_angle"``'s."""
    bakes = {}
    for key, angle in BLENDER_SHADINGS.items():
        bakes[key] = blender_classic_bake(reference_glb, folder / f"{key}.glb", count, texture_size, sharp_angle=angle)
        paths[key] = bakes[key].path
    seconds["blender_bake"] = sum(bake.seconds["total"] for bake in bakes.values())
    smooth, by_angle = bakes["blender"], bakes["blender_by_angle"]
    return {"input_triangles": smooth.input_triangles, "triangles": smooth.triangles, "texture_size": texture_size,
            "seconds": smooth.seconds, "by_angle": {"sharp_angle": SHARP_ANGLE, "triangles": by_angle.triangles,
                                                    "seconds": by_angle.seconds}}


def users_blender(scores: dict[str, dict]) -> str:
    """The key of the model of Blender's pipeline a user keeps: of ``BLENDER_SHADINGS`` those
    in ``scores`` (``{key: {"psnr", "flip"}}``, Cycles with shadows), the one of the highest
    PSNR."""
    return max((key for key in BLENDER_SHADINGS if key in scores), key=lambda key: scores[key]["psnr"])


def blender_baseline(judged: dict) -> str:
    """The key of Blender's model a judged run (``judge_run``'s result) is held against: the
    ``"chosen"`` one, or ``"blender"`` where the judging had one model of Blender's."""
    return judged.get("blender_bake", {}).get("chosen", "blender")


def held_against(judged: dict, scores: dict[str, dict]) -> dict[str, dict]:
    """``scores`` (one renderer's ``{key: {"psnr", "flip"}}`` of the judged run ``judged``) with
    ``"blender"`` standing for the model of Blender's pipeline ours is held against
    (``blender_baseline``)."""
    return {**scores, "blender": scores[blender_baseline(judged)]}


def write_baselines(folder: Path, input_asset: Asset, cfg: Config, count: int, moving: bool,
                    baselines: dict[str, Asset]) -> dict[str, Path]:
    """Write the run's plain decimation and classic bake into ``folder`` (``decimated.glb``,
    ``baked.glb``): ``baselines`` where given, else those of an earlier judging, else built
    again from the run's settings and seed (``count`` triangles; skinned as the run's where
    ``moving``). Returns ``{key: path}``."""
    assets = {"decimated": None, "baked": None, **baselines}
    if any(assets[k] is None and not (folder / f"{k}.glb").exists() for k in ("decimated", "baked")):
        guess = build_initial_guess(input_asset, cfg, None if cfg.io.init_mesh else count)
        if moving:
            guess = animated.animated_guess(input_asset, guess, cfg.latent.skin_candidates)
        assets.update({"decimated": guess.baseline, "baked": guess.baked})
    for key in ("decimated", "baked"):
        if assets[key] is not None:
            io.save(assets[key], folder / f"{key}.glb")
    return {key: folder / f"{key}.glb" for key in ("decimated", "baked")}


def mean_scores(result: dict) -> dict:
    """``{renderer: {method: {"psnr", "flip"}}}``: the means of a ``judge_run`` result."""
    return {renderer: {key: {"psnr": s["psnr"], "flip": s["flip"]} for key, s in scores.items()}
            for renderer, scores in result["scores"].items()}


def add_to_metrics(metrics_path: Path, result: dict) -> None:
    """Add the judge's mean scores (``mean_scores``), views and resolution to the run's
    ``metrics.json`` as ``"judge"`` (rewritten atomically); nothing where there is none."""
    if not metrics_path.is_file():
        return
    metrics = json.loads(metrics_path.read_text())
    metrics["judge"] = {"renderer": "Blender Cycles", "views": result["views"], "resolution": result["resolution"],
                        "labels": result["labels"], "scores": mean_scores(result),
                        "details": f"{JUDGE_FOLDER}/{RESULT_NAME}"}
    write_text_atomic(metrics_path, json.dumps(metrics, indent=2))


def judge_summary(result: dict) -> str:
    """A few lines for the terminal: PSNR / FLIP of every method in every renderer."""
    lines = [f"judged on {result['views']} held-out views at {result['resolution']} px "
             "(PSNR over covered pixels / FLIP):"]
    for renderer, scores in result["scores"].items():
        figures = ", ".join(f"{result['labels'][key]} {s['psnr']:.2f} dB / {s['flip']:.4f}" for key, s in scores.items())
        lines.append(f"  {RENDERERS[renderer]}: {figures}")
    return "\n".join(lines)


def reference_of_run(run_dir: str | Path, material_override=None, input_path: str | Path | None = None) -> Asset:
    """The input of the run in ``run_dir`` as it saw it: ``input_path`` (default: the input its
    ``config.toml`` names) with ``material_override`` applied."""
    cfg = load_config(Path(run_dir) / "config.toml")
    asset, _ = prepare_input(io.load(input_path or cfg.io.input), material_override)
    return asset
