"""``lookalike bench implicit``: ``simplify`` with default settings on the signed distance
fields of ``examples/`` (``FIELDS``: the bundled rook and gear, and fields of other characters:
a machined part, an organic blend with thin parts, fine periodic relief) at 1,000 and 2,000
triangles, scored on held-out views of the field itself (sphere-traced) against marching cubes
decimated to the count with colour at the vertices (plain decimation) and marching cubes + the
classic bake (the field's own material and normals baked onto the decimated mesh).

Bar: each run within 10 minutes; ours at least 1 dB above marching cubes + bake with a lower
FLIP. ``--judge blender`` also runs the pipeline a user without lookalike would: marching cubes
of the field at ``JUDGE_CELLS`` cubes across (roughness and metalness as a palette of
materials), then Blender's own decimate + unwrap + bake from that fine mesh
(``lookalike.jobs.judge``). Every method is then judged in Blender against that fine mesh, in
Cycles and in our renderer, and Blender's model is also scored, beside ours, on the run's own
held-out views of the field (``field_scores``). The judge's bar: ours at least 1 dB above
Blender's decimate + bake with a lower FLIP, in Cycles with shadows (against the fine mesh) and
in our renderer (against the field).
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from ._table import aligned_table, judged_table, runs_table
from .quality import (BAR_GAIN_OVER_BAKED_DB, BAR_JUDGE_GAIN_DB, BAR_MINUTES, TIME_BUDGET_S, BenchAsset, blender_kept,
                      case_rows, check_judge, output_root, table_row)

HELP = "simplify signed distance fields and compare with marching cubes + decimation/bake (and Blender's)"

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
FIELDS = (("rook", "rook.py"), ("gear", "gear.glsl"), ("bracket", "bracket.py"), ("coral", "coral.py"),
          ("vase", "vase.glsl"))
"""``(name, file in examples/)`` of the benchmark's fields: the two the README shows, then a
machined part (hard CSG edges, bores, paint that stops sharply at the machined faces), an organic
smooth blend with thin branches, and fine periodic relief under glazes that meet at sharp lines."""
TRIANGLES = (1000, 2000)
"""The triangle counts each field is simplified to."""
ASSETS = tuple(BenchAsset(f"{name}-{count}", file, count, False) for name, file in FIELDS for count in TRIANGLES)
JUDGE_CELLS = 1440
"""Marching-cubes cubes across the field for the mesh Cycles judges against, and Blender's
pipeline bakes from: fine enough that the mesh's own departures from the field (each crease
rounded within a cube) stay below those of the models judged, so that the judge does not favour
the model baked from the mesh itself..."""
JUDGE_BLOCK = 8
"""... evaluated near the surface only, in blocks of this many cubes (``asset.implicit.narrow_band_values``)."""


def field_row(case: BenchAsset, metrics: dict) -> dict:
    """``quality.table_row`` of a run, its bar this benchmark's: within ``BAR_MINUTES``, ours at
    least ``BAR_GAIN_OVER_BAKED_DB`` above marching cubes + bake with a lower FLIP."""
    row = table_row(case, metrics)
    row["meets_bar"] = (row["minutes"] <= BAR_MINUTES and row["gain_over_baked_db"] >= BAR_GAIN_OVER_BAKED_DB
                        and row["flip_ours"] < row["flip_baked"])
    return row


def judged_field(case: BenchAsset, assets_dir: Path, run_dir: Path, baselines: dict | None,
                 cells: int = JUDGE_CELLS, **judging) -> dict:
    """Judge the run of ``case`` in Blender (``lookalike.jobs.judge.judge_run``, ``judging``
    its ``resolution`` and ``views``) against the field's marching-cubes mesh at ``cells`` cubes
    across, from which Blender's decimate + bake is made, the other baselines the run's own
    (``baselines``, or made again from its input and settings: not from the fine mesh); then
    score Blender's model and ours on the run's held-out views of the field (``field_scores``,
    as ``"field"``). With the gains of ours over our bake and over Blender's in Cycles with
    shadows and over Blender's against the field, and whether it meets the bar: ours at least
    ``BAR_JUDGE_GAIN_DB`` above Blender's with a lower FLIP, in both. Blender's model is the one
    its user keeps (``jobs.judge.blender_baseline``: of the shaded-smooth model and the one smooth
    by angle, the better in Cycles with shadows); the field's scores call it ``"blender"``."""
    from .. import io
    from ..init.initial_guess import target_triangle_count
    from ..io.field_asset import field_asset
    from ..jobs.judge import JUDGE_FOLDER, blender_baseline, held_against, judge_run
    from ..jobs.outputs import MODEL_NAME
    from ..jobs.simplify import build_initial_guess
    from ..settings import load_config

    path = assets_dir / case.path
    asset = io.load(path)
    if baselines is None:
        cfg = load_config(run_dir / "config.toml")
        count = target_triangle_count(cfg.latent.triangles, cfg.latent.ratio, asset.mesh.num_triangles)
        guess = build_initial_guess(asset, cfg, count)
        baselines = {"decimated": guess.baseline, "baked": guess.baked}
    judged = judge_run(run_dir, field_asset(asset.field, path, cells=cells, block=JUDGE_BLOCK), baselines, **judging)
    kept = run_dir / JUDGE_FOLDER / f"{blender_baseline(judged)}.glb"
    judged["field"] = field_scores(run_dir, asset, {"blender": kept, "ours": run_dir / MODEL_NAME})
    cycles, field = held_against(judged, judged["scores"]["cycles"]), judged["field"]
    judged["gain_over_baked_db"] = cycles["ours"]["psnr"] - cycles["baked"]["psnr"]
    judged["gain_over_blender_db"] = cycles["ours"]["psnr"] - cycles["blender"]["psnr"]
    judged["field_gain_over_blender_db"] = field["ours"]["psnr"] - field["blender"]["psnr"]
    judged["meets_bar"] = all(gain >= BAR_JUDGE_GAIN_DB and scores["ours"]["flip"] < scores["blender"]["flip"]
                              for gain, scores in ((judged["gain_over_blender_db"], cycles),
                                                   (judged["field_gain_over_blender_db"], field)))
    return judged


