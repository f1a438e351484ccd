"""``lookalike bench warmstart``: how many iterations does starting from the classic bake save?

Every benchmark asset of ``bench quality`` is simplified three times with default settings:

- ``random``: textures from noise (``init="random"``, the paper's start), time budget;
- ``bake``: from the classic bake (the default), the same time budget;
- ``bake-half``: from the bake, with a fixed iteration count of half the random start's steps.

All runs score their states on the same validation views every ``optim.validate_every`` steps
(``metrics.json``, ``validation``).

Bar (the goal: "starting from the bake reaches the result of a random start in at most half the
iterations"): the ``bake-half`` run ends at least as good as the random start, both in best
validation PSNR and in held-out PSNR. A run of half the steps is what a user with half the
budget gets: the learning-rate and Laplacian schedules stretch over whatever length a run has
(``lookalike.fit.schedule``), so the state half-way through a longer run is not that result.

The table also keeps the in-run figure: the first scored iteration at which the full-length
``bake`` run reaches the random start's best validation PSNR, as a fraction of the random
start's steps.

The ``bake`` runs are the default ``simplify`` runs, so their rows of the ``bench quality``
table come with the result.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from ._table import aligned_table

from .quality import (ASSETS, SHARED_ASSETS, TIME_BUDGET_S, BenchAsset, table_row, check_assets_dir, output_root,
                      simplify_case, summary)
from .quality import format_table as format_quality_table

HELP = ("simplify the benchmark assets from a random start, from the bake, and from the bake in half the "
        "random start's steps: does the bake start get there in half the iterations?")

BAR_FRACTION = 0.5
STARTS = ("random", "bake")
HALF_RUN = "bake-half"


def iterations_to_reach(curve: dict, score: float) -> int | None:
    """The first scored iteration of ``curve`` (``{"iterations": [K], "psnr": [K]}``) whose
    PSNR is at least ``score``; ``None`` if none is."""
    return next((i for i, value in zip(curve["iterations"], curve["psnr"]) if value >= score), None)


def half_iterations(random: dict) -> int:
    """Steps of the ``bake-half`` run: ``BAR_FRACTION`` of the random start's, at least one."""
    return max(1, int(random["iterations"] * BAR_FRACTION))


def _row_of(case: BenchAsset, random: dict, bake: dict, half: dict) -> dict:
    """One table row from the ``metrics.json`` contents of the three runs of ``case``."""
    goal = max(random["validation"]["psnr"])
    reached = iterations_to_reach(bake["validation"], goal)
    fraction = None if reached is None else reached / max(random["iterations"], 1)
    half_best = max(half["validation"]["psnr"])
    return {
        "asset": case.name,
        "iterations_random": random["iterations"],
        "iterations_bake": bake["iterations"],
        "iterations_half": half["iterations"],
        "validation_psnr_random_best": goal,
        "validation_psnr_bake_start": bake["validation"]["psnr"][0],
        "validation_psnr_bake_best": max(bake["validation"]["psnr"]),
        "validation_psnr_half_best": half_best,
        "bake_reaches_random_at": reached,
        "fraction": fraction,
        "psnr_random": random["heldout"]["ours"]["psnr"],
        "psnr_bake": bake["heldout"]["ours"]["psnr"],
        "psnr_half": half["heldout"]["ours"]["psnr"],
        "flip_random": random["heldout"]["ours"]["flip"],
        "flip_bake": bake["heldout"]["ours"]["flip"],
        "flip_half": half["heldout"]["ours"]["flip"],
        "meets_bar": half_best >= goal and half["heldout"]["ours"]["psnr"] >= random["heldout"]["ours"]["psnr"],
    }


