"""``lookalike bench warmstart``: its plumbing, the crossing iteration and its table, with
``simplify`` stubbed out (the real benchmark takes about 25 minutes per asset and is run by hand)."""

from __future__ import annotations

import importlib
import json
from types import SimpleNamespace

import pytest

from lookalike.bench import warmstart


def _metrics(init: str, asset: str, iterations: int | None) -> dict:
    """Random starts climb from 20 to 30 dB over 1,000 steps. Bake starts begin at 28 dB and
    climb 1 dB per 100 steps, except on spot, where they stay at 28 dB; a fixed-length run
    (the half run) ends 1 dB higher than a full-length run at the same step.
    Held-out PSNR is the last validation score + 0.5, except nefertiti's half run: 4 dB lower."""
    steps = list(range(0, (iterations or 1000) + 1, 100))
    if init == "random":
        curve = [20.0 + i / 100 for i in steps]
    else:
        curve = [28.0 + (0 if "spot" in asset else i / 100) for i in steps]
    if iterations is not None:
        curve[-1] += 1.0
    ours = {"psnr": curve[-1] + (-4.0 if iterations and "nefertiti" in asset else 0.5), "flip": 0.05}
    return {"triangles": {"input": 10_000, "output": 1_000}, "iterations": steps[-1],
            "seconds": {"total": 590.0, "per_iteration": 0.5}, "validation": {"iterations": steps, "psnr": curve},
            "heldout": {"decimated": {"psnr": 20.0, "flip": 0.2}, "baked": {"psnr": 27.0, "flip": 0.1}, "ours": ours}}


@pytest.fixture
def runs(monkeypatch, tmp_path):
    calls = []

    def fake(input, outdir, *, triangles, time_budget, init, iterations, force, progress, material_override, init_mesh, device=None):
        calls.append(SimpleNamespace(input=str(input), outdir=outdir, init=init, time_budget=time_budget,
                                     iterations=iterations))
        return SimpleNamespace(metrics=_metrics(init, str(input), iterations))

    monkeypatch.setattr(importlib.import_module("lookalike.jobs.simplify"), "simplify", fake)
    assets = tmp_path / "assets"
    assets.mkdir()
    return calls, warmstart.run(out=tmp_path / "out", assets_dir=assets, time_budget=60.0)


def test_each_asset_runs_from_both_starts_with_the_same_budget_then_from_the_bake_in_half_the_steps(runs):
    calls, result = runs
    assert [c.init for c in calls] == ["random", "bake", "bake"] * 4
    assert [c.outdir.name for c in calls[:3]] == ["stanford-bunny-random", "stanford-bunny-bake",
                                                  "stanford-bunny-bake-half"]
    assert [c.iterations for c in calls[:3]] == [None, None, 500]
    assert {c.time_budget for c in calls} == {60.0}
    json.dumps(result)


def test_the_crossing_is_the_first_scored_iteration_at_the_random_best(runs):
    _, result = runs
    rows = {r["asset"]: r for r in result["runs"]}
    bunny = rows["stanford-bunny"]
    assert bunny["validation_psnr_random_best"] == pytest.approx(30.0)
    assert bunny["bake_reaches_random_at"] == 200 and bunny["fraction"] == pytest.approx(0.2)
    assert rows["spot"]["bake_reaches_random_at"] is None


def test_the_bar_needs_the_half_run_as_good_in_validation_and_held_out_psnr(runs):
    _, result = runs
    rows = {r["asset"]: r for r in result["runs"]}
    bunny = rows["stanford-bunny"]
    assert bunny["iterations_half"] == 500 and bunny["validation_psnr_half_best"] == pytest.approx(34.0)
    assert bunny["psnr_half"] == pytest.approx(34.5) and bunny["psnr_random"] == pytest.approx(30.5)
    assert bunny["meets_bar"]
    assert rows["nefertiti"]["validation_psnr_half_best"] > rows["nefertiti"]["validation_psnr_random_best"]
    assert not rows["nefertiti"]["meets_bar"]
    assert not rows["spot"]["meets_bar"]
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
    assert "NOT met" in table and "full-length bake-start runs" in table and "PSNR baked" in table
    assert "PSNR half" in table.splitlines()[0]
    assert result["quality"]["runs"][0]["gain_over_baked_db"] == pytest.approx(38.0 + 0.5 - 27.0)