def field_scores(run_dir: Path, asset, models: dict[str, Path]) -> dict[str, dict[str, float]]:
    """``{key: {"psnr", "flip"}}``: each glb of ``models`` scored as the run in ``run_dir``
    scores ours, on its held-out views of the field ``asset`` (the run's reference, views, seed,
    resolution and draw: ``lookalike.jobs.run``), against the field itself."""
    from .. import io
    from ..fit.training_views import view_sampler
    from ..jobs.reference_kinds import run_reference
    from ..jobs.run import scoring_draw
    from ..report.heldout import HeldoutViews
    from ..report.metrics import flip, psnr
    from ..settings import load_config

    cfg = load_config(run_dir / "config.toml")
    reference = run_reference(asset, cfg, moving=False).renderer
    centre, radius = reference.bounding_sphere()
    views = HeldoutViews(reference, view_sampler(centre, radius, fixed_light=reference.fixed_light),
                         cfg.views.heldout, cfg.views.heldout_seed, cfg.render.resolution, cfg.render.target_spp)
    draw, scores = scoring_draw(cfg), {}
    for key, glb in models.items():
        images = views.images(io.load(glb), draw)
        scores[key] = {"psnr": psnr(views.reference, images), "flip": flip(views.reference, images)}
    return scores


def run(out: str | Path | None = None, time_budget: float = TIME_BUDGET_S, assets: tuple[BenchAsset, ...] = ASSETS,
        assets_dir: str | Path = EXAMPLES, judge: str | None = None, reuse: bool = False, repeats: int | None = None) -> dict:
    """Simplify each field once (``quality.run``'s arguments: ``out`` keeps the runs,
    ``reuse`` takes those already there, ``judge="blender"`` judges them) and collect the
    held-out scores; ``{"time_budget_s", "bar", "runs", "all_meet_bar", "outputs"}``."""
    if judge is not None:
        check_judge(judge)
    assets_dir = Path(assets_dir)
    with tempfile.TemporaryDirectory(prefix="lookalike-bench-") as scratch:
        root = output_root(out, scratch)
        rows = case_rows(assets, assets_dir, root, time_budget, reuse, field_row,
                         judged_field if judge is not None else None)
        return {"time_budget_s": time_budget,
                "bar": {"minutes": BAR_MINUTES, "gain_over_baked_db": BAR_GAIN_OVER_BAKED_DB,
                        **({"judge_gain_over_blender_db": BAR_JUDGE_GAIN_DB} if judge is not None else {})},
                "runs": rows,
                "all_meet_bar": all(r["meets_bar"] and r.get("judge", {}).get("meets_bar", True) for r in rows),
                "outputs": None if root == Path(scratch) else str(root.resolve())}


