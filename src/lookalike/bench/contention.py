"""``lookalike bench contention``: how much slower is a step with a second busy program?

Users run ``simplify`` beside other work. torch's and Numba's thread pools each claiming every
core oversubscribe the machine; one thread policy (``--threads``, ``lookalike.threads``) is
meant to leave a fair 2 x.

``simplify`` of spot (the smallest benchmark asset, to 1,000 triangles) with a fixed step count
runs twice as a user runs it (``lookalike simplify``, default settings, in a child process):
alone, then with a second ``simplify`` of the same input started at the same moment and
stopped when the first ends. Each run's seconds per step are its ``metrics.json``'s.

Bar: s/step with the second program at most 2.5 x s/step alone.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

from ._table import aligned_table
from .quality import ASSETS, SHARED_ASSETS, check_assets_dir, output_root

HELP = "simplify spot alone and beside a second simplify: s/step of each, and their ratio"

CASE = next(case for case in ASSETS if case.name == "spot")
STEPS = 120
RATIO_BAR = 2.5


def simplify_command(source: Path, outdir: Path, triangles: int, steps: int, config: Path | None) -> list[str]:
    """The command line of one quiet ``simplify`` of ``source`` into ``outdir`` to ``triangles``
    with ``steps`` steps (and the settings file ``config`` where given)."""
    return [sys.executable, "-m", "lookalike.cli", "simplify", str(source), "-o", str(outdir), "--triangles",
            str(triangles), "--iterations", str(steps), "--quiet", "--force", *(["--config", str(config)] if config else [])]


def seconds_per_step(outdir: Path) -> float:
    """The ``seconds.per_iteration`` of the run in ``outdir``."""
    return json.loads((outdir / "metrics.json").read_text(encoding="utf-8"))["seconds"]["per_iteration"]


def measured_run(command: list[str], outdir: Path, second: list[str] | None) -> float:
    """s/step of the run ``command`` writes into ``outdir``, with the command ``second`` running
    beside it (stopped at the end) where given."""
    second = subprocess.Popen(second, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL) if second else None
    try:
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    finally:
        if second is not None:
            second.kill()
            second.wait()
    return seconds_per_step(outdir)


def run(repeats: int | None = None, out: str | Path | None = None, assets_dir: str | Path = SHARED_ASSETS,
        steps: int = STEPS, source: Path | None = None, triangles: int = CASE.triangles,
        config: Path | None = None) -> dict:
    """Both runs (``repeats`` is ignored; ``source``, ``triangles``, ``config``: another input,
    target and settings file than spot's). Returns ``{"asset", "steps",
    "alone_seconds_per_step", "loaded_seconds_per_step", "ratio", "ratio_bar", "all_meet_bar",
    "outputs"}``."""
    source = source or check_assets_dir(assets_dir) / CASE.path
    with tempfile.TemporaryDirectory(prefix="lookalike-bench-") as scratch:
        root = output_root(out, scratch)
        root.mkdir(parents=True, exist_ok=True)
        alone = measured_run(simplify_command(source, root / "alone", triangles, steps, config), root / "alone", None)
        loaded = measured_run(simplify_command(source, root / "loaded", triangles, steps, config), root / "loaded",
                              simplify_command(source, root / "second", triangles, 10 * steps, config))
        outputs = None if root == Path(scratch) else str(root.resolve())
    ratio = loaded / alone
    return {"asset": Path(source).stem, "steps": steps, "alone_seconds_per_step": alone, "loaded_seconds_per_step": loaded,
            "ratio": ratio, "ratio_bar": RATIO_BAR, "all_meet_bar": ratio <= RATIO_BAR, "outputs": outputs}


def format_table(result: dict) -> str:
    lines = aligned_table(["asset", "steps", "s/step alone", "s/step beside a second simplify", "ratio"],
                          [[result["asset"], str(result["steps"]), f"{result['alone_seconds_per_step']:.3f}",
                            f"{result['loaded_seconds_per_step']:.3f}", f"{result['ratio']:.2f}"]])
    lines.append(f"bar: ratio <= {result['ratio_bar']:g}: {'met' if result['all_meet_bar'] else 'NOT met'}")
    if result.get("outputs"):
        lines.append(f"outputs: {result['outputs']}")
    return "\n".join(lines)
