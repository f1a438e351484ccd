"""``lookalike bench quality``: ``simplify`` with default settings on the four benchmark assets
of ``../shared/assets``, scored on held-out views.

Bar: every run within 10 minutes on a 2-core machine, ours at least 3 dB PSNR above plain
decimation on every asset and, where the classic bake was scored, at least 1 dB above the bake
with a lower FLIP.

``--judge blender`` also judges every run in Blender (``lookalike.jobs.judge``):
the input, plain decimation, our classic bake, Blender's own decimate + bake and ours, rendered
on the run's held-out views by our renderer and by Cycles with and without shadows, PSNR over
the pixels either picture covers and FLIP. Its bar: in Cycles with shadows ours at least 1 dB
above Blender's bake with a lower FLIP, and in our renderer at least 1 dB above our bake.
``--reuse`` judges the runs already in ``--out`` instead of simplifying again (a missing run is
simplified).
"""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

from ..errors import ConfigError
from ._table import aligned_table

HELP = "simplify the four benchmark assets and compare held-out PSNR/FLIP with plain decimation"

SHARED_ASSETS = Path(__file__).resolve().parents[3].parent / "shared" / "assets"
OUT_ENVIRONMENT = "LOOKALIKE_BENCH_OUT"      # keep the outputs here when no ``out`` is given
TIME_BUDGET_S = 600.0
BAR_MINUTES = 10.0
BAR_GAIN_DB = 3.0
BAR_GAIN_OVER_BAKED_DB = 1.0
JUDGES = ("blender", "three")
"""The independent judges: Blender Cycles (``lookalike.blender``), three.js (``lookalike.webgl``)."""
BAR_JUDGE_GAIN_DB = 1.0                     # ours over Blender's bake (Cycles, shadows) and over our bake (ours)
SCAN_COLOUR = (0.75, 0.72, 0.68)            # base colour, metallic 0, roughness 0.45 for untextured scans
SCAN_ROUGHNESS = 0.45


@dataclass(frozen=True)
class BenchAsset:
    """One benchmark case: ``path`` under the assets folder, the triangle budget, and whether
    it is an untextured scan that gets the scan material."""

    name: str
    path: str
    triangles: int
    scan: bool


ASSETS = (
    BenchAsset("stanford-bunny", "stanford-bunny/stanford-bunny.obj", 1500, True),
    BenchAsset("nefertiti", "nefertiti/nefertiti.obj", 2000, True),
    BenchAsset("flight-helmet", "flight-helmet/FlightHelmet.gltf", 5000, False),
    BenchAsset("spot", "spot/spot.obj", 1000, False),
)


def select_assets(names: list[str], cases: tuple[BenchAsset, ...] = ASSETS) -> tuple[BenchAsset, ...]:
    """The ``cases`` named in ``names``, in ``cases`` order; an unknown name is a
    ``ConfigError`` listing the known ones."""
    known = {case.name for case in cases}
    unknown = [name for name in names if name not in known]
    if unknown:
        raise ConfigError(f"unknown benchmark asset {', '.join(unknown)}; the assets are {', '.join(sorted(known))}")
    return tuple(case for case in cases if case.name in names)


def scan_material():
    """The material the benchmark prescribes for untextured scans."""
    from ..asset import Material, Texture

    return Material(name="scan", kd=Texture.constant([*SCAN_COLOUR, 1.0]),
                    ks=Texture.constant([0.0, SCAN_ROUGHNESS, 0.0]))


