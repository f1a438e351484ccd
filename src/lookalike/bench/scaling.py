"""``lookalike bench scaling``: do start-up and a step's cost stay flat as the input grows?

For each size (``SIZES``: 100k, 1M and 4M triangles) the demo's bumpy, painted torus knot is
tessellated to that many triangles (``lookalike.jobs.demo.demo_asset``), written to a glb and
simplified to 2,000 triangles with a fixed step count, default settings otherwise, profiled
(``simplify --profile``), in a child process of its own (``_scaling_worker``), so that each
row's peak memory (the child's ``ru_maxrss``) is its own.

A row: the input's triangles; start-up seconds (every stage before the first step: loading,
decimation, unwrapping, the bake, the reference's views, scoring the baselines) with each
stage's and phase's wall seconds and CPU/wall; seconds per step; peak resident memory.

Bar: s/step at 4M at most 1.3 x that at 100k; peak memory at 4M at most 8 GB;
start-up at 4M at most 90 s.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from ._table import aligned_table
from .quality import output_root

HELP = "simplify generated inputs of 100k, 1M and 4M triangles: start-up by phase, s/step and peak memory"

SIZES = (100_000, 1_000_000, 4_000_000)
STEPS = 100
STARTUP_STAGES = ("load and initial guess", "reference views", "the start", "scoring plain decimation",
                  "scoring the classic bake")
STEP_RATIO_BAR = 1.3
MEMORY_BAR_GB = 8.0
STARTUP_BAR_S = 90.0


def measure(triangles: int, steps: int, folder: Path, config: str | Path | None = None) -> dict:
    """Run ``_scaling_worker`` for one size in a child process (with the settings file
    ``config``, else the defaults); returns the row (see the module docstring) with the run's
    profile under ``"profile"``."""
    result = folder / f"result-{triangles}.json"
    child = subprocess.Popen([sys.executable, "-m", "lookalike.bench._scaling_worker", str(triangles), str(steps),
                              str(folder / f"knot-{triangles}"), str(result), *([str(config)] if config else [])])
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode != 0:
        raise RuntimeError(f"bench scaling: the {triangles:,}-triangle run failed (exit {child.returncode})")
    found = json.loads(result.read_text(encoding="utf-8"))
    metrics = found["metrics"]
    seconds = metrics["seconds"]
    return {"triangles": metrics["triangles"]["input"], "generate_seconds": found["generate_s"],
            "startup_seconds": sum(seconds[stage] for stage in STARTUP_STAGES if stage in seconds),
            "stages": {stage: seconds[stage] for stage in STARTUP_STAGES if stage in seconds},
            "seconds_per_step": seconds["per_iteration"], "steps": metrics["iterations"],
            "peak_rss_gb": usage.ru_maxrss * 1024 / 2**30, "profile": metrics["profile"]}


def run(repeats: int | None = None, out: str | Path | None = None, sizes: tuple[int, ...] = SIZES,
        steps: int = STEPS, config: str | Path | None = None) -> dict:
    """Every size in turn (``repeats`` is ignored; ``config``: a settings file for every run).
    Returns ``{"steps", "rows": [row, ...],
    "bars": {...}, "all_meet_bar", "outputs"}``; the bars compare the largest size with the
    smallest."""
    with tempfile.TemporaryDirectory(prefix="lookalike-bench-") as scratch:
        root = output_root(out, scratch)
        root.mkdir(parents=True, exist_ok=True)
        rows = [measure(size, steps, root, config) for size in sizes]
        outputs = None if root == Path(scratch) else str(root.resolve())
    small, large = rows[0], rows[-1]
    bars = {"step_ratio": large["seconds_per_step"] / small["seconds_per_step"],
            "step_ratio_bar": STEP_RATIO_BAR, "peak_rss_gb": large["peak_rss_gb"], "peak_rss_bar_gb": MEMORY_BAR_GB,
            "startup_seconds": large["startup_seconds"], "startup_bar_s": STARTUP_BAR_S}
    meets = (bars["step_ratio"] <= STEP_RATIO_BAR and large["peak_rss_gb"] <= MEMORY_BAR_GB
             and large["startup_seconds"] <= STARTUP_BAR_S)
    return {"steps": steps, "rows": rows, "bars": bars, "all_meet_bar": meets, "outputs": outputs}


def format_table(result: dict) -> str:
    stages = list(STARTUP_STAGES)
    header = ["triangles", "start-up s", *stages, "s/step", "peak RSS GB"]
    cells = [[f"{r['triangles']:,}", f"{r['startup_seconds']:.1f}",
              *(f"{r['stages'].get(stage, 0.0):.1f}" for stage in stages),
              f"{r['seconds_per_step']:.3f}", f"{r['peak_rss_gb']:.2f}"] for r in result["rows"]]
    lines = aligned_table(header, cells)
    b = result["bars"]
    lines.append(f"bar: s/step ratio {b['step_ratio']:.2f} (<= {b['step_ratio_bar']}), peak RSS {b['peak_rss_gb']:.2f} GB "
                 f"(<= {b['peak_rss_bar_gb']:g}), start-up {b['startup_seconds']:.0f} s (<= {b['startup_bar_s']:g}): "
                 f"{'met' if result['all_meet_bar'] else 'NOT met'} ({result['steps']} steps per run)")
    lines.append("phases of the largest input (wall s, CPU/wall):")
    for path, t in result["rows"][-1]["profile"].items():
        lines.append(f"  {path:<60} {t['wall_s']:8.1f}  {t['cpu_per_wall']:4.2f}")
    if result.get("outputs"):
        lines.append(f"outputs: {result['outputs']}")
    return "\n".join(lines)
