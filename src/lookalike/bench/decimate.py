"""``lookalike bench decimate``: how far the start strays from the input, per simplifier.

Every benchmark asset at the triangle counts the benchmarks use (``quality``, ``lod``), and the
generated cases of ``_decimate_cases`` at 15 % and 5 % of their triangles, are decimated by:

- ``chosen``: ``lookalike.init.decimate.decimate_reported``, the setting that strays least;
- ``old``: fast-simplification's settings in ``SCHEDULE`` order, the first that reaches the
  count (the first decimation's choice, ``_decimate_methods.old_schedule``);
- ``meshoptimizer``: meshoptimizer's ``meshopt_simplify`` alone;
- ``blender``: with ``--judge blender``, Blender's Decimate modifier alone
  (``_decimate_methods.blender_decimate``: the judge's worker,
  ``lookalike.blender.decimate_bake_worker``, stopped after its decimation).

Each is measured by the same sampled two-sided surface distance
(``lookalike.init.surface_distance``, ``SAMPLES`` points each way, seeded) from the welded input:
the share of the area farther than 3 % of the bounding radius (``far_area``), the mean and the
99th percentile, in bounding radii, and the seconds it took (Blender's: its decimation alone,
not its start).

Bar, per asset and count: the chosen far area at most ``max(BAR_BLENDER x Blender's,
BAR_FAR)`` (``BAR_FAR`` alone without the judge), and the chosen never further from the input
than the old choice (``no_further``: its far area, then its 99th
percentile, no larger). The methods live in ``_decimate_methods``, so that the command line
loads this module's cases without the numerical stack.

``noisy-sphere-4m`` (not run unless named with ``--asset``) is a generated scan of 4 million
triangles: the cost of the coarse pass and of measuring at that size.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path

from ..errors import ConfigError
from ._table import aligned_table
from .quality import SHARED_ASSETS

HELP = "decimate every benchmark asset and generated case; how far each simplifier's result strays from the input"

BAR_FAR = 0.005
"""The chosen far area at most this share of the area, or ``BAR_BLENDER`` times Blender's."""
BAR_BLENDER = 1.5
METHODS = ("chosen", "old", "meshoptimizer", "blender")
_P99_ROUNDING = 1e-3                       # relative change of a 99th percentile that float32 positions may make


@dataclass(frozen=True)
class DecimateCase:
    """One input: ``path`` under the assets folder, or ``generator`` (a function of
    ``_decimate_cases``) with its keywords; ``counts``: triangle counts, or shares of the
    input's triangles where below 1."""

    name: str
    counts: tuple[float, ...]
    path: str | None = None
    generator: str | None = None
    keywords: tuple[tuple[str, object], ...] = ()


ASSETS = (
    DecimateCase("stanford-bunny", (1500,), path="stanford-bunny/stanford-bunny.obj"),
    DecimateCase("nefertiti", (8000, 2000, 500), path="nefertiti/nefertiti.obj"),
    DecimateCase("flight-helmet", (8000, 5000, 2000, 500), path="flight-helmet/FlightHelmet.gltf"),
    DecimateCase("spot", (1000,), path="spot/spot.obj"),
    DecimateCase("hard-surface-kit", (0.15, 0.05), generator="hard_surface_kit"),
    DecimateCase("thin-shells", (0.15, 0.05), generator="thin_shells"),
    DecimateCase("noisy-scan", (0.15, 0.05), generator="noisy_sphere"),
    DecimateCase("character", (0.15, 0.05), generator="character"),
    DecimateCase("noisy-sphere-4m", (2000,), generator="noisy_sphere", keywords=(("triangles", 4_000_000),)),
)
DEFAULT = tuple(case for case in ASSETS if case.name != "noisy-sphere-4m")


