"""``lookalike bench displace``: ``displace`` with default settings (levels 0 to 3, engine
shading) on nefertiti (a base of 1,000 triangles) and stanford-bunny (750), each level scored on
the run's held-out views beside the classic displacement bake at that level (the run's start:
the same base, heights baked by rays along the base's interpolated normals, a normal map baked
in the base's interpolated frame) and the classic decimate + bake at the base's own count, with
file bytes and GPU memory, and the PSNR that the same bytes buy as a plain mesh (the classic
decimate + bake at each level's count, interpolated in log bytes).

Bar (``level_rows``, and with ``--judge blender`` the same in Cycles with shadows, where every
level of ours and of the classic displacement bake is rendered from its ``lodK.glb``): each run
within 10 minutes; at every level ours at least 0.5 dB above the classic displacement bake with
a lower FLIP; each level at least the one below less 0.1 dB; level 2 at least 3 dB above the
classic decimate + bake at the base's count.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import numpy as np

from ._table import aligned_table
from .quality import BAR_MINUTES, SHARED_ASSETS, TIME_BUDGET_S, BenchAsset, check_assets_dir, check_judge, \
    output_root, scan_material, stop_if_interrupted

HELP = "fit base meshes with displacement maps at levels 0-3 and compare each level with the classic bake"

ASSETS = (BenchAsset("nefertiti", "nefertiti/nefertiti.obj", 1000, True),
          BenchAsset("stanford-bunny", "stanford-bunny/stanford-bunny.obj", 750, True))
BAR_GAIN_DB = 0.5
"""Ours over the classic displacement bake, at every level."""
BAR_LEVEL_SLACK_DB = 0.1
"""How far a level may fall below the one under it."""
BAR_OVER_BASE_DB = 3.0
"""Level ``BAR_OVER_BASE_LEVEL`` over the classic decimate + bake at the base's own count."""
BAR_OVER_BASE_LEVEL = 2


def displace_case(case: BenchAsset, assets_dir: Path, outdir: Path, time_budget: float):
    """``displace`` of one case with default settings, its base ``case.triangles``; the
    ``RunResult``."""
    from ..jobs.displace import displace

    return displace(assets_dir / case.path, outdir, triangles=case.triangles, time_budget=time_budget, force=True,
                    progress=False, material_override=scan_material() if case.scan else None)


def same_bytes_psnr(levels: list[dict]) -> float | None:
    """The held-out PSNR a plain mesh (the classic decimate + bake) reaches at ours' file bytes
    (``base.glb`` with its maps), linear in log bytes between the bakes at the levels' counts
    (``bake_bytes``, ``bake_psnr``), clamped at their ends; ``None`` without two bakes."""
    bakes = sorted((row["bake_bytes"], row["bake_psnr"]) for row in levels if "bake_bytes" in row)
    if len(bakes) < 2:
        return None
    sizes, scores = np.log([b for b, _ in bakes]), [p for _, p in bakes]
    return float(np.interp(np.log(levels[0]["bytes"]), sizes, scores))


def bar_checks(scores: dict[str, dict], levels: list[int]) -> dict[int, dict[str, bool]]:
    """Per level, the bar's clauses on ``scores`` (key -> ``{"psnr", "flip"}``: ``ours_lK``,
    ``start_lK`` for every level, ``bake_l0``): ``over_start`` (ours at least ``BAR_GAIN_DB``
    above the classic displacement bake with a lower FLIP), ``over_below`` (at least the level
    below less ``BAR_LEVEL_SLACK_DB``), ``over_base`` (at ``BAR_OVER_BASE_LEVEL``, at least
    ``BAR_OVER_BASE_DB`` above the classic decimate + bake at the base's count)."""
    checks = {}
    for i, level in enumerate(levels):
        ours, start = scores[f"ours_l{level}"], scores[f"start_l{level}"]
        checks[level] = {
            "over_start": ours["psnr"] >= start["psnr"] + BAR_GAIN_DB and ours["flip"] < start["flip"],
            "over_below": i == 0 or ours["psnr"] >= scores[f"ours_l{levels[i - 1]}"]["psnr"] - BAR_LEVEL_SLACK_DB,
            "over_base": level != BAR_OVER_BASE_LEVEL or "bake_l0" not in scores
            or ours["psnr"] >= scores["bake_l0"]["psnr"] + BAR_OVER_BASE_DB}
    return checks


