"""``bench decimate``'s rows, bar and table on a generated case (the assets and Blender run in
``lookalike bench decimate``, not here)."""

from __future__ import annotations

import pytest

from lookalike.bench import benchmark_modules
from lookalike.bench.decimate import ASSETS, DEFAULT, format_table, no_further, run
from lookalike.errors import ConfigError


def test_thin_shells_are_decimated_by_every_method_and_the_chosen_strays_least(tmp_path):
    case = next(c for c in ASSETS if c.name == "thin-shells")
    result = run(assets=(case,), out=tmp_path)
    assert [r["target"] for r in result["runs"]] == [720, 240] and not result["judged"]
    for row in result["runs"]:
        assert set(row["methods"]) == {"chosen", "old", "meshoptimizer"}
        chosen = row["methods"]["chosen"]
        assert abs(chosen["triangles"] - row["target"]) <= 2 and chosen["far_area"] <= 0.005
        assert row["meets_bar"] and no_further(chosen, row["methods"]["old"], row["samples"])
        assert (tmp_path / f"thin-shells-{row['target']}-old.glb").is_file()
    text = format_table(result)
    assert "thin-shells" in text and "meshoptimizer" in text and "without --judge blender" in text
    assert "bench decimate" not in text and text.splitlines()[-1].endswith(": met")


def test_never_further_allows_rounding_and_puts_the_far_area_first():
    old = {"far_area": 0.01, "p99": 0.02}
    assert no_further({"far_area": 0.01, "p99": 0.02 * 1.0005}, old, 20_000)        # float32 positions, same mesh
    assert not no_further({"far_area": 0.01, "p99": 0.021}, old, 20_000)
    assert no_further({"far_area": 0.005, "p99": 0.05}, old, 20_000)                 # less far area wins
    assert not no_further({"far_area": 0.02, "p99": 0.001}, old, 20_000)


def test_the_bench_is_listed_and_judged_by_blender_only():
    assert "decimate" in benchmark_modules()
    assert "noisy-sphere-4m" in {c.name for c in ASSETS} - {c.name for c in DEFAULT}
    with pytest.raises(ConfigError, match="blender only"):
        run(assets=(), judge="three")