def table_row(case: BenchAsset, metrics: dict) -> dict:
    """One table row from a run's ``metrics.json`` content."""
    heldout = metrics["heldout"]
    methods = [k for k in ("decimated", "baked", "ours") if k in heldout]
    row = {
        "asset": case.name,
        "input_triangles": metrics["triangles"]["input"],
        "triangles": metrics["triangles"]["output"],
        "minutes": metrics["seconds"]["total"] / 60,
        "seconds_per_iteration": metrics["seconds"]["per_iteration"],
        "iterations": metrics["iterations"],
        "device": metrics.get("device", "cpu"),
        **{f"psnr_{k}": heldout[k]["psnr"] for k in methods},
        **{f"flip_{k}": heldout[k]["flip"] for k in methods},
    }
    if heldout["ours"].get("silhouette_error") is not None:
        row["silhouette_error_ours"] = heldout["ours"]["silhouette_error"]
    row["gain_db"] = row["psnr_ours"] - row["psnr_decimated"]
    row["meets_bar"] = row["minutes"] <= BAR_MINUTES and row["gain_db"] >= BAR_GAIN_DB
    if "psnr_baked" in row:
        row["gain_over_baked_db"] = row["psnr_ours"] - row["psnr_baked"]
        row["meets_bar"] &= row["gain_over_baked_db"] >= BAR_GAIN_OVER_BAKED_DB and row["flip_ours"] < row["flip_baked"]
    return row


def check_assets_dir(assets_dir: str | Path) -> Path:
    """``assets_dir`` as a path; ``ConfigError`` if it is not a folder."""
    assets_dir = Path(assets_dir)
    if not assets_dir.is_dir():
        raise ConfigError(f"the benchmark assets are missing: no folder {assets_dir} (point --assets-dir at them)")
    return assets_dir


def simplify_case(case: BenchAsset, assets_dir: Path, outdir: Path, time_budget: float, init: str | None = None,
                  iterations: int | None = None, init_mesh: Path | None = None, device: str | None = None):
    """``simplify`` of one benchmark case with default settings (and ``init``, a fixed
    ``iterations`` count instead of the time budget, a starting mesh ``init_mesh`` and the
    ``render.device`` ``device`` where given) into ``outdir``; returns its ``RunResult``."""
    from ..jobs.simplify import simplify

    return simplify(assets_dir / case.path, outdir, triangles=case.triangles, time_budget=time_budget, init=init,
                    iterations=iterations, init_mesh=init_mesh, device=device, force=True, progress=False,
                    material_override=scan_material() if case.scan else None)


def output_root(out: str | Path | None, scratch: str) -> Path:
    """Where runs keep their outputs: ``out``, else ``$LOOKALIKE_BENCH_OUT``, else ``scratch``."""
    out = out if out is not None else os.environ.get(OUT_ENVIRONMENT)
    return Path(out) if out else Path(scratch)


def run(repeats: int | None = None, out: str | Path | None = None, time_budget: float = TIME_BUDGET_S,
        assets: tuple[BenchAsset, ...] = ASSETS, assets_dir: str | Path = SHARED_ASSETS, judge: str | None = None,
        reuse: bool = False, device: str | None = None) -> dict:
    """Simplify every benchmark asset once and collect its held-out scores.

    Args:
        repeats: ignored (each asset runs once; a run takes minutes).
        out: keep each run's outputs in ``out/<asset>`` (default: ``$LOOKALIKE_BENCH_OUT`` or a
            temporary folder removed afterwards).
        time_budget: seconds per run (the benchmark's default, 600).
        assets: which cases to run; assets_dir: where their files are.
        judge: ``"blender"``: also judge every run in Blender (module docstring; needs the
            ``judge`` extra).
        reuse: take the runs already in ``out/<asset>`` (those with a ``metrics.json``) instead
            of simplifying again; needs ``out``.
        device: the runs' ``render.device`` (``None``: the default, ``"auto"``).

    Returns:
        ``{"time_budget_s", "bar": {...}, "runs": [row, ...], "all_meet_bar"}``; a row holds the
        asset, triangle counts, minutes, seconds per iteration, iterations, PSNR and FLIP of each
        method, the gain of ours in dB, and whether it meets the bar; judged rows also hold
        ``"judge"`` (``judged_row``, with its own ``"meets_bar"``). ``all_meet_bar``: every row
        meets both bars.
    """
    assets_dir = check_assets_dir(assets_dir)
    if judge is not None:
        check_judge(judge)
    if reuse and out is None and not os.environ.get(OUT_ENVIRONMENT):
        raise ConfigError("--reuse judges earlier runs: name their folder with --out (or $LOOKALIKE_BENCH_OUT)")
    with tempfile.TemporaryDirectory(prefix="lookalike-bench-") as scratch:
        root = output_root(out, scratch)
        rows = case_rows(assets, assets_dir, root, time_budget, reuse, table_row,
                         judged_row if judge is not None else None, device)
        return summary(rows, time_budget, None if root == Path(scratch) else root, judged=judge is not None)


