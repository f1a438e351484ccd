"""``lookalike bench quality``: ``simplify`` with default settings on the four benchmark assets
of ``../shared/assets``, scored on held-out views.

Bar: every run within 10 minutes on a 2-core machine, ours at least 3 dB PSNR above plain
decimation on every asset (issue 4) and, where the classic bake was scored, at least 1 dB
above the bake with a lower FLIP (issue 5).
"""

from __future__ import annotations

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


def select_assets(names: list[str]) -> tuple[BenchAsset, ...]:
    """The cases of ``ASSETS`` named in ``names``, in ``ASSETS`` order; an unknown name is a
    ``ConfigError`` listing the known ones."""
    known = {case.name for case in ASSETS}
    unknown = [name for name in names if name not in known]
    if unknown:
        raise ConfigError(f"unknown benchmark asset {', '.join(unknown)}; the assets are {', '.join(sorted(known))}")
    return tuple(case for case in ASSETS if case.name in names)


def scan_material():
    """The material the issue prescribes for untextured scans."""
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
                  iterations: int | None = None, init_mesh: Path | None = None):
    """``simplify`` of one benchmark case with default settings (and ``init``, a fixed
    ``iterations`` count instead of the time budget, and a starting mesh ``init_mesh`` where
    given) into ``outdir``; returns its ``SimplifyResult``."""
    from ..jobs.simplify import simplify

    return simplify(assets_dir / case.path, outdir, triangles=case.triangles, time_budget=time_budget, init=init,
                    iterations=iterations, init_mesh=init_mesh, force=True, progress=False,
                    material_override=scan_material() if case.scan else None)


def output_root(out: str | Path | None, scratch: str) -> Path:
    """Where runs keep their outputs: ``out``, else ``$LOOKALIKE_BENCH_OUT``, else ``scratch``."""
    out = out if out is not None else os.environ.get(OUT_ENVIRONMENT)
    return Path(out) if out else Path(scratch)


def run(repeats: int | None = None, out: str | Path | None = None, time_budget: float = TIME_BUDGET_S,
        assets: tuple[BenchAsset, ...] = ASSETS, assets_dir: str | Path = SHARED_ASSETS) -> dict:
    """Simplify every benchmark asset once and collect its held-out scores.

    Args:
        repeats: ignored (each asset runs once; a run takes minutes).
        out: keep each run's outputs in ``out/<asset>`` (default: ``$LOOKALIKE_BENCH_OUT`` or a
            temporary folder removed afterwards).
        time_budget: seconds per run (the issue's default, 600).
        assets: which cases to run; assets_dir: where their files are.

    Returns:
        ``{"time_budget_s", "bar": {...}, "runs": [row, ...], "all_meet_bar"}``; a row holds the
        asset, triangle counts, minutes, seconds per iteration, iterations, PSNR and FLIP of each
        method, the gain of ours in dB, and whether it meets the bar.
    """
    assets_dir = check_assets_dir(assets_dir)
    with tempfile.TemporaryDirectory(prefix="lookalike-bench-") as scratch:
        root = output_root(out, scratch)
        rows = [table_row(case, simplify_case(case, assets_dir, root / case.name, time_budget).metrics) for case in assets]
        return summary(rows, time_budget, None if root == Path(scratch) else root)


def summary(rows: list[dict], time_budget: float, outputs: Path | None) -> dict:
    """The result of a quality run from its ``rows`` (see ``run``)."""
    return {
        "time_budget_s": time_budget,
        "bar": {"minutes": BAR_MINUTES, "gain_db": BAR_GAIN_DB, "gain_over_baked_db": BAR_GAIN_OVER_BAKED_DB},
        "runs": rows,
        "all_meet_bar": all(r["meets_bar"] for r in rows),
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
    lines.append(f"bar: each run <= {bar['minutes']:g} min, ours >= {bar['gain_db']:g} dB above plain decimation"
                 f"{over_baked}: {'met' if result['all_meet_bar'] else 'NOT met'} "
                 f"(time budget {result['time_budget_s']:g} s per run)")
    if result.get("outputs"):
        lines.append(f"outputs: {result['outputs']}")
    return "\n".join(lines)
