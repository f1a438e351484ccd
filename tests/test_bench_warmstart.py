"""``lookalike bench warmstart``: its plumbing, the crossing iteration and its table, with
``simplify`` stubbed out (the real benchmark takes eighty minutes and is run by hand)."""

from __future__ import annotations

import importlib
import json
from types import SimpleNamespace

import pytest

from lookalike.bench import warmstart


def _metrics(init: str, asset: str) -> dict:
    """Random starts climb from 20 to 30 dB over 1,000 steps; bake starts begin at 28 dB and
    climb 1 dB per 100 steps, except on spot, where they stay at 28 dB."""
    steps = list(range(0, 1001, 100))
    if init == "random":
        curve = [20.0 + i / 100 for i in steps]
    else:
        curve = [28.0 + (0 if "spot" in asset else i / 100) for i in steps]
    ours = {"psnr": curve[-1] + 0.5, "flip": 0.05}
    return {"triangles": {"input": 10_000, "output": 1_000}, "iterations": 1000,
            "seconds": {"total": 590.0, "per_iteration": 0.5}, "validation": {"iterations": steps, "psnr": curve},
            "heldout": {"decimated": {"psnr": 20.0, "flip": 0.2}, "baked": {"psnr": 27.0, "flip": 0.1}, "ours": ours}}


@pytest.fixture
def runs(monkeypatch, tmp_path):
    calls = []

    def fake(input, outdir, *, triangles, time_budget, init, force, progress, material_override):
        calls.append(SimpleNamespace(input=str(input), outdir=outdir, init=init, time_budget=time_budget))
        return SimpleNamespace(metrics=_metrics(init, str(input)))

    monkeypatch.setattr(importlib.import_module("lookalike.fit.simplify"), "simplify", fake)
    assets = tmp_path / "assets"
    assets.mkdir()
    return calls, warmstart.run(out=tmp_path / "out", assets_dir=assets, time_budget=60.0)


def test_each_asset_runs_from_both_starts_with_the_same_budget(runs):
    calls, result = runs
    assert [c.init for c in calls] == ["random", "bake"] * 4
    assert [c.outdir.name for c in calls[:2]] == ["stanford-bunny-random", "stanford-bunny-bake"]
    assert {c.time_budget for c in calls} == {60.0}
    json.dumps(result)


def test_the_crossing_is_the_first_scored_iteration_at_the_random_best(runs):
    _, result = runs
    rows = {r["asset"]: r for r in result["runs"]}
    bunny = rows["stanford-bunny"]
    assert bunny["validation_psnr_random_best"] == pytest.approx(30.0)
    assert bunny["bake_reaches_random_at"] == 200 and bunny["fraction"] == pytest.approx(0.2)
    assert bunny["meets_bar"]
    assert rows["spot"]["bake_reaches_random_at"] is None and not rows["spot"]["meets_bar"]
    assert not result["all_meet_bar"]


def test_iterations_to_reach():
    curve = {"iterations": [0, 25, 50], "psnr": [10.0, 12.0, 11.0]}
    assert warmstart.iterations_to_reach(curve, 9.0) == 0
    assert warmstart.iterations_to_reach(curve, 11.5) == 25
    assert warmstart.iterations_to_reach(curve, 12.5) is None


def test_the_table_shows_the_comparison_and_the_quality_rows_of_the_bake_starts(runs):
    _, result = runs
    table = warmstart.format_table(result)
    assert table.splitlines()[0].startswith("asset")
    assert any(line.startswith("spot") and "never" in line and line.rstrip().endswith("MISSED")
               for line in table.splitlines())
    assert "NOT met" in table and "bake-start runs" in table and "PSNR baked" in table
    assert result["quality"]["runs"][0]["gain_over_baked_db"] == pytest.approx(38.0 + 0.5 - 27.0)
