"""Scores from an independent judge: the input and every method rendered on the same held-out
views by Blender Cycles (``lookalike.blender``), with shadows and without, and by our own
pipeline, each method scored against its renderer's picture of the input.

Scores (``score_renders``), for every renderer alike:

- PSNR over the pixels that either image covers (``coverage_union``: alpha > 0 in the input's
  or the method's picture), on tone-mapped values (``lookalike.report.metrics.masked_psnr_views``)
  of both pictures composited over the report's background (``BACKGROUND``);
- FLIP over the whole pictures composited over that background (``flip_views``).

Renderers (the keys of ``judge_models``' result): ``"ours"`` (the report's settings: the input
supersampled ``spp`` x ``spp``, the methods with ``render_asset``: ``msaa`` x ``msaa`` samples,
each shaded),
``"cycles"`` (shadows on) and ``"cycles_no_shadows"``.

Animated runs (a skinned input fitted over its clips): the held-out views carry poses (a clip
and a time each, ``heldout_views``), and every renderer draws every skinned model in the pose of
each view: ours poses the input with ``SkinnedReference`` and the models with ``render_asset``
(``lookalike.asset.skinning.posed``), Cycles plays the clip of the glb at that time with
Blender's armature (``lookalike.blender.cycles_worker``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np
import torch

from ..asset import Asset
from ..fit.reference import RENDER_CHUNK, Reference, render_in_chunks
from ..fit.textured_mesh import render_asset
from ..fit.training_views import PoseSampler, Views, view_sampler
from ..blender.cycles import render_cycles_views
from ..report.heldout import BACKGROUND
from ..report.pictures import image_grid, to_srgb_uint8
from ..report.metrics import coverage_union, flip_views, masked_psnr_views

JUDGE_RESOLUTION = 384
"""Side of the judged pictures in pixels (the judge's prescribed size)."""

RENDERERS = {"ours": "our renderer", "cycles": "Cycles, shadows", "cycles_no_shadows": "Cycles, no shadows"}
"""Renderer keys of the judged scores (``judge_models``), and what tables call them."""

THREEJS_RENDERERS = {"three_shadows": "three.js, shadows", "three": "three.js, no shadows"}
"""Renderer keys of ``threejs_scores``, where a judge asks for three.js too, and their names."""

THREEJS_SAMPLES = 4
"""MSAA samples per pixel of the three.js judge's pictures (a viewer's antialiasing)."""

CONTACT_VIEWS = 3
"""Views shown per model in the contact sheet (``contact_sheet``)."""


@dataclass
class JudgedModel:
    """One method to judge: ``key`` (``"decimated"``, ``"baked"``, ``"blender"``, ``"bind_pose"``,
    ``"ours"``), ``label``, its glb (for Cycles) and the same model as an ``Asset`` (for our
    renderer); skinned, with the input's skeleton and clips, in an animated run."""

    key: str
    label: str
    glb: Path
    asset: Asset


def heldout_views(reference: Reference, count: int, seed: int, poses: PoseSampler | None = None) -> Views:
    """The held-out views of a run on ``reference`` (as ``HeldoutViews`` draws them:
    ``view_sampler`` around ``reference.bounding_sphere()``, with a pose per view from ``poses``
    in an animated run, lit by the reference's ``fixed_light`` where it has one, from
    ``default_rng(seed)``): cameras, lights and poses (``None`` in a still run), in the input's
    own frame, the frame of the glb files we write."""
    centre, radius = reference.bounding_sphere()
    sampler = view_sampler(centre, radius, poses=poses, fixed_light=reference.fixed_light)
    return sampler(np.random.default_rng(seed), count)


def composite_over_background(rgba: torch.Tensor) -> torch.Tensor:
    """``[B, H, W, 3]``: premultiplied ``rgba [B, H, W, 4]`` over ``BACKGROUND``."""
    rgba = torch.as_tensor(rgba).float()
    return rgba[..., :3] + (1.0 - rgba[..., 3:4]) * torch.tensor(BACKGROUND, dtype=torch.float32)


def score_renders(reference_rgba: torch.Tensor, rgba: torch.Tensor) -> dict:
    """PSNR over the covered pixels and FLIP (module docstring) of ``rgba`` against
    ``reference_rgba`` (both ``[B, H, W, 4]``, premultiplied, linear).

    Returns:
        ``{"psnr", "flip", "psnr_views", "flip_views"}`` (means and per-view lists).
    """
    reference, test = composite_over_background(reference_rgba), composite_over_background(rgba)
    mask = coverage_union(reference_rgba[..., 3], rgba[..., 3])
    psnr = masked_psnr_views(reference, test, mask)
    flip = flip_views(reference, test)[0]
    return {"psnr": float(psnr.mean()), "flip": float(flip.mean()), "psnr_views": psnr.tolist(),
            "flip_views": flip.tolist()}


@torch.no_grad()
def render_ours(reference: Reference, models: list[JudgedModel], views: Views, resolution: int, spp: int,
                msaa: int, layers: int = 1) -> dict[str, torch.Tensor]:
    """``{"reference" | model key: [B, H, W, 4]}`` drawn by our pipeline as the report draws
    them on ``views`` (in their poses, where they have them): the input by ``reference``,
    supersampled ``spp`` x ``spp``; the methods with ``render_asset`` over ``layers``
    depth-peeled layers (the run's ``render.layers``; the reference peels its own, ``render.reference_layers``)."""
    images = {"reference": render_in_chunks(reference, views.camera, views.light, resolution, spp, pose=views.pose)}
    chunks = [views[i:i + RENDER_CHUNK] for i in range(0, views.batch_size, RENDER_CHUNK)]
    for model in models:
        images[model.key] = torch.cat([render_asset(model.asset, chunk.camera, chunk.light, chunk.pose,
                                                    resolution=resolution, msaa=msaa, layers=layers)
                                     for chunk in chunks])
    return images


def judge_models(reference: Reference, reference_glb: Path, models: list[JudgedModel], views: Views,
                 resolution: int = JUDGE_RESOLUTION, spp: int = 2, msaa: int = 2,
                 contact_sheet_path: Path | None = None, layers: int = 1) -> dict:
    """Render the input and every model in our pipeline and in Cycles (shadows on, off) on
    ``views`` (in their poses, where they have them) and score them (module docstring).

    Args:
        reference: the input as the run saw it (a ``MeshReference``, or a ``SkinnedReference``
            in an animated run); reference_glb: the same input written as a glb.
        models: the methods; views: the held-out views (``heldout_views``).
        resolution: side of the pictures; spp, msaa: our renderer's samples (the report's);
            layers: the depth-peeled layers our renderer draws the models with.
        contact_sheet_path: also write a PNG of the first ``CONTACT_VIEWS`` views of every
            model in every renderer there (``contact_sheet``).

    Returns:
        ``{"resolution", "views", "scores": {renderer: {key: score_renders(...)}},
        "labels": {key: label}, "reference_coverage": {renderer: mean alpha of the input's
        pictures}, "agreement": {"reference" | key: {"psnr", "flip"}}, "seconds": {"ours",
        "cycles", "cycles_per_view"}}``. The coverages agree where the views were converted
        right; ``agreement`` scores our renderer's pictures of each model against Cycles'
        without shadows (how far the two renderers part on the same file).
    """
    seconds = {}
    started = time.monotonic()
    ours = render_ours(reference, models, views, resolution, spp, msaa, layers)
    seconds["ours"] = time.monotonic() - started
    started = time.monotonic()
    cycles_images = {True: {}, False: {}}
    per_view = []
    for key, glb in [("reference", reference_glb)] + [(m.key, m.glb) for m in models]:
        rendered = render_cycles_views(glb, views.camera, views.light, resolution, shadows=(True, False),
                                       pose=views.pose)
        per_view.append(rendered.seconds_per_view)
        for shadows, images in rendered.images.items():
            cycles_images[shadows][key] = images
    seconds["cycles"] = time.monotonic() - started
    seconds["cycles_per_view"] = float(np.mean(per_view))
    renders = {"ours": ours, "cycles": cycles_images[True], "cycles_no_shadows": cycles_images[False]}
    scores = {renderer: {m.key: score_renders(images["reference"], images[m.key]) for m in models}
              for renderer, images in renders.items()}
    if contact_sheet_path is not None:
        contact_sheet(renders, models, contact_sheet_path)
    coverage = {renderer: float(images["reference"][..., 3].mean()) for renderer, images in renders.items()}
    agreement = {key: score_renders(cycles_images[False][key], ours[key]) for key in ["reference"] + [m.key for m in models]}
    return {"resolution": resolution, "views": views.batch_size, "scores": scores,
            "labels": {m.key: m.label for m in models}, "reference_coverage": coverage,
            "agreement": {key: {"psnr": a["psnr"], "flip": a["flip"]} for key, a in agreement.items()},
            "seconds": seconds}


def threejs_scores(reference_glb: Path, models: list[JudgedModel], views: Views,
                   resolution: int = JUDGE_RESOLUTION) -> dict[str, dict[str, dict]]:
    """``{"three_shadows" | "three": {key: score_renders(...)}}``: the input and every model
    drawn by three.js (``lookalike.webgl``) on the still ``views`` under each view's light, with
    its shadow maps on and off, each model scored against three.js's picture of the input."""
    from ..webgl import render_threejs

    scores = {}
    for renderer, shadows in (("three_shadows", True), ("three", False)):
        draw = partial(render_threejs, camera=views.camera, resolution=resolution, light=views.light,
                       samples=THREEJS_SAMPLES, shadows=shadows)
        reference = draw(reference_glb)
        scores[renderer] = {m.key: score_renders(reference, draw(m.glb)) for m in models}
    return scores


def contact_sheet(renders: dict[str, dict[str, torch.Tensor]], models: list[JudgedModel], path: Path) -> None:
    """A PNG grid: one column per model (the input first), one row per (renderer, view) for
    the first ``CONTACT_VIEWS`` views, over the report's background."""
    keys = ["reference"] + [m.key for m in models]
    cells, row_labels = [], []
    for renderer, images in renders.items():
        shown = {key: to_srgb_uint8(composite_over_background(images[key][:CONTACT_VIEWS])) for key in keys}
        for view in range(len(shown["reference"])):
            cells.append([shown[key][view] for key in keys])
            row_labels.append(f"{RENDERERS[renderer]}, view {view + 1}")
    image_grid(cells, ["input"] + [m.label for m in models], row_labels).save(path)