def case_rows(assets: tuple[BenchAsset, ...], assets_dir: Path, root: Path, time_budget: float, reuse: bool,
              row_of, judge_of=None, device: str | None = None) -> list[dict]:
    """One row per case: its run in ``root/<name>`` (the one already there where ``reuse`` and
    it has a ``metrics.json``, else ``simplify_case`` on ``device``), ``row_of(case, metrics)``, and where
    ``judge_of`` is given its ``"judge"``, ``judge_of(case, assets_dir, run_dir, baselines)``
    (``baselines`` the run's, ``None`` for a reused run)."""
    rows = []
    for case in assets:
        run_dir = root / case.name
        if reuse and (run_dir / "metrics.json").is_file():
            metrics, baselines = json.loads((run_dir / "metrics.json").read_text()), None
        else:
            result = simplify_case(case, assets_dir, run_dir, time_budget, device=device)
            stop_if_interrupted(result)
            metrics, baselines = result.metrics, getattr(result, "baselines", None)
        row = row_of(case, metrics)
        if judge_of is not None:
            row["judge"] = judge_of(case, assets_dir, run_dir, baselines)
        rows.append(row)
    return rows


def stop_if_interrupted(result) -> None:
    """``KeyboardInterrupt`` where a run was stopped (Ctrl-C, or a scheduler's SIGTERM): the
    benchmark stops with it instead of going on to the next run."""
    if getattr(result, "interrupted", False):
        raise KeyboardInterrupt


def check_judge(judge: str, accepted: tuple[str, ...] = ("blender",)) -> None:
    """``ConfigError`` unless ``judge`` is one of the ``accepted`` judges of a benchmark and is
    installed."""
    if judge not in accepted:
        raise ConfigError(f"this benchmark's judges are {', '.join(accepted)}, not {judge!r}")
    if judge == "three":
        from ..webgl import require_threejs

        require_threejs()
    else:
        from ..blender import require_judge

        require_judge()


def judged_row(case: BenchAsset, assets_dir: Path, run_dir: Path, baselines: dict | None) -> dict:
    """Judge the run of ``case`` in ``run_dir`` in Blender (``lookalike.jobs.judge.judge_run``,
    which writes ``run_dir/judge/``); its result plus the gains of ours over Blender's bake (the
    one its user keeps, ``jobs.judge.blender_baseline``; Cycles, shadows) and over our bake (our
    renderer), in dB, and whether they meet the bar."""
    from ..jobs.judge import held_against, judge_run
    from ..jobs.input_asset import prepare_input

    loaded = io_load(assets_dir / case.path)
    reference, _ = prepare_input(loaded, scan_material() if case.scan else None)
    judged = judge_run(run_dir, reference, baselines)
    cycles, ours = held_against(judged, judged["scores"]["cycles"]), judged["scores"]["ours"]
    judged["gain_over_blender_db"] = cycles["ours"]["psnr"] - cycles["blender"]["psnr"]
    judged["gain_over_baked_db"] = ours["ours"]["psnr"] - ours["baked"]["psnr"] if "baked" in ours else None
    judged["meets_bar"] = (judged["gain_over_blender_db"] >= BAR_JUDGE_GAIN_DB
                           and cycles["ours"]["flip"] < cycles["blender"]["flip"]
                           and (judged["gain_over_baked_db"] is None or judged["gain_over_baked_db"] >= BAR_JUDGE_GAIN_DB))
    return judged


