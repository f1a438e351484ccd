"""``lookalike bench pathtraced``: ``simplify --reference mitsuba`` with default settings (but the
bar's 15-minute budget) against path-traced references (64 samples per pixel), beside
``simplify`` with our own rasterized reference (its own run with default settings, drawn on the
same path-traced views as the run's baselines are).

Cases: spot (1,000 triangles) and flight-helmet (5,000) under the generated studio; spot
given a generated emission map (``glowing``: lit panels in its texture space), under the
studio; under a generated sky (``generated_sky``, an environment map: nothing analytic), fitted
``--unlit``: nefertiti (2,500, an untextured scan in the scan material: rough, its look all in
its shape's shading) and flight-helmet (5,000: metal, glass and leather).

Every case checks its reference: each held-out and validation view's coverage within
``BAR_COVERAGE`` of the input's rasterized coverage (``jobs.reference_coverage``).

Bar under the studio: ours at least 3 dB above the classic bake (rasterized under the studio's
key light) and 2 dB above ``simplify``, with a lower FLIP than both; ``model.glb`` as written,
drawn by three.js (``lookalike.webgl``) with its own point light, within 1 dB of what our
renderer scores. Under the sky, the baselines are path traced as the reference is (our
rasterizer would draw them black), the run also scores the classic bake of the lighting (the
light leaving the input baked onto the decimated mesh's atlas, drawn unlit: an artist's
light-map bake, and ours' start), and the independent judge is Cycles (``--judge blender``): the
input, plain decimation and ``simplify``'s model path traced by Cycles under the same map with
``JUDGE_BOUNCES`` bounces, against ours and the lighting bake drawn unlit; ours at least 1 dB
above plain decimation there, with a lower FLIP; three.js within 1 dB of our renderer. Every run within 15
minutes including its reference renders.
"""

from __future__ import annotations

import dataclasses
import json
import tempfile
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np
import torch

from ._table import runs_table
from .quality import (SHARED_ASSETS, BenchAsset, check_assets_dir, check_judge, output_root, scan_material,
                      simplify_case, stop_if_interrupted)
from .quality import TIME_BUDGET_S as SIMPLIFY_BUDGET_S

HELP = "simplify under fixed lighting against path-traced (Mitsuba 3) references; compare with the classic bake and simplify"


@dataclass(frozen=True)
class PathTracedCase(BenchAsset):
    """A benchmark case under fixed lighting: ``sky`` lights it by the generated environment map
    (else the studio), ``glowing`` gives it the generated emission map, ``unlit`` fits it
    ``--unlit``."""

    sky: bool = False
    glowing: bool = False
    unlit: bool = False


ASSETS = (PathTracedCase("spot", "spot/spot.obj", 1000, False),
          PathTracedCase("flight-helmet", "flight-helmet/FlightHelmet.gltf", 5000, False),
          PathTracedCase("spot-glowing", "spot/spot.obj", 1000, False, glowing=True),
          PathTracedCase("nefertiti-sky", "nefertiti/nefertiti.obj", 2500, True, sky=True, unlit=True),
          PathTracedCase("flight-helmet-sky", "flight-helmet/FlightHelmet.gltf", 5000, False, sky=True, unlit=True))
BAR_MINUTES = 15.0
TIME_BUDGET_S = 60 * BAR_MINUTES
"""Our run's budget, its reference renders included: the bar's 15 minutes (``simplify`` beside it
keeps its default 10, ``SIMPLIFY_BUDGET_S``)."""
BAR_GAIN_OVER_BAKE_DB = 3.0
BAR_GAIN_OVER_SIMPLIFY_DB = 2.0
BAR_ENGINE_DB = 1.0
"""Ours drawn by three.js (``model.glb`` as written, its own light) within this of our renderer's score."""
BAR_COVERAGE = 0.01
"""Every reference view's coverage within this share of the input's rasterized coverage."""
BAR_CYCLES_GAIN_DB = 1.0
"""Under the sky, in Cycles: ours unlit at least this above plain decimation path traced by Cycles."""
JUDGE_BOUNCES = 4
"""Light bounces of the Cycles judge under the sky: the indirect light a user's render has."""
JUDGE_SAMPLES = 256
"""Cycles samples per pixel under the sky: its noise stays well below the differences scored."""

