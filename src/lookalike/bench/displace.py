"""``lookalike bench displace``: ``displace`` with default settings (levels 0 to 3) on nefertiti
(a base of 1,000 triangles) and stanford-bunny (750), each level scored on the run's held-out
views beside the classic decimate + bake at the level's triangle count (from the run's report)
and ``simplify`` at that count (a run of its own per level, the displace run's budget split over
the levels, so that both spend the same time), with file bytes: one base mesh with one set of
maps against a mesh with maps for each count.

Bar: each run within 10 minutes; at every level from 1 up, ours at least 0.5 dB above the
classic bake at that count with a lower FLIP, in our renderer and (``--judge blender``) in
Cycles with shadows, where each level (``lodK.glb``) and each classic bake is rendered.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

from ._table import aligned_table
from .quality import BAR_MINUTES, SHARED_ASSETS, TIME_BUDGET_S, BenchAsset, check_assets_dir, check_judge, \
    output_root, scan_material, simplify_case, stop_if_interrupted

HELP = "fit base meshes with displacement maps at levels 0-3 and compare each level with the classic bake"

ASSETS = (BenchAsset("nefertiti", "nefertiti/nefertiti.obj", 1000, True),
          BenchAsset("stanford-bunny", "stanford-bunny/stanford-bunny.obj", 750, True))
BAR_GAIN_DB = 0.5
"""Ours over the classic bake at each level's triangle count, from level 1 up."""


def displace_case(case: BenchAsset, assets_dir: Path, outdir: Path, time_budget: float):
    """``displace`` of one case with default settings, its base ``case.triangles``; the
    ``RunResult``."""
    from ..jobs.displace import displace

    return displace(assets_dir / case.path, outdir, triangles=case.triangles, time_budget=time_budget, force=True,
                    progress=False, material_override=scan_material() if case.scan else None)


def level_rows(case: BenchAsset, metrics: dict, simplified: dict[int, dict]) -> list[dict]:
    """One row per level of a run's ``metrics["levels"]``, with ``simplify``'s scores at the
    level's count (``simplified``: level -> its run's metrics) and whether it meets the bar."""
    rows = []
    for level in metrics["levels"]:
        row = {"asset": case.name, "minutes": metrics["seconds"]["total"] / 60, **level}
        if level["level"] in simplified:
            ours = simplified[level["level"]]["heldout"]["ours"]
            row.update({"simplify_psnr": ours["psnr"], "simplify_flip": ours["flip"]})
        if "bake_psnr" in row:
            row["gain_over_bake_db"] = row["psnr"] - row["bake_psnr"]
        row["meets_bar"] = row["minutes"] <= BAR_MINUTES and (
            level["level"] == 0 or ("bake_psnr" in row and row["gain_over_bake_db"] >= BAR_GAIN_DB
                                    and row["flip"] < row["bake_flip"]))
        rows.append(row)
    return rows


def judged_levels(case: BenchAsset, assets_dir: Path, run_dir: Path, baselines: dict) -> dict:
    """Each level (``lodK.glb``) and the classic bake at its count rendered in Cycles and ours
    on the run's held-out views (``lookalike.jobs.judge_scores.judge_models``); ``{"scores":
    {renderer: {key: scores}}, "meets_bar"}``, keys ``ours_lK`` and ``bake_lK``."""
    from .. import io
    from ..fit.reference import MeshReference
    from ..jobs.input_asset import prepare_input
    from ..jobs.judge_scores import JudgedModel, heldout_views, judge_models
    from ..settings import load_config

    cfg = load_config(run_dir / "config.toml")
    reference_asset, _ = prepare_input(io.load(assets_dir / case.path), scan_material() if case.scan else None)
    folder = run_dir / "judge"
    folder.mkdir(exist_ok=True)
    io.save(reference_asset, folder / "reference.glb")
    models = []
    for level in cfg.latent.tessellation_levels:
        if f"bake_l{level}" in baselines:
            io.save(baselines[f"bake_l{level}"], folder / f"bake_l{level}.glb")
            models.append(JudgedModel(f"bake_l{level}", f"Classic bake, level {level}", folder / f"bake_l{level}.glb",
                                      baselines[f"bake_l{level}"]))
        lod = run_dir / f"lod{level}.glb"
        models.append(JudgedModel(f"ours_l{level}", f"Ours, level {level}", lod, io.load(lod)))
    reference = MeshReference(reference_asset)
    views = heldout_views(reference, cfg.views.heldout, cfg.views.heldout_seed)
    result = judge_models(reference, folder / "reference.glb", models, views, spp=cfg.render.target_spp,
                          msaa=cfg.render.latent_msaa, contact_sheet_path=folder / "views.png")
    (folder / "judge.json").write_text(json.dumps(result, indent=2))
    cycles = result["scores"]["cycles"]
    met = all(cycles[f"ours_l{level}"]["psnr"] >= cycles[f"bake_l{level}"]["psnr"] + BAR_GAIN_DB
              and cycles[f"ours_l{level}"]["flip"] < cycles[f"bake_l{level}"]["flip"]
              for level in cfg.latent.tessellation_levels if level > 0 and f"bake_l{level}" in cycles)
    return {"scores": result["scores"], "meets_bar": met}


