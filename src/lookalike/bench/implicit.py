"""``lookalike bench implicit``: ``simplify`` with default settings on the two bundled signed
distance fields (``examples/rook.py``, ``examples/gear.glsl``) at 2,000 triangles, scored on
held-out views of the field itself (sphere-traced) against marching cubes decimated to the count
with colour at the vertices (plain decimation) and marching cubes + the classic bake (the
field's own material and normals baked onto the decimated mesh).

Bar: each run within 10 minutes; ours at least 1 dB above marching cubes + bake with a lower
FLIP. ``--judge blender`` also judges each run in Blender against a very fine marching-cubes
mesh of the field (``JUDGE_CELLS`` cubes across, roughness and metalness as a palette of
materials), in Cycles and in our renderer, with the same bar in Cycles with shadows.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from ._table import judged_table, runs_table
from .quality import (BAR_GAIN_OVER_BAKED_DB, BAR_MINUTES, TIME_BUDGET_S, BenchAsset, case_rows, check_judge,
                      output_root, table_row)

HELP = "simplify the two bundled signed distance fields and compare with marching cubes + decimation/bake"

EXAMPLES = Path(__file__).resolve().parents[3] / "examples"
ASSETS = (BenchAsset("rook", "rook.py", 2000, False), BenchAsset("gear", "gear.glsl", 2000, False))
JUDGE_CELLS = 960
"""Marching-cubes cubes across the field for the mesh Cycles judges against..."""
JUDGE_BLOCK = 8
"""... evaluated near the surface only, in blocks of this many cubes (``asset.implicit.narrow_band_values``)."""


def field_row(case: BenchAsset, metrics: dict) -> dict:
    """``quality.table_row`` of a run, its bar this benchmark's: within ``BAR_MINUTES``, ours at
    least ``BAR_GAIN_OVER_BAKED_DB`` above marching cubes + bake with a lower FLIP."""
    row = table_row(case, metrics)
    row["meets_bar"] = (row["minutes"] <= BAR_MINUTES and row["gain_over_baked_db"] >= BAR_GAIN_OVER_BAKED_DB
                        and row["flip_ours"] < row["flip_baked"])
    return row


def judged_field(case: BenchAsset, assets_dir: Path, run_dir: Path, baselines: dict | None) -> dict:
    """Judge the run of ``case`` in Blender against the field's marching-cubes mesh at
    ``JUDGE_CELLS`` (``lookalike.jobs.judge.judge_run``), the baselines the run's own
    (``baselines``, or made again from its input and settings: not from the fine mesh); with the
    gain of ours over our bake in Cycles with shadows and whether it meets the bar."""
    from .. import io
    from ..init.initial_guess import target_triangle_count
    from ..io.field_asset import field_asset
    from ..jobs.judge import judge_run
    from ..jobs.simplify import build_initial_guess
    from ..settings import load_config

    path = assets_dir / case.path
    asset = io.load(path)
    if baselines is None:
        cfg = load_config(run_dir / "config.toml")
        count = target_triangle_count(cfg.latent.triangles, cfg.latent.ratio, asset.mesh.num_triangles)
        guess = build_initial_guess(asset, cfg, count)
        baselines = {"decimated": guess.baseline, "baked": guess.baked}
    judged = judge_run(run_dir, field_asset(asset.field, path, cells=JUDGE_CELLS, block=JUDGE_BLOCK), baselines)
    cycles = judged["scores"]["cycles"]
    judged["gain_over_baked_db"] = cycles["ours"]["psnr"] - cycles["baked"]["psnr"]
    judged["gain_over_blender_db"] = cycles["ours"]["psnr"] - cycles["blender"]["psnr"]
    judged["meets_bar"] = (judged["gain_over_baked_db"] >= BAR_GAIN_OVER_BAKED_DB
                           and cycles["ours"]["flip"] < cycles["baked"]["flip"])
    return judged


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
                "bar": {"minutes": BAR_MINUTES, "gain_over_baked_db": BAR_GAIN_OVER_BAKED_DB},
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


def judge_lines(rows: list[dict]) -> list[str]:
    """The judge's table (each renderer's PSNR and FLIP of every method) and its bar."""
    flat = [{"asset": r["asset"], "judge": r["judge"]["scores"]} for r in rows if "judge" in r]
    lines = judged_table(flat, "field", JUDGED, "ours", (("ours-bake dB", "baked"), ("ours-Blender dB", "blender")),
                         f"judge: against the field's marching-cubes mesh at {JUDGE_CELLS} cubes across")
    met = all(r["judge"]["meets_bar"] for r in rows if "judge" in r)
    lines.append(f"judge bar: in Cycles with shadows ours >= marching cubes + bake + {BAR_GAIN_OVER_BAKED_DB:g} dB with "
                 f"lower FLIP: {'met' if met else 'NOT met'}")
    return lines


def format_table(result: dict) -> str:
    """The runs as an aligned text table with the bar, and the judge's where judged."""
    return runs_table(result, COLUMNS, f"bar: each run <= {BAR_MINUTES:g} min, ours >= marching cubes + bake + "
                      f"{BAR_GAIN_OVER_BAKED_DB:g} dB with lower FLIP", judge_lines)