COLUMNS = (("field", "asset", "{}"), ("triangles", "triangles", "{:,}"), ("minutes", "minutes", "{:.1f}"),
           ("s/iter", "seconds_per_iteration", "{:.2f}"), ("iters", "iterations", "{:,}"),
           ("PSNR MC+dec", "psnr_decimated", "{:.2f}"), ("PSNR MC+bake", "psnr_baked", "{:.2f}"),
           ("PSNR ours", "psnr_ours", "{:.2f}"), ("vs bake dB", "gain_over_baked_db", "{:+.2f}"),
           ("FLIP MC+dec", "flip_decimated", "{:.4f}"), ("FLIP MC+bake", "flip_baked", "{:.4f}"),
           ("FLIP ours", "flip_ours", "{:.4f}"))
JUDGED = (("MC+dec", "decimated"), ("MC+bake", "baked"), ("Blender", "blender"), ("ours", "ours"))
"""(column name, method key) of the judged methods; ``"blender"`` stands for the model of
Blender's pipeline its user keeps (``jobs.judge.blender_baseline``)."""


def judge_lines(rows: list[dict]) -> list[str]:
    """The judge's tables (each renderer's PSNR and FLIP of every method against the fine mesh;
    Blender's decimate + bake beside ours and our bake against the field) and its bar."""
    from ..jobs.judge import held_against

    judged = [r for r in rows if "judge" in r]
    flat = [{"asset": r["asset"], "judge": {renderer: held_against(r["judge"], scores)
                                            for renderer, scores in r["judge"]["scores"].items()}} for r in judged]
    lines = judged_table(flat, "field", JUDGED, "ours", (("ours-bake dB", "baked"), ("ours-Blender dB", "blender")),
                         f"judge: against the field's marching-cubes mesh at {JUDGE_CELLS} cubes across")
    cells = [[r["asset"], f"{r['psnr_baked']:.2f}", f"{r['judge']['field']['blender']['psnr']:.2f}",
              f"{r['judge']['field']['ours']['psnr']:.2f}", f"{r['judge']['field_gain_over_blender_db']:+.2f}",
              f"{r['flip_baked']:.4f}", f"{r['judge']['field']['blender']['flip']:.4f}",
              f"{r['judge']['field']['ours']['flip']:.4f}", "ok" if r["judge"]["meets_bar"] else "MISSED"]
             for r in judged]
    lines += ["", "against the field itself, our renderer (the run's held-out views; ours as written):"]
    lines += aligned_table(["field", "PSNR MC+bake", "PSNR Blender", "PSNR ours", "ours-Blender dB", "FLIP MC+bake",
                            "FLIP Blender", "FLIP ours", "judge bar"], cells)
    met = all(r["judge"]["meets_bar"] for r in judged)
    lines.append(f"judge bar: ours >= marching cubes + Blender's decimate + bake + {BAR_JUDGE_GAIN_DB:g} dB with lower "
                 f"FLIP, in Cycles with shadows (against the {JUDGE_CELLS}-cube mesh) and in our renderer (against the "
                 f"field): {'met' if met else 'NOT met'}")
    return lines + [blender_kept(judged)]


def format_table(result: dict) -> str:
    """The runs as an aligned text table with the bar, and the judge's where judged."""
    return runs_table(result, COLUMNS, f"bar: each run <= {BAR_MINUTES:g} min, ours >= marching cubes + bake + "
                      f"{BAR_GAIN_OVER_BAKED_DB:g} dB with lower FLIP", judge_lines)