def run(repeats: int | None = None, out: str | Path | None = None, time_budget: float = TIME_BUDGET_S,
        assets: tuple[BenchAsset, ...] = ASSETS, assets_dir: str | Path = SHARED_ASSETS) -> dict:
    """Simplify every benchmark asset from both starts, and from the bake in half the random
    start's steps, and compare the results.

    Args:
        repeats: ignored (each run takes minutes).
        out: keep the runs' outputs in ``out/<asset>-<start>`` (default: ``$LOOKALIKE_BENCH_OUT``
            or a temporary folder removed afterwards).
        time_budget: seconds per run (600, as in ``bench quality``).
        assets: which cases to run; assets_dir: where their files are.

    Returns:
        ``{"time_budget_s", "bar_fraction", "runs": [row, ...], "all_meet_bar", "quality": {...}}``;
        a row holds the three runs' iterations, validation and held-out scores, the iteration
        at which the full-length bake start reached the random start's best validation PSNR
        and its fraction of the random start's iterations, and whether the half-length bake
        start meets the bar; ``quality`` is the ``bench quality`` result of the full-length
        bake-start runs.
    """
    assets_dir = check_assets_dir(assets_dir)
    with tempfile.TemporaryDirectory(prefix="lookalike-bench-") as scratch:
        root = output_root(out, scratch)
        rows, quality_rows = [], []
        for case in assets:
            metrics = {start: simplify_case(case, assets_dir, root / f"{case.name}-{start}", time_budget, init=start).metrics
                       for start in STARTS}
            half = simplify_case(case, assets_dir, root / f"{case.name}-{HALF_RUN}", time_budget, init="bake",
                                 iterations=half_iterations(metrics["random"])).metrics
            rows.append(_row_of(case, metrics["random"], metrics["bake"], half))
            quality_rows.append(table_row(case, metrics["bake"]))
        outputs = None if root == Path(scratch) else root
        return {
            "time_budget_s": time_budget,
            "bar_fraction": BAR_FRACTION,
            "runs": rows,
            "all_meet_bar": all(r["meets_bar"] for r in rows),
            "quality": summary(quality_rows, time_budget, outputs),
        }


COLUMNS = (
    ("asset", "asset", "{}"), ("iters random", "iterations_random", "{:,}"), ("iters bake", "iterations_bake", "{:,}"),
    ("val random best", "validation_psnr_random_best", "{:.2f}"), ("val bake start", "validation_psnr_bake_start", "{:.2f}"),
    ("val bake best", "validation_psnr_bake_best", "{:.2f}"), ("bake reaches it at", "bake_reaches_random_at", "{:,}"),
    ("fraction", "fraction", "{:.2f}"), ("iters half", "iterations_half", "{:,}"),
    ("val half best", "validation_psnr_half_best", "{:.2f}"), ("PSNR random", "psnr_random", "{:.2f}"),
    ("PSNR bake", "psnr_bake", "{:.2f}"), ("PSNR half", "psnr_half", "{:.2f}"),
    ("FLIP random", "flip_random", "{:.4f}"), ("FLIP bake", "flip_bake", "{:.4f}"), ("FLIP half", "flip_half", "{:.4f}"),
)


def format_table(result: dict) -> str:
    """The comparison as an aligned text table with its bar, then the quality table of the
    full-length bake-start runs."""
    header = [name for name, _, _ in COLUMNS] + ["bar"]
    cells = [[fmt.format(r[key]) if r.get(key) is not None else "never" for _, key, fmt in COLUMNS]
             + ["ok" if r["meets_bar"] else "MISSED"] for r in result["runs"]]
    lines = aligned_table(header, cells)
    lines.append(f"bar: the bake start given {result['bar_fraction']:g} of the random start's iterations (half) "
                 f"ends at least as good in best validation PSNR and in held-out PSNR: "
                 f"{'met' if result['all_meet_bar'] else 'NOT met'} (time budget {result['time_budget_s']:g} s per "
                 f"random and bake run; 'bake reaches it at': first scored step of the full-length bake run at the "
                 f"random start's best validation PSNR; PSNR and FLIP columns: held-out views)")
    return "\n".join(lines) + "\n\nfull-length bake-start runs (default settings):\n" + format_quality_table(result["quality"])