def no_further(chosen: dict, old: dict, samples: int) -> bool:
    """Whether ``chosen`` strays no further than ``old`` (each ``{"far_area", "p99", ...}``): a
    far area smaller by more than one sample, or the same within one sample and a 99th
    percentile at most 0.1 % larger (the written mesh's float32 positions move it that much);
    ``samples``: the points each far area was counted on."""
    step = 1.0 / samples
    if chosen["far_area"] < old["far_area"] - step:
        return True
    return chosen["far_area"] <= old["far_area"] + step and chosen["p99"] <= old["p99"] * (1 + _P99_ROUNDING)


def bar_row(row: dict) -> dict:
    """``row`` (``_decimate_methods.bench_case``) with its bar: the far area allowed
    (``bar_far_area``), whether the chosen strays no further than the old choice, and whether
    it meets both (``meets_bar``)."""
    methods = row["methods"]
    chosen = methods["chosen"]
    bar = max(BAR_BLENDER * methods["blender"]["far_area"], BAR_FAR) if "blender" in methods else BAR_FAR
    not_further = no_further(chosen, methods["old"], row["samples"])
    return {**row, "bar_far_area": bar, "not_further_than_old": not_further,
            "meets_bar": chosen["far_area"] <= bar and not_further}


def run(repeats: int | None = None, out: str | Path | None = None, assets: tuple[DecimateCase, ...] = DEFAULT,
        assets_dir: str | Path = SHARED_ASSETS, judge: str | None = None) -> dict:
    """Every case of ``assets`` at each of its counts (module docstring); ``repeats`` is ignored.
    ``out``: write every method's mesh there as ``ASSET-COUNT-METHOD.glb``. ``judge``:
    ``"blender"`` adds Blender's Decimate (needs the ``judge`` extra).

    Returns:
        ``{"runs": [row, ...], "all_meet_bar", "bar_far_area", "bar_blender", "judged"}``; a
        row holds the asset, its input and welded triangles, the target, per method its setting,
        triangles, far area, mean, 99th percentile and seconds, the bar's far area and whether
        the row meets it.
    """
    from ._decimate_methods import bench_case, load_case

    if judge not in (None, "blender"):
        raise ConfigError(f"--judge {judge}: bench decimate is judged by blender only")
    out = None if out is None else Path(out)
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory(prefix="lookalike-bench-decimate-") as scratch:
        for case in assets:
            asset = load_case(case, Path(assets_dir))
            rows += [bar_row(bench_case(case, asset, count, judge, Path(scratch), out)) for count in case.counts]
    return {"runs": rows, "all_meet_bar": all(r["meets_bar"] for r in rows), "bar_far_area": BAR_FAR,
            "bar_blender": BAR_BLENDER, "judged": judge == "blender"}


def format_table(result: dict) -> str:
    """The rows as text, one line per asset, count and method: triangles, far area, mean and 99th
    percentile (in % of the bounding radius), seconds and setting; the bar on each chosen line."""
    header = ["asset", "target", "method", "triangles", "far %", "mean %", "p99 %", "seconds", "setting", "bar"]
    cells = []
    for r in result["runs"]:
        for method in (m for m in METHODS if m in r["methods"]):
            f = r["methods"][method]
            first = method == "chosen"
            cells.append([r["asset"] if first else "", f"{r['target']:,}" if first else "", method,
                          f"{f['triangles']:,}", f"{100 * f['far_area']:.2f}", f"{100 * f['mean']:.3f}",
                          f"{100 * f['p99']:.2f}", f"{f['seconds']:.3f}", f["setting"],
                          ("ok" if r["meets_bar"] else "MISSED") if first else ""])
    lines = aligned_table(header, cells)
    limit = (f"max({result['bar_blender']:g} x Blender's, {100 * result['bar_far_area']:g} %)" if result["judged"]
             else f"{100 * result['bar_far_area']:g} % (without --judge blender)")
    lines.append(f"bar: the chosen far area (share of the area farther than 3 % of the bounding radius) at most "
                 f"{limit}, and never further than the old choice: {'met' if result['all_meet_bar'] else 'NOT met'}")
    return "\n".join(lines)