JUDGED = ("decimated", "simplify", "lighting_baked", "ours")
"""The models Cycles judges under the sky, as the table lists them."""

SKY_SIZE = (256, 512)
"""Rows and columns of the generated sky (latitude-longitude)."""


def generated_sky(size: tuple[int, int] = SKY_SIZE) -> np.ndarray:
    """``[H, W, 3]`` float32 linear radiance of a clear sky, latitude-longitude, row 0 the zenith:
    blue overhead paling to the horizon, a warm sun 35 degrees up (a disc of 4 degrees holding
    most of the light, with a glow around it), and dim brown ground below the horizon."""
    rows, columns = size
    elevation = (0.5 - (np.arange(rows) + 0.5) / rows)[:, None] * np.pi        # +pi/2 at the zenith
    azimuth = ((np.arange(columns) + 0.5) / columns)[None, :] * 2 * np.pi
    up = np.clip(np.sin(elevation), 0.0, 1.0)
    sky = np.where(elevation >= 0, 1.0, 0.0)[..., None] * (
        np.array([0.25, 0.45, 0.9]) * up[..., None] + np.array([0.8, 0.85, 0.9]) * (1 - up[..., None]) ** 4)
    ground = np.where(elevation < 0, 1.0, 0.0)[..., None] * np.array([0.12, 0.09, 0.06])
    sun_elevation, sun_azimuth = np.radians(35.0), np.radians(60.0)
    cosine = (np.sin(elevation) * np.sin(sun_elevation)
              + np.cos(elevation) * np.cos(sun_elevation) * np.cos(azimuth - sun_azimuth))
    angle = np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))
    sun = (np.where(angle < 2.0, 400.0, 0.0) + 3.0 * np.exp(-angle / 8.0))[..., None] * np.array([1.0, 0.85, 0.6])
    sky = np.broadcast_to(sky, (rows, columns, 3)) + ground + sun
    return np.ascontiguousarray(sky, dtype=np.float32)