def io_load(path: Path):
    """``lookalike.io.load`` (imported when first needed: the bench's plumbing stays light)."""
    from .. import io

    return io.load(path)


def summary(rows: list[dict], time_budget: float, outputs: Path | None, judged: bool = False) -> dict:
    """The result of a quality run from its ``rows`` (see ``run``)."""
    bar = {"minutes": BAR_MINUTES, "gain_db": BAR_GAIN_DB, "gain_over_baked_db": BAR_GAIN_OVER_BAKED_DB}
    if judged:
        bar["judge_gain_db"] = BAR_JUDGE_GAIN_DB
    return {
        "time_budget_s": time_budget,
        "bar": bar,
        "runs": rows,
        "all_meet_bar": all(r["meets_bar"] and r.get("judge", {}).get("meets_bar", True) for r in rows),
        "outputs": str(outputs.resolve()) if outputs else None,
    }


def _columns(baked: bool) -> list[tuple[str, str, str]]:
    """``(header, row key, format)`` of each table column; the baked ones only where a bake ran."""
    columns = [
        ("asset", "asset", "{}"), ("triangles", "triangles", "{:,}"), ("minutes", "minutes", "{:.1f}"),
        ("s/iter", "seconds_per_iteration", "{:.2f}"), ("iters", "iterations", "{:,}"),
        ("PSNR dec", "psnr_decimated", "{:.2f}"), ("PSNR baked", "psnr_baked", "{:.2f}"),
        ("PSNR ours", "psnr_ours", "{:.2f}"), ("gain dB", "gain_db", "{:+.2f}"),
        ("vs baked dB", "gain_over_baked_db", "{:+.2f}"),
        ("FLIP dec", "flip_decimated", "{:.4f}"), ("FLIP baked", "flip_baked", "{:.4f}"),
        ("FLIP ours", "flip_ours", "{:.4f}"), ("ours: error near outline", "silhouette_error_ours", "{:.0%}"),
    ]
    return [c for c in columns if baked or "baked" not in c[1]]


def format_table(result: dict) -> str:
    """The runs as an aligned text table, with the bar underneath."""
    rows = result["runs"]
    columns = _columns(any("psnr_baked" in r for r in rows))
    header = [name for name, _, _ in columns] + ["bar"]
    cells = [[fmt.format(r[key]) if key in r else "-" for _, key, fmt in columns] + ["ok" if r["meets_bar"] else "MISSED"]
             for r in rows]
    lines = aligned_table(header, cells)
    bar = result["bar"]
    over_baked = (f", >= {bar['gain_over_baked_db']:g} dB above the classic bake with lower FLIP"
                  if "gain_over_baked_db" in bar and any("psnr_baked" in r for r in rows) else "")
    runs_met = all(r["meets_bar"] for r in rows)
    lines.append(f"bar: each run <= {bar['minutes']:g} min, ours >= {bar['gain_db']:g} dB above plain decimation"
                 f"{over_baked}: {'met' if runs_met else 'NOT met'} "
                 f"(time budget {result['time_budget_s']:g} s per run)")
    if result.get("outputs"):
        lines.append(f"outputs: {result['outputs']}")
    if any("judge" in r for r in rows):
        lines += [""] + judge_table(result)
    return "\n".join(lines)


JUDGED_METHODS = (("dec", "decimated"), ("bake", "baked"), ("Blender", "blender"), ("ours", "ours"))
"""(column name, method key) of the judged methods, in table order; ``"blender"`` stands for the
model of Blender's pipeline its user keeps (``jobs.judge.blender_baseline``)."""