def run(out: str | Path | None = None, time_budget: float = TIME_BUDGET_S, assets: tuple[BenchAsset, ...] = ASSETS,
        assets_dir: str | Path = SHARED_ASSETS, judge: str | None = None, reuse: bool = False) -> dict:
    """Run each case (``out`` keeps the runs, ``reuse`` takes those already there,
    ``judge="blender"`` judges them) and ``simplify`` at each level's count; ``{"time_budget_s",
    "bar", "runs" (one row per asset and level), "judged", "all_meet_bar", "outputs"}``."""
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
            metrics = json.loads((run_dir / "metrics.json").read_text())
            levels = [row["level"] for row in metrics["levels"]]
            simplified = {}
            for row in metrics["levels"]:
                folder = root / f"{case.name}-simplify-{row['triangles']}"
                if not (reuse and (folder / "metrics.json").is_file()):
                    counted = BenchAsset(case.name, case.path, row["triangles"], case.scan)
                    stop_if_interrupted(simplify_case(counted, assets_dir, folder, time_budget / len(levels)))
                simplified[row["level"]] = json.loads((folder / "metrics.json").read_text())
            rows += level_rows(case, metrics, simplified)
            if judge is not None:
                baselines = result.baselines if result is not None else rebuilt_bakes(case, assets_dir, run_dir)
                judged[case.name] = judged_levels(case, assets_dir, run_dir, baselines)
        return {"time_budget_s": time_budget, "bar": {"minutes": BAR_MINUTES, "gain_over_bake_db": BAR_GAIN_DB},
                "runs": rows, "judged": judged,
                "all_meet_bar": all(r["meets_bar"] for r in rows) and all(j["meets_bar"] for j in judged.values()),
                "outputs": None if root == Path(scratch) else str(root.resolve())}


def rebuilt_bakes(case: BenchAsset, assets_dir: Path, run_dir: Path) -> dict:
    """The classic bakes at each level's count of a reused run, made again from its settings."""
    from .. import io
    from ..init.initial_guess import target_triangle_count
    from ..jobs.displace import classic_bakes
    from ..jobs.input_asset import prepare_input
    from ..jobs.simplify import build_initial_guess
    from ..settings import load_config

    cfg = load_config(run_dir / "config.toml")
    asset, _ = prepare_input(io.load(assets_dir / case.path), scan_material() if case.scan else None)
    guess = build_initial_guess(asset, cfg, target_triangle_count(cfg.latent.triangles, cfg.latent.ratio,
                                                                 asset.mesh.num_triangles))
    return {key: model for key, _, model in classic_bakes(asset, cfg, guess, sorted(cfg.latent.tessellation_levels))}


COLUMNS = (("asset", "asset", "{}"), ("level", "level", "{}"), ("triangles", "triangles", "{:,}"),
           ("bytes ours", "bytes", "{:,}"), ("bytes bake", "bake_bytes", "{:,}"),
           ("PSNR bake", "bake_psnr", "{:.2f}"), ("PSNR simplify", "simplify_psnr", "{:.2f}"),
           ("PSNR ours", "psnr", "{:.2f}"), ("vs bake dB", "gain_over_bake_db", "{:+.2f}"),
           ("FLIP bake", "bake_flip", "{:.4f}"), ("FLIP simplify", "simplify_flip", "{:.4f}"),
           ("FLIP ours", "flip", "{:.4f}"), ("minutes", "minutes", "{:.1f}"))


def format_table(result: dict) -> str:
    """The levels as an aligned text table with the bar, and the judge's per level."""
    header = [name for name, _, _ in COLUMNS] + ["bar"]
    cells = [[fmt.format(r[key]) if key in r else "—" for _, key, fmt in COLUMNS]
             + ["—" if r["level"] == 0 else "ok" if r["meets_bar"] else "MISSED"] for r in result["runs"]]
    lines = aligned_table(header, cells)
    lines.append(f"bar: each run <= {BAR_MINUTES:g} min; from level 1 up, ours >= classic bake + {BAR_GAIN_DB:g} dB with "
                 f"lower FLIP: {'met' if result['all_meet_bar'] else 'NOT met'}")
    for name, judged in result.get("judged", {}).items():
        for renderer, scores in judged["scores"].items():
            levels = sorted({int(key.split("_l")[1]) for key in scores})
            lines.append(f"judge {name} {renderer}: " + "; ".join(
                f"L{level} bake {scores[f'bake_l{level}']['psnr']:.2f} / ours {scores[f'ours_l{level}']['psnr']:.2f}"
                if f"bake_l{level}" in scores else f"L{level} ours {scores[f'ours_l{level}']['psnr']:.2f}"
                for level in levels))
    if result.get("outputs"):
        lines.append(f"outputs: {result['outputs']}")
    return "\n".join(lines)