def glowing(asset):
    """``asset`` with an emission map on each material: warm panels lit in a 12 x 12 grid of its
    texture space (every third cell), of radiance 0.9 x 0.45 x 0.12, sharp-edged."""
    from ..asset import Texture

    size = 512
    cells = (np.arange(size) * 12 // size)
    lit = ((cells[:, None] + 2 * cells[None, :]) % 3 == 0)
    inset = ((np.arange(size) * 12) % size > size // 10)
    lit &= inset[:, None] & inset[None, :]
    emission = torch.from_numpy(lit[..., None] * np.array([0.9, 0.45, 0.12], dtype=np.float32))
    return dataclasses.replace(asset, materials=[dataclasses.replace(m, emissive=Texture(emission.clone()))
                                                 for m in asset.materials])


def case_input(case: PathTracedCase, assets_dir: Path, root: Path) -> Path:
    """The file a case's runs read: the asset as it is, or, ``glowing``, the asset with its
    emission map written into ``root/inputs``."""
    if not case.glowing:
        return assets_dir / case.path
    from .. import io

    target = root / "inputs" / f"{case.name}.glb"
    if not target.is_file():
        target.parent.mkdir(parents=True, exist_ok=True)
        io.save(glowing(io.load(assets_dir / case.path)), target)
    return target


def case_lighting(case: PathTracedCase, root: Path) -> str:
    """``reference.lighting`` of a case: ``"studio"``, or the generated sky written into ``root``."""
    if not case.sky:
        return "studio"
    from ..io.environment_map import write_environment_map

    target = root / "sky.hdr"
    if not target.is_file():
        write_environment_map(target, generated_sky())
    return str(target)


def path_traced_case(case: PathTracedCase, source: Path, lighting: str, outdir: Path, time_budget: float):
    """``simplify --reference mitsuba`` of one case with default settings; the ``RunResult``."""
    from ..jobs.simplify import simplify

    return simplify(source, outdir, triangles=case.triangles, time_budget=time_budget, renderer="mitsuba",
                    lighting=lighting, unlit=case.unlit, force=True, progress=False,
                    material_override=scan_material() if case.scan else None)


def path_traced_views(case: PathTracedCase, source: Path, run_dir: Path):
    """``(input asset, RunReference, HeldoutViews, cfg)`` of ``case``'s path-traced run in
    ``run_dir``: its held-out views read from its cache, never rendered again."""
    from .. import io
    from ..fit.training_views import view_sampler
    from ..jobs.input_asset import prepare_input
    from ..jobs.reference_kinds import run_reference
    from ..report.heldout import HeldoutViews
    from ..settings import load_config

    cfg = load_config(run_dir / "config.toml")
    cfg.io = dataclasses.replace(cfg.io, outdir=str(run_dir))
    asset, _ = prepare_input(io.load(source), scan_material() if case.scan else None)
    reference = run_reference(asset, cfg, False)
    centre, radius = reference.renderer.bounding_sphere()
    sampler = view_sampler(centre, radius, fixed_light=reference.renderer.fixed_light)
    heldout = HeldoutViews(reference.renderer, sampler, cfg.views.heldout, cfg.views.heldout_seed,
                           cfg.render.resolution, cfg.render.target_spp)
    if reference.renderer.rendered:
        raise RuntimeError(f"{run_dir}: its path-traced held-out views are not all in its cache")
    return asset, reference, heldout, cfg


def scored_on_path_traced_views(case: PathTracedCase, source: Path, run_dir: Path, simplified: Path) -> dict:
    """Scores on the held-out views of the path-traced run in ``run_dir``: ``"simplify"``, the
    model at ``simplified`` drawn as the run drew its baselines (our renderer under the
    lighting's analytic light, or path traced where that lights nothing); ``"engine"``, ours
    (``model.glb`` as written, with its own light) drawn by three.js; ``"bake_traced"``, the
    run's classic bake (``baked.glb``) path traced under the reference's lighting, as an offline
    renderer would show the classic pipeline's model. Each ``{"psnr", "flip"}``."""
    from .. import io
    from ..fit.textured_mesh import render_asset
    from ..webgl import render_threejs

    _, reference, heldout, cfg = path_traced_views(case, source, run_dir)
    size = cfg.render.resolution
    draw, _ = reference.baseline_draw(partial(render_asset, resolution=size, msaa=cfg.render.latent_msaa))
    ours = run_dir / "model.glb"
    scores = {"simplify": heldout.score("simplify", "simplify", io.load(simplified), draw, None),
              "engine": heldout.score("engine", "three.js", io.load(ours),
                                      lambda model, camera, light, pose: render_threejs(ours, camera, size), None),
              "bake_traced": heldout.score("bake_traced", "classic bake, path traced", io.load(run_dir / "baked.glb"),
                                           reference.draw_traced, None)}
    return {key: {"psnr": scored.psnr, "flip": scored.flip} for key, scored in scores.items()}


def judged_under_sky(case: PathTracedCase, source: Path, run_dir: Path, simplified: Path, lighting: str) -> dict:
    """Cycles' scores (``jobs.judge_scores.score_renders``: masked PSNR and FLIP) of ours
    (``model.glb``, unlit), the classic bake of the lighting (``lighting-baked.glb``, unlit), plain
    decimation (``decimated.glb``) and ``simplify``'s model, each against the input, all path
    traced by Cycles under the sky ``lighting`` with ``JUDGE_BOUNCES`` bounces, on the run's
    held-out cameras at the judge's resolution: ``{"decimated", "simplify", "lighting_baked",
    "ours"}``, each ``{"psnr", "flip"}``, and ``"seconds"``."""
    import time

    from .. import io
    from ..blender.cycles import render_cycles_views
    from ..jobs.judge_scores import JUDGE_RESOLUTION, score_renders

    asset, _, heldout, _ = path_traced_views(case, source, run_dir)
    started = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="lookalike-judge-") as scratch:
        models = {"input": Path(scratch) / "input.glb", "decimated": run_dir / "decimated.glb",
                  "simplify": simplified, "lighting_baked": run_dir / "lighting-baked.glb", "ours": run_dir / "model.glb"}
        io.save(asset, models["input"])
        pictures = {key: render_cycles_views(glb, heldout.camera, heldout.light, JUDGE_RESOLUTION, shadows=(True,),
                                             samples=JUDGE_SAMPLES, environment=lighting,
                                             bounces=JUDGE_BOUNCES).images[True]
                    for key, glb in models.items()}
    scores = {key: score_renders(pictures["input"], pictures[key]) for key in JUDGED}
    return {**{key: {"psnr": s["psnr"], "flip": s["flip"]} for key, s in scores.items()},
            "seconds": time.monotonic() - started}


def case_row(case: PathTracedCase, metrics: dict, scored: dict, judged: dict | None = None) -> dict:
    """The table's row of one case from the path-traced run's ``metrics``, the scores on its
    views of ``simplify`` and of ours in three.js (``scored``) and, under the sky, Cycles'
    (``judged``), with the bar (``meets_bar``)."""
    heldout, seconds, coverage = metrics["heldout"], metrics["seconds"], metrics["reference_coverage"]
    row = {"asset": case.name, "triangles": metrics["triangles"]["output"],
           "minutes": seconds["total"] / 60, "minutes_reference": metrics["reference_views"]["seconds"] / 60,
           "minutes_fit": seconds.get("optimisation", 0.0) / 60, "variant": metrics["reference_views"]["variant"],
           "iterations": metrics["iterations"], "coverage_min": coverage["min"], "coverage_max": coverage["max"]}
    for key, method in (("bake", "baked"), ("input", "input_rasterized"), ("lighting_baked", "lighting_baked"),
                        ("ours", "ours")):
        scores = heldout.get(method, {"psnr": float("nan"), "flip": float("nan")})
        row[f"psnr_{key}"], row[f"flip_{key}"] = scores["psnr"], scores["flip"]
    for key in ("simplify", "engine", "bake_traced"):
        row[f"psnr_{key}"], row[f"flip_{key}"] = scored[key]["psnr"], scored[key]["flip"]
    row["engine_minus_ours_db"] = row["psnr_engine"] - row["psnr_ours"]
    row["gain_over_bake_db"] = row["psnr_ours"] - row["psnr_bake"]
    row["gain_over_simplify_db"] = row["psnr_ours"] - row["psnr_simplify"]
    common = (row["minutes"] <= BAR_MINUTES and abs(row["engine_minus_ours_db"]) <= BAR_ENGINE_DB
              and 1 - BAR_COVERAGE <= row["coverage_min"] and row["coverage_max"] <= 1 + BAR_COVERAGE)
    if not case.sky:
        row["meets_bar"] = (common and row["gain_over_bake_db"] >= BAR_GAIN_OVER_BAKE_DB
                            and row["gain_over_simplify_db"] >= BAR_GAIN_OVER_SIMPLIFY_DB
                            and row["flip_ours"] < min(row["flip_bake"], row["flip_simplify"]))
        return row
    if judged is not None:
        row["judge"] = judged
        row["cycles_gain_db"] = judged["ours"]["psnr"] - judged["decimated"]["psnr"]
    row["meets_bar"] = (common and judged is not None and row["cycles_gain_db"] >= BAR_CYCLES_GAIN_DB
                        and judged["ours"]["flip"] < judged["decimated"]["flip"])
    return row


def run(out: str | Path | None = None, time_budget: float = TIME_BUDGET_S, assets: tuple[PathTracedCase, ...] = ASSETS,
        assets_dir: str | Path = SHARED_ASSETS, reuse: bool = False, judge: str | None = None) -> dict:
    """Run each case and ``simplify`` beside it (``out`` keeps the runs, ``reuse`` takes those
    already there); ``judge="blender"`` judges the sky's cases in Cycles.
    ``{"time_budget_s", "bar", "rows", "all_meet_bar", "outputs"}``."""
    from .. import io
    from ..webgl import require_threejs

    assets_dir = check_assets_dir(assets_dir)
    require_threejs()
    if judge is not None:
        check_judge(judge)
    with tempfile.TemporaryDirectory(prefix="lookalike-bench-") as scratch:
        root = output_root(out, scratch)
        root.mkdir(parents=True, exist_ok=True)
        rows = []
        for case in assets:
            run_dir, simplify_dir = root / case.name, root / f"{case.name}-simplify"
            source, lighting = case_input(case, assets_dir, root), case_lighting(case, root)
            if not (reuse and (run_dir / "metrics.json").is_file()):
                result = path_traced_case(case, source, lighting, run_dir, time_budget)
                stop_if_interrupted(result)
                for key in ("decimated", "baked", "lighting_baked"):
                    if key in result.baselines:
                        io.save(result.baselines[key], run_dir / f"{key.replace('_', '-')}.glb")
            if not (reuse and (simplify_dir / "metrics.json").is_file()):
                stop_if_interrupted(simplify_case(dataclasses.replace(case, path=str(source)), assets_dir, simplify_dir,
                                                  SIMPLIFY_BUDGET_S))
            scored = scored_on_path_traced_views(case, source, run_dir, simplify_dir / "model.glb")
            judged = (judged_under_sky(case, source, run_dir, simplify_dir / "model.glb", lighting)
                      if case.sky and judge is not None else None)
            rows.append(case_row(case, json.loads((run_dir / "metrics.json").read_text()), scored, judged))
        return {"time_budget_s": time_budget,
                "bar": {"minutes": BAR_MINUTES, "gain_over_bake_db": BAR_GAIN_OVER_BAKE_DB,
                        "gain_over_simplify_db": BAR_GAIN_OVER_SIMPLIFY_DB, "engine_db": BAR_ENGINE_DB,
                        "coverage": BAR_COVERAGE, "cycles_gain_db": BAR_CYCLES_GAIN_DB},
                "rows": rows, "all_meet_bar": all(r["meets_bar"] for r in rows),
                "outputs": None if root == Path(scratch) else str(root.resolve())}


COLUMNS = (("asset", "asset", "{}"), ("triangles", "triangles", "{:,}"), ("min. reference", "minutes_reference", "{:.1f}"),
           ("min. fit", "minutes_fit", "{:.1f}"), ("min. total", "minutes", "{:.1f}"), ("steps", "iterations", "{}"),
           ("coverage", "coverage_min", "{:.3f}"), ("to", "coverage_max", "{:.3f}"),
           ("PSNR bake", "psnr_bake", "{:.2f}"), ("PSNR input", "psnr_input", "{:.2f}"),
           ("PSNR simplify", "psnr_simplify", "{:.2f}"), ("PSNR ours", "psnr_ours", "{:.2f}"),
           ("vs bake dB", "gain_over_bake_db", "{:+.2f}"), ("vs simplify dB", "gain_over_simplify_db", "{:+.2f}"),
           ("FLIP bake", "flip_bake", "{:.4f}"), ("FLIP simplify", "flip_simplify", "{:.4f}"),
           ("FLIP ours", "flip_ours", "{:.4f}"), ("PSNR / FLIP lighting baked", "psnr_lighting_baked", "{:.2f}"),
           ("", "flip_lighting_baked", "{:.4f}"), ("PSNR / FLIP bake path traced", "psnr_bake_traced", "{:.2f}"),
           ("", "flip_bake_traced", "{:.4f}"), ("PSNR three.js", "psnr_engine", "{:.2f}"),
           ("three.js - ours dB", "engine_minus_ours_db", "{:+.2f}"), ("Mitsuba", "variant", "{}"))


def cycles_table(rows: list[dict]) -> list[str]:
    """Lines of the Cycles judge's table under the sky: masked PSNR / FLIP per method."""
    from ._table import aligned_table

    judged = [r for r in rows if "judge" in r]
    if not judged:
        return []
    cells = [[r["asset"], *(f"{r['judge'][key]['psnr']:.2f} / {r['judge'][key]['flip']:.4f}"
                            for key in JUDGED), f"{r['cycles_gain_db']:+.2f}"]
             for r in judged]
    return [f"Cycles under the sky, {JUDGE_BOUNCES} bounces, {JUDGE_SAMPLES} samples (masked PSNR / FLIP against the "
            "input path traced by Cycles):",
            *aligned_table(["asset", "decimation", "simplify", "lighting baked (unlit)", "ours (unlit)",
                            "ours - decimation dB"], cells)]


def format_table(result: dict) -> str:
    """The cases as an aligned text table with the bar."""
    bar = result["bar"]
    line = (f"bar: each run <= {bar['minutes']:g} min with its reference renders, every reference view's coverage "
            f"within {bar['coverage']:.0%} of the input's; under the studio ours >= classic bake + "
            f"{bar['gain_over_bake_db']:g} dB and >= simplify + {bar['gain_over_simplify_db']:g} dB with lower FLIP; "
            f"under the sky, in Cycles, ours >= plain decimation + {bar['cycles_gain_db']:g} dB with lower FLIP; "
            f"model.glb in three.js within {bar['engine_db']:g} dB of ours")
    return runs_table(dict(result, runs=result["rows"]), COLUMNS, line, cycles_table)