def judge_table(result: dict) -> list[str]:
    """Lines of the judge's table: per asset, one row per renderer (ours; Cycles with and without
    shadows) with PSNR and FLIP of each method and the gains of ours, then the bar."""
    from ..jobs.judge import held_against
    from ..jobs.judge_scores import RENDERERS

    rows = [r for r in result["runs"] if "judge" in r]
    header = (["asset", "renderer"] + [f"PSNR {name}" for name, _ in JUDGED_METHODS]
              + ["ours-Blender dB", "ours-bake dB"] + [f"FLIP {name}" for name, _ in JUDGED_METHODS] + ["bar"])
    cells = []
    for row in rows:
        judged = row["judge"]
        for i, (renderer, label) in enumerate(RENDERERS.items()):
            scores = held_against(judged, judged["scores"][renderer])

            def figure(key: str, metric: str, fmt: str) -> str:
                return fmt.format(scores[key][metric]) if key in scores else "-"

            def gain(key: str) -> str:
                return f"{scores['ours']['psnr'] - scores[key]['psnr']:+.2f}" if key in scores else "-"

            bar = ("ok" if judged["meets_bar"] else "MISSED") if i == 0 else ""
            cells.append([row["asset"] if i == 0 else "", label]
                         + [figure(key, "psnr", "{:.2f}") for _, key in JUDGED_METHODS] + [gain("blender"), gain("baked")]
                         + [figure(key, "flip", "{:.4f}") for _, key in JUDGED_METHODS] + [bar])
    lines = [f"judge: Blender Cycles (32 samples, direct light) and our renderer, {rows[0]['judge']['views']} held-out "
             f"views at {rows[0]['judge']['resolution']} px; PSNR over the pixels either picture covers, FLIP over "
             "the whole picture"] + aligned_table(header, cells)
    gain = result["bar"].get("judge_gain_db", BAR_JUDGE_GAIN_DB)
    met = all(r["judge"]["meets_bar"] for r in rows)
    lines.append(f"judge bar: in Cycles with shadows ours >= Blender's decimate + bake + {gain:g} dB with lower FLIP, "
                 f"and in our renderer ours >= our bake + {gain:g} dB: {'met' if met else 'NOT met'}")
    for row in rows:
        agreement = row["judge"].get("agreement")
        if agreement:
            figures = ", ".join(f"{name} {agreement[key]['psnr']:.1f}" for name, key in (("input", "reference"),)
                                + JUDGED_METHODS if key in agreement)
            lines.append(f"{row['asset']}: our renderer vs Cycles without shadows on the same file, PSNR dB: {figures}")
    for row in rows:
        noise = row["judge"].get("map_noise")
        if noise:
            figures = ", ".join(f"{name} {' / '.join(f'{v:.4f}' for v in noise[key].values())}"
                                for name, key in JUDGED_METHODS if key in noise)
            lines.append(f"{row['asset']}: map noise (base colour / specular / normal, as written): {figures}")
    timings = ", ".join(f"{r['asset']} {blender_seconds(r['judge']['blender_bake']):.0f} s" for r in rows)
    per_view = sum(r["judge"]["seconds"]["cycles_per_view"] for r in rows) / len(rows)
    lines.append(f"Blender's decimate + bake: {timings}; Cycles {per_view:.2f} s per view")
    return lines + [blender_kept(rows)]


def blender_seconds(bake: dict) -> float:
    """Seconds Blender's pipeline took in a judging (``judge.json``'s ``"blender_bake"``): every
    shading's run."""
    return bake["seconds"]["total"] + bake.get("by_angle", {}).get("seconds", {}).get("total", 0.0)


def blender_kept(rows: list[dict]) -> str:
    """A line naming, for each judged row, the model of Blender's pipeline held against ours
    (``jobs.judge.blender_baseline``: the better in Cycles with shadows)."""
    from ..jobs.judge import LABELS, blender_baseline

    kept = ", ".join(f"{r['asset']}: {LABELS[blender_baseline(r['judge'])]}" for r in rows if "judge" in r)
    return f"Blender's model held against ours (the better in Cycles with shadows): {kept}"
