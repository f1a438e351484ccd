"""``lookalike bench pathtraced``: ``simplify --reference mitsuba`` with default settings (but the
bar's 15-minute budget) under the generated studio lighting (64 samples per pixel) on spot
(1,000 triangles) and flight-helmet (5,000), scored on the run's held-out path-traced views beside the classic bake
rasterized (no global illumination), the input rasterized, and ``simplify`` with our own
rasterized reference (its own run with default settings, scored on the same path-traced views
under the lighting's analytic light).

Bar: ours at least 3 dB above the classic bake and 2 dB above ``simplify``, with a lower FLIP
than both, each run within 15 minutes including its reference renders; and ``model.glb`` as
written, drawn by three.js (``lookalike.webgl``) with its own point light, within 1 dB of
what our renderer scores.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

from ._table import runs_table
from .quality import SHARED_ASSETS, BenchAsset, check_assets_dir, output_root, simplify_case, stop_if_interrupted
from .quality import TIME_BUDGET_S as SIMPLIFY_BUDGET_S

HELP = "simplify under fixed lighting against path-traced (Mitsuba 3) references; compare with the classic bake and simplify"

ASSETS = (BenchAsset("spot", "spot/spot.obj", 1000, False),
          BenchAsset("flight-helmet", "flight-helmet/FlightHelmet.gltf", 5000, False))
BAR_MINUTES = 15.0
TIME_BUDGET_S = 60 * BAR_MINUTES
"""Our run's budget, its reference renders included: the bar's 15 minutes (``simplify`` beside it
keeps its default 10, ``SIMPLIFY_BUDGET_S``)."""
BAR_GAIN_OVER_BAKE_DB = 3.0
BAR_GAIN_OVER_SIMPLIFY_DB = 2.0
BAR_ENGINE_DB = 1.0
"""Ours drawn by three.js (``model.glb`` as written, its own light) within this of our renderer's score."""


def path_traced_case(case: BenchAsset, assets_dir: Path, outdir: Path, time_budget: float):
    """``simplify --reference mitsuba`` of one case with default settings; the ``RunResult``."""
    from ..jobs.simplify import simplify

    return simplify(assets_dir / case.path, outdir, triangles=case.triangles, time_budget=time_budget,
                    renderer="mitsuba", force=True, progress=False)


def scored_on_path_traced_views(case: BenchAsset, assets_dir: Path, run_dir: Path, simplified: Path) -> dict:
    """Scores on the held-out views of the path-traced run in ``run_dir`` (read from its cache,
    never rendered again): ``"simplify"``, the model at ``simplified`` drawn by our renderer lit
    by the lighting's analytic light as ours is; ``"engine"``, ours (``model.glb`` as written,
    with its own light) drawn by three.js. Each ``{"psnr", "flip"}``."""
    import dataclasses
    from functools import partial

    from .. import io
    from ..fit.textured_mesh import render_asset
    from ..fit.training_views import view_sampler
    from ..jobs.input_asset import prepare_input
    from ..jobs.path_traced import path_traced_reference
    from ..report.heldout import HeldoutViews
    from ..settings import load_config
    from ..webgl import render_threejs

    cfg = load_config(run_dir / "config.toml")
    cfg.io = dataclasses.replace(cfg.io, outdir=str(run_dir))
    asset, _ = prepare_input(io.load(assets_dir / case.path), None)
    reference = path_traced_reference(asset, cfg, False)
    centre, radius = reference.bounding_sphere()
    sampler = view_sampler(centre, radius, fixed_light=reference.fixed_light)
    size = cfg.render.resolution
    heldout = HeldoutViews(reference, sampler, cfg.views.heldout, cfg.views.heldout_seed, size, cfg.render.target_spp)
    if reference.rendered:
        raise RuntimeError(f"{run_dir}: its path-traced held-out views are not all in its cache")
    ours = run_dir / "model.glb"
    scores = {"simplify": heldout.score("simplify", "simplify", io.load(simplified),
                                        partial(render_asset, resolution=size, msaa=cfg.render.latent_msaa), None),
              "engine": heldout.score("engine", "three.js", io.load(ours),
                                      lambda model, camera, light, pose: render_threejs(ours, camera, size), None)}
    return {key: {"psnr": scored.psnr, "flip": scored.flip} for key, scored in scores.items()}