def level_rows(case: BenchAsset, metrics: dict) -> list[dict]:
    """One row per level of a run's ``metrics["levels"]``, with its gains over the classic
    displacement bake and over the classic decimate + bake at the base's count, the PSNR the
    same bytes buy as a plain mesh, and whether it meets the bar (``bar_checks``)."""
    levels = metrics["levels"]
    base_bake = next((row for row in levels if row["level"] == levels[0]["level"] and "bake_psnr" in row), None)
    scores = {f"{key}_l{row['level']}": {"psnr": row[psnr], "flip": row[flip]}
              for row in levels for key, psnr, flip in (("ours", "psnr", "flip"), ("start", "start_psnr", "start_flip"))}
    if base_bake is not None:
        scores["bake_l0"] = {"psnr": base_bake["bake_psnr"], "flip": base_bake["bake_flip"]}
    checks = bar_checks(scores, [row["level"] for row in levels])
    same_bytes = same_bytes_psnr(levels)
    rows = []
    for level in levels:
        row = {"asset": case.name, "minutes": metrics["seconds"]["total"] / 60, **level,
               "gain_over_start_db": level["psnr"] - level["start_psnr"]}
        if base_bake is not None:
            row.update({"base_bake_psnr": base_bake["bake_psnr"], "base_bake_flip": base_bake["bake_flip"],
                        "gain_over_base_bake_db": level["psnr"] - base_bake["bake_psnr"]})
        if same_bytes is not None:
            row["same_bytes_psnr"] = same_bytes
        row["meets_bar"] = row["minutes"] <= BAR_MINUTES and all(checks[level["level"]].values())
        rows.append(row)
    return rows


def judged_levels(case: BenchAsset, assets_dir: Path, run_dir: Path, baselines: dict) -> dict:
    """Each level of ours and of the classic displacement bake (``lodK.glb``, ``start_lK.glb``)
    and the classic decimate + bake at the base's count rendered in Cycles and ours on the run's
    held-out views (``lookalike.jobs.judge_scores.judge_models``); ``{"scores": {renderer:
    {key: scores}}, "checks", "meets_bar"}``, keys ``ours_lK``, ``start_lK`` and ``bake_l0``,
    the bar's clauses (``bar_checks``) in Cycles with shadows."""
    from .. import io
    from ..fit.reference import MeshReference
    from ..jobs.displace import written_level
    from ..jobs.input_asset import prepare_input
    from ..jobs.judge_scores import JudgedModel, heldout_views, judge_models
    from ..settings import load_config

    cfg = load_config(run_dir / "config.toml")
    levels = sorted(cfg.latent.tessellation_levels)
    reference_asset, _ = prepare_input(io.load(assets_dir / case.path), scan_material() if case.scan else None)
    folder = run_dir / "judge"
    folder.mkdir(exist_ok=True)
    io.save(reference_asset, folder / "reference.glb")
    models = []
    for key, label, model in [("bake_l0", "Classic decimate + bake, base count", baselines.get("bake_l0"))] + [
            (f"start_l{level}", f"Classic displacement bake, level {level}",
             written_level(baselines["start" if level == levels[-1] else f"start_l{level}"])) for level in levels]:
        if model is not None:
            io.save(model, folder / f"{key}.glb")
            models.append(JudgedModel(key, label, folder / f"{key}.glb", model))
    for level in levels:
        lod = run_dir / f"lod{level}.glb"
        models.append(JudgedModel(f"ours_l{level}", f"Ours, level {level}", lod, io.load(lod)))
    reference = MeshReference(reference_asset)
    views = heldout_views(reference, cfg.views.heldout, cfg.views.heldout_seed)
    result = judge_models(reference, folder / "reference.glb", models, views, spp=cfg.render.target_spp,
                          msaa=cfg.render.latent_msaa, contact_sheet_path=folder / "views.png")
    (folder / "judge.json").write_text(json.dumps(result, indent=2))
    checks = bar_checks(result["scores"]["cycles"], levels)
    return {"scores": result["scores"], "checks": checks,
            "meets_bar": all(all(clauses.values()) for clauses in checks.values())}


