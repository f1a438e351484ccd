"""Benchmarks: speed, memory and quality goals live here, never in timed unit tests.

Each module ``lookalike.bench.NAME`` is the benchmark ``lookalike bench NAME`` and defines
``HELP`` (one line), ``run(repeats=None) -> dict`` (JSON-serialisable figures) and
``format_table(result) -> str``.
"""

from __future__ import annotations

import pkgutil


def benchmark_modules() -> dict[str, str]:
    """``{benchmark name: module name}`` for every module in this package."""
    return {m.name: m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_")}