def case_row(case: BenchAsset, metrics: dict, scored: dict) -> dict:
    """The table's row of one case from the path-traced run's ``metrics`` and the scores on its
    views of ``simplify`` and of ours in three.js (``scored``), with the bar."""
    heldout, seconds = metrics["heldout"], metrics["seconds"]
    row = {"asset": case.name, "triangles": metrics["triangles"]["output"],
           "minutes": seconds["total"] / 60, "minutes_reference": metrics["reference_views"]["seconds"] / 60,
           "minutes_fit": seconds.get("optimisation", 0.0) / 60, "variant": metrics["reference_views"]["variant"],
           "iterations": metrics["iterations"]}
    for key, method in (("bake", "baked"), ("input", "input_rasterized"), ("ours", "ours")):
        row[f"psnr_{key}"], row[f"flip_{key}"] = heldout[method]["psnr"], heldout[method]["flip"]
    for key in ("simplify", "engine"):
        row[f"psnr_{key}"], row[f"flip_{key}"] = scored[key]["psnr"], scored[key]["flip"]
    row["engine_minus_ours_db"] = row["psnr_engine"] - row["psnr_ours"]
    row["gain_over_bake_db"] = row["psnr_ours"] - row["psnr_bake"]
    row["gain_over_simplify_db"] = row["psnr_ours"] - row["psnr_simplify"]
    row["meets_bar"] = (row["minutes"] <= BAR_MINUTES and row["gain_over_bake_db"] >= BAR_GAIN_OVER_BAKE_DB
                        and row["gain_over_simplify_db"] >= BAR_GAIN_OVER_SIMPLIFY_DB
                        and row["flip_ours"] < min(row["flip_bake"], row["flip_simplify"])
                        and abs(row["engine_minus_ours_db"]) <= BAR_ENGINE_DB)
    return row


def run(out: str | Path | None = None, time_budget: float = TIME_BUDGET_S, assets: tuple[BenchAsset, ...] = ASSETS,
        assets_dir: str | Path = SHARED_ASSETS, reuse: bool = False) -> dict:
    """Run each case and ``simplify`` beside it (``out`` keeps the runs, ``reuse`` takes those
    already there); ``{"time_budget_s", "bar", "rows", "all_meet_bar", "outputs"}``."""
    from ..webgl import require_threejs

    assets_dir = check_assets_dir(assets_dir)
    require_threejs()
    with tempfile.TemporaryDirectory(prefix="lookalike-bench-") as scratch:
        root = output_root(out, scratch)
        rows = []
        for case in assets:
            run_dir, simplify_dir = root / case.name, root / f"{case.name}-simplify"
            if not (reuse and (run_dir / "metrics.json").is_file()):
                stop_if_interrupted(path_traced_case(case, assets_dir, run_dir, time_budget))
            if not (reuse and (simplify_dir / "metrics.json").is_file()):
                stop_if_interrupted(simplify_case(case, assets_dir, simplify_dir, SIMPLIFY_BUDGET_S))
            scored = scored_on_path_traced_views(case, assets_dir, run_dir, simplify_dir / "model.glb")
            rows.append(case_row(case, json.loads((run_dir / "metrics.json").read_text()), scored))
        return {"time_budget_s": time_budget,
                "bar": {"minutes": BAR_MINUTES, "gain_over_bake_db": BAR_GAIN_OVER_BAKE_DB,
                        "gain_over_simplify_db": BAR_GAIN_OVER_SIMPLIFY_DB, "engine_db": BAR_ENGINE_DB},
                "rows": rows, "all_meet_bar": all(r["meets_bar"] for r in rows),
                "outputs": None if root == Path(scratch) else str(root.resolve())}


COLUMNS = (("asset", "asset", "{}"), ("triangles", "triangles", "{:,}"), ("min. reference", "minutes_reference", "{:.1f}"),
           ("min. fit", "minutes_fit", "{:.1f}"), ("min. total", "minutes", "{:.1f}"), ("steps", "iterations", "{}"),
           ("PSNR bake", "psnr_bake", "{:.2f}"), ("PSNR input", "psnr_input", "{:.2f}"),
           ("PSNR simplify", "psnr_simplify", "{:.2f}"), ("PSNR ours", "psnr_ours", "{:.2f}"),
           ("vs bake dB", "gain_over_bake_db", "{:+.2f}"), ("vs simplify dB", "gain_over_simplify_db", "{:+.2f}"),
           ("FLIP bake", "flip_bake", "{:.4f}"), ("FLIP simplify", "flip_simplify", "{:.4f}"),
           ("FLIP ours", "flip_ours", "{:.4f}"), ("PSNR three.js", "psnr_engine", "{:.2f}"),
           ("three.js - ours dB", "engine_minus_ours_db", "{:+.2f}"), ("Mitsuba", "variant", "{}"))


def format_table(result: dict) -> str:
    """The cases as an aligned text table with the bar."""
    bar = result["bar"]
    line = (f"bar: each run <= {bar['minutes']:g} min with its reference renders; ours >= classic bake + "
            f"{bar['gain_over_bake_db']:g} dB and >= simplify + {bar['gain_over_simplify_db']:g} dB with lower FLIP; "
            f"model.glb in three.js within {bar['engine_db']:g} dB of ours")
    return runs_table(dict(result, runs=result["rows"]), COLUMNS, line, lambda rows: [])