def run(out: str | Path | None = None, time_budget: float = TIME_BUDGET_S, assets: tuple[BenchAsset, ...] = ASSETS,
        assets_dir: str | Path = SHARED_ASSETS, judge: str | None = None, reuse: bool = False) -> dict:
    """Run each case (``out`` keeps the runs, ``reuse`` takes those already there,
    ``judge="blender"`` judges them); ``{"time_budget_s", "bar", "runs" (one row per asset and
    level), "judged", "all_meet_bar", "outputs"}``."""
    if judge is not None:
        check_judge(judge)
    assets_dir = check_assets_dir(assets_dir)
    with tempfile.TemporaryDirectory(prefix="lookalike-bench-") as scratch:
        root = output_root(out, scratch)
        rows, judged = [], {}
        for case in assets:
            run_dir = root / case.name
            result = None
            if not (reuse and (run_dir / "metrics.json").is_file()):
                result = displace_case(case, assets_dir, run_dir, time_budget)
                stop_if_interrupted(result)
            rows += level_rows(case, json.loads((run_dir / "metrics.json").read_text()))
            if judge is not None:
                baselines = result.baselines if result is not None else rebuilt_baselines(case, assets_dir, run_dir)
                judged[case.name] = judged_levels(case, assets_dir, run_dir, baselines)
        return {"time_budget_s": time_budget,
                "bar": {"minutes": BAR_MINUTES, "gain_over_start_db": BAR_GAIN_DB,
                        "level_slack_db": BAR_LEVEL_SLACK_DB, "level": BAR_OVER_BASE_LEVEL,
                        "gain_over_base_bake_db": BAR_OVER_BASE_DB},
                "runs": rows, "judged": judged,
                "all_meet_bar": all(r["meets_bar"] for r in rows) and all(j["meets_bar"] for j in judged.values()),
                "outputs": None if root == Path(scratch) else str(root.resolve())}


def rebuilt_baselines(case: BenchAsset, assets_dir: Path, run_dir: Path) -> dict:
    """A reused run's start and comparisons (``displace_guess``), made again from its settings."""
    from .. import io
    from ..init.initial_guess import target_triangle_count
    from ..jobs.displace import displace_guess
    from ..jobs.input_asset import prepare_input
    from ..settings import load_config

    cfg = load_config(run_dir / "config.toml")
    asset, _ = prepare_input(io.load(assets_dir / case.path), scan_material() if case.scan else None)
    guess = displace_guess(asset, cfg, target_triangle_count(cfg.latent.triangles, cfg.latent.ratio,
                                                             asset.mesh.num_triangles))
    return {"start": guess.start, **{key: model for key, _, model in guess.comparisons}}


COLUMNS = (("asset", "asset", "{}"), ("level", "level", "{}"), ("triangles", "triangles", "{:,}"),
           ("bytes ours", "bytes", "{:,}"), ("PSNR same bytes", "same_bytes_psnr", "{:.2f}"),
           ("PSNR bake at base", "base_bake_psnr", "{:.2f}"), ("PSNR classic displ.", "start_psnr", "{:.2f}"),
           ("PSNR ours", "psnr", "{:.2f}"), ("vs classic dB", "gain_over_start_db", "{:+.2f}"),
           ("vs bake at base dB", "gain_over_base_bake_db", "{:+.2f}"), ("FLIP classic displ.", "start_flip", "{:.4f}"),
           ("FLIP ours", "flip", "{:.4f}"), ("minutes", "minutes", "{:.1f}"))


def format_table(result: dict) -> str:
    """The levels as an aligned text table with the bar, and the judge's per level."""
    header = [name for name, _, _ in COLUMNS] + ["bar"]
    cells = [[fmt.format(r[key]) if key in r else "—" for _, key, fmt in COLUMNS]
             + ["ok" if r["meets_bar"] else "MISSED"] for r in result["runs"]]
    lines = aligned_table(header, cells)
    lines.append(f"bar: each run <= {BAR_MINUTES:g} min; at every level ours >= the classic displacement bake + "
                 f"{BAR_GAIN_DB:g} dB with lower FLIP and >= the level below - {BAR_LEVEL_SLACK_DB:g} dB; level "
                 f"{BAR_OVER_BASE_LEVEL} >= decimate + bake at the base's count + {BAR_OVER_BASE_DB:g} dB: "
                 f"{'met' if result['all_meet_bar'] else 'NOT met'}")
    for name, judged in result.get("judged", {}).items():
        for renderer, scores in judged["scores"].items():
            levels = sorted({int(key.split("_l")[1]) for key in scores if key.startswith("ours_l")})
            base = f"bake at base {scores['bake_l0']['psnr']:.2f}; " if "bake_l0" in scores else ""
            lines.append(f"judge {name} {renderer}: {base}" + "; ".join(
                f"L{level} classic {scores[f'start_l{level}']['psnr']:.2f} / {scores[f'start_l{level}']['flip']:.4f}, "
                f"ours {scores[f'ours_l{level}']['psnr']:.2f} / {scores[f'ours_l{level}']['flip']:.4f}"
                for level in levels))
    if result.get("outputs"):
        lines.append(f"outputs: {result['outputs']}")
    return "\n".join(lines)
