"""Benchmarks: speed, memory and quality goals live here, never in timed unit tests.

Each benchmark is a module with ``run(**options) -> dict`` (JSON-serialisable figures) and
``format_table(result) -> str``.
"""

BENCHMARKS: dict[str, str] = {
    # name: module under lookalike.bench
}
