"""``lookalike bench skinned``: ``simplify`` of the rigged, animated benchmark characters of
``../shared/assets`` with default settings, scored on held-out (camera, light, clip, time)
views spread over every clip.

Per asset, ``simplify --compare-static``: two runs, ``simplify`` as a user runs it (fitted over
the animations, weights included) and the bind-pose fit (``--static``, a still model, with its
own budget), whose output gets the input's weights transferred from the closest point of its
surface (``lookalike.init.skin_weights.transfer_skin``) and is scored on the same views. The
table: plain decimation and the classic bake (weights transferred), the bind-pose fit, and ours.

Bar: each run within 10 minutes on a 2-core machine; ours at least 3 dB PSNR above plain
decimation and at least 0.5 dB above the bind-pose fit on every asset, with a lower FLIP than
both.

``--judge blender`` also judges every run in Blender Cycles (``lookalike.jobs.judge``): the
input, plain decimation, the classic bake, the bind-pose fit and ours, each posed by Blender's
own glTF importer at every held-out view's clip and time, scored against Cycles' picture of the
input (with shadows and without) as well as in our renderer.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

from ._table import judged_table, runs_table
from .quality import SHARED_ASSETS, TIME_BUDGET_S, BenchAsset, check_assets_dir, check_judge, output_root

HELP = "simplify the animated characters over their clips; compare with decimation and the bind-pose fit"

BAR_MINUTES = 10.0
BAR_GAIN_OVER_DECIMATED_DB = 3.0
BAR_GAIN_OVER_BIND_POSE_DB = 0.5

ASSETS = (
    BenchAsset("cesium-man", "cesium-man/CesiumMan.glb", 1000, False),
    BenchAsset("soldier", "soldier/Soldier.glb", 2500, False),
    BenchAsset("fox", "fox/Fox.glb", 300, False),
)


def run(repeats: int | None = None, out: str | Path | None = None, time_budget: float = TIME_BUDGET_S,
        assets: tuple[BenchAsset, ...] = ASSETS, assets_dir: str | Path = SHARED_ASSETS, reuse: bool = False,
        judge: str | None = None) -> dict:
    """Simplify every character twice (module docstring) and score both on the animated run's
    held-out views.

    Args:
        repeats: ignored (each run takes minutes).
        out: keep the runs in ``out/<asset>`` (the bind-pose fit in its ``bind-pose-fit/``;
            default: ``$LOOKALIKE_BENCH_OUT`` or a temporary folder removed afterwards).
        time_budget: seconds per run (the default run's 600).
        assets: which cases; assets_dir: where their files are.
        reuse: take the runs already in ``out`` (those with a ``metrics.json``) instead of
            running them again.
        judge: ``"blender"``: also judge every run in Cycles (module docstring; needs the
            ``judge`` extra).

    Returns:
        ``{"time_budget_s", "bar", "runs": [row, ...], "all_meet_bar", "outputs"}``; a row holds
        the asset, triangle counts, the minutes of both runs, iterations, PSNR and FLIP of
        plain decimation, the bind-pose fit and ours, the gains of ours and whether it meets
        the bar; judged rows also hold ``"judge"``: ``{renderer: {method: {"psnr", "flip"}}}``.
    """
    assets_dir = check_assets_dir(assets_dir)
    if judge is not None:
        check_judge(judge)
    with tempfile.TemporaryDirectory(prefix="lookalike-bench-") as scratch:
        root = output_root(out, scratch)
        rows = [_case(case, assets_dir, root, time_budget, reuse, judge is not None) for case in assets]
        return {
            "time_budget_s": time_budget,
            "bar": {"minutes": BAR_MINUTES, "gain_over_decimated_db": BAR_GAIN_OVER_DECIMATED_DB,
                    "gain_over_bind_pose_db": BAR_GAIN_OVER_BIND_POSE_DB},
            "runs": rows,
            "all_meet_bar": all(r["meets_bar"] for r in rows),
            "outputs": None if root == Path(scratch) else str(root.resolve()),
        }


def _case(case: BenchAsset, assets_dir: Path, root: Path, time_budget: float, reuse: bool, judged: bool) -> dict:
    """``simplify --compare-static`` of one character (both runs, the bind-pose fit scored
    beside ours), judged in Cycles where ``judged``, and its table row."""
    from ..jobs.judge import judge_run, mean_scores, reference_of_run
    from ..jobs.bind_pose import BIND_POSE_FOLDER, BIND_POSE_STAGE
    from ..jobs.simplify import simplify

    run_dir = root / case.name
    baselines = None
    if reuse and (run_dir / "metrics.json").is_file():
        metrics = json.loads((run_dir / "metrics.json").read_text())
    else:
        result = simplify(assets_dir / case.path, run_dir, triangles=case.triangles, time_budget=time_budget,
                          compare_static=True, force=True, progress=False)
        metrics, baselines = result.metrics, result.baselines
    static = json.loads((run_dir / BIND_POSE_FOLDER / "metrics.json").read_text())
    heldout, seconds = metrics["heldout"], metrics["seconds"]
    row = {
        "asset": case.name,
        "input_triangles": metrics["triangles"]["input"],
        "triangles": metrics["triangles"]["output"],
        "minutes": (seconds["total"] - seconds[BIND_POSE_STAGE]) / 60,
        "minutes_bind_pose": static["seconds"]["total"] / 60,
        "iterations": metrics["iterations"],
        "seconds_per_iteration": seconds["per_iteration"],
        **{f"{metric}_{key}": heldout[key][metric] for key in ("decimated", "baked", "bind_pose", "ours")
           for metric in ("psnr", "flip")},
    }
    row["gain_over_decimated_db"] = row["psnr_ours"] - row["psnr_decimated"]
    row["gain_over_bind_pose_db"] = row["psnr_ours"] - row["psnr_bind_pose"]
    row["meets_bar"] = (max(row["minutes"], row["minutes_bind_pose"]) <= BAR_MINUTES
                        and row["gain_over_decimated_db"] >= BAR_GAIN_OVER_DECIMATED_DB
                        and row["gain_over_bind_pose_db"] >= BAR_GAIN_OVER_BIND_POSE_DB
                        and row["flip_ours"] < min(row["flip_decimated"], row["flip_bind_pose"]))
    if judged:
        reference = reference_of_run(run_dir, input_path=assets_dir / case.path)
        row["judge"] = mean_scores(judge_run(run_dir, reference, baselines))
    return row


COLUMNS = (
    ("asset", "asset", "{}"), ("triangles", "triangles", "{:,}"), ("minutes", "minutes", "{:.1f}"),
    ("min. bind-pose", "minutes_bind_pose", "{:.1f}"), ("iters", "iterations", "{:,}"),
    ("PSNR dec", "psnr_decimated", "{:.2f}"), ("PSNR bake", "psnr_baked", "{:.2f}"),
    ("PSNR bind-pose", "psnr_bind_pose", "{:.2f}"), ("PSNR ours", "psnr_ours", "{:.2f}"),
    ("ours-dec dB", "gain_over_decimated_db", "{:+.2f}"), ("ours-bind dB", "gain_over_bind_pose_db", "{:+.2f}"),
    ("FLIP dec", "flip_decimated", "{:.4f}"), ("FLIP bake", "flip_baked", "{:.4f}"),
    ("FLIP bind-pose", "flip_bind_pose", "{:.4f}"), ("FLIP ours", "flip_ours", "{:.4f}"),
)


def format_table(result: dict) -> str:
    """The runs as an aligned text table, with the bar underneath."""
    bar = result["bar"]
    return runs_table(result, COLUMNS, f"bar: each run <= {bar['minutes']:g} min; ours >= plain decimation + "
                      f"{bar['gain_over_decimated_db']:g} dB and >= the bind-pose fit + {bar['gain_over_bind_pose_db']:g} "
                      "dB, with lower FLIP than both", judge_table)


JUDGED = (("dec", "decimated"), ("bake", "baked"), ("bind-pose", "bind_pose"), ("ours", "ours"))
"""(column name, method key) of the judged methods, in table order."""


def judge_table(rows: list[dict]) -> list[str]:
    """Lines of the judge's table: per asset, one row per renderer (Cycles with and without
    shadows, ours) with PSNR and FLIP of each method and the gains of ours."""
    return judged_table(rows, "asset", JUDGED, "ours", (("ours-dec dB", "decimated"), ("ours-bind dB", "bind_pose")),
                        "judge: Blender Cycles (32 samples, direct light, each model posed by Blender's glTF importer) "
                        "and our renderer on the held-out views; PSNR over the pixels either picture covers, FLIP over "
                        "the whole picture")
