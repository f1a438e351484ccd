"""``lookalike bench quality``: its plumbing and its table, with ``simplify`` stubbed out (the
real benchmark takes forty minutes and is run by hand)."""

from __future__ import annotations

import importlib
import json
from types import SimpleNamespace

import pytest

from lookalike.bench import quality
from lookalike.errors import ConfigError


def _metrics(triangles, psnr_decimated, psnr_ours, seconds=420.0, baked=None):
    heldout = {"decimated": {"psnr": psnr_decimated, "flip": 0.12},
               "ours": {"psnr": psnr_ours, "flip": 0.07, "silhouette_error": 0.537}}
    if baked is not None:
        heldout["baked"] = {"psnr": baked, "flip": 0.1}
    return {"triangles": {"input": 10 * triangles, "output": triangles}, "iterations": 700,
            "seconds": {"total": seconds, "per_iteration": 0.5}, "heldout": heldout}


@pytest.fixture
def stub_simplify(monkeypatch, tmp_path):
    calls = []

    def fake(input, outdir, *, triangles, time_budget, init, iterations, force, progress, material_override, init_mesh, device=None):
        calls.append(SimpleNamespace(input=input, outdir=outdir, triangles=triangles, time_budget=time_budget,
                                     iterations=iterations, material=material_override))
        gain = 2.0 if "spot" in str(input) else 4.0
        return SimpleNamespace(metrics=_metrics(triangles, 27.0, 27.0 + gain))

    monkeypatch.setattr(importlib.import_module("lookalike.jobs.simplify"), "simplify", fake)
    assets = tmp_path / "assets"
    assets.mkdir()
    return calls, assets


def test_runs_every_asset_with_its_budget_and_material(stub_simplify, tmp_path):
    calls, assets = stub_simplify
    result = quality.run(out=tmp_path / "out", assets_dir=assets, time_budget=30.0)
    assert [c.triangles for c in calls] == [1500, 2000, 5000, 1000]
    assert all(c.time_budget == 30.0 and c.iterations is None for c in calls)
    assert [c.outdir.name for c in calls] == ["stanford-bunny", "nefertiti", "flight-helmet", "spot"]
    scans = [c.material for c in calls[:2]]
    assert all(m is not None and m.kd.data.flatten()[:3].tolist() == pytest.approx([0.75, 0.72, 0.68]) for m in scans)
    assert all(m.ks.data.flatten().tolist() == pytest.approx([0.0, 0.45, 0.0]) for m in scans)
    assert calls[2].material is None and calls[3].material is None
    rows = {r["asset"]: r for r in result["runs"]}
    assert rows["spot"]["gain_db"] == pytest.approx(2.0) and not rows["spot"]["meets_bar"]
    assert rows["nefertiti"]["meets_bar"] and not result["all_meet_bar"]
    json.dumps(result)


def test_table_lists_runs_and_the_bar(stub_simplify, tmp_path):
    _, assets = stub_simplify
    table = quality.format_table(quality.run(out=tmp_path, assets_dir=assets))
    lines = table.splitlines()
    assert lines[0].split()[:3] == ["asset", "triangles", "minutes"]
    assert any(line.startswith("spot") and line.rstrip().endswith("MISSED") for line in lines)
    assert any(line.startswith("flight-helmet") and "+4.00" in line and "5,000" in line for line in lines)
    assert "NOT met" in lines[-2]


def test_baked_columns_appear_when_a_bake_ran():
    row = quality.table_row(quality.ASSETS[0], _metrics(1500, 27.0, 31.5, baked=30.0))
    assert row["gain_over_baked_db"] == pytest.approx(1.5)
    table = quality.format_table({"runs": [row], "bar": {"minutes": 10, "gain_db": 3}, "all_meet_bar": True,
                                  "time_budget_s": 600})
    assert "PSNR baked" in table and "+1.50" in table
    assert "error near outline" in table and "54%" in table


def test_missing_assets_are_a_clear_error(tmp_path):
    with pytest.raises(ConfigError, match="benchmark assets are missing"):
        quality.run(assets_dir=tmp_path / "nowhere")


def test_select_assets_keeps_the_benchmark_order_and_names_unknown_ones():
    assert [c.name for c in quality.select_assets(["spot", "stanford-bunny"])] == ["stanford-bunny", "spot"]
    with pytest.raises(ConfigError, match="unknown benchmark asset teapot; the assets are flight-helmet, nefertiti"):
        quality.select_assets(["spot", "teapot"])


def test_bench_command_runs_only_the_chosen_assets(stub_simplify, tmp_path, capsys):
    from lookalike.cli import main

    calls, assets = stub_simplify
    assert main(["bench", "quality", "--asset", "spot", "--assets-dir", str(assets), "--out", str(tmp_path / "out")]) == 0
    assert [c.outdir.name for c in calls] == ["spot"]
    assert [line.split()[0] for line in capsys.readouterr().out.splitlines()[2:3]] == ["spot"]
    assert main(["bench", "render", "--asset", "spot"]) != 0
    assert "--asset: bench render does not take it" in capsys.readouterr().err
    assert main(["bench", "render", "--assets-dir", str(assets)]) != 0
    assert "--assets-dir: bench render does not take it" in capsys.readouterr().err
    assert main(["bench", "quality", "--assets-dir", str(tmp_path / "nowhere")]) != 0
    assert "benchmark assets are missing: no folder" in capsys.readouterr().err


def test_bench_command_passes_a_time_budget_to_the_runs(stub_simplify, tmp_path, capsys):
    from lookalike.cli import main

    calls, assets = stub_simplify
    assert main(["bench", "quality", "--asset", "spot", "--assets-dir", str(assets), "--time-budget", "90s",
                 "--out", str(tmp_path / "out")]) == 0
    assert [c.time_budget for c in calls] == [90.0]
    assert main(["bench", "render", "--time-budget", "90s"]) != 0
    assert "--time-budget: bench render does not take it" in capsys.readouterr().err


def _judged(ours_cycles: float, blender_cycles: float, ours_ours: float, baked_ours: float) -> dict:
    """A ``judged_row``-shaped result with the given PSNRs (FLIP lower for ours)."""
    def scores(values):
        return {key: {"psnr": psnr, "flip": 0.02 if key == "ours" else 0.03} for key, psnr in values.items()}

    cycles = scores({"decimated": 20.0, "baked": 25.0, "blender": blender_cycles, "ours": ours_cycles})
    judged = {"views": 16, "resolution": 384,
              "scores": {"ours": scores({"decimated": 21.0, "baked": baked_ours, "blender": 26.0, "ours": ours_ours}),
                         "cycles": cycles, "cycles_no_shadows": cycles},
              "blender_bake": {"seconds": {"total": 12.0}}, "seconds": {"cycles_per_view": 1.5},
              "agreement": {key: {"psnr": 37.4, "flip": 0.01} for key in ("reference", "decimated", "baked", "blender", "ours")}}
    judged["gain_over_blender_db"] = ours_cycles - blender_cycles
    judged["gain_over_baked_db"] = ours_ours - baked_ours
    judged["meets_bar"] = judged["gain_over_blender_db"] >= 1 and judged["gain_over_baked_db"] >= 1
    return judged


def test_judge_reuses_earlier_runs_and_prints_both_renderers(stub_simplify, tmp_path, monkeypatch, capsys):
    from lookalike.cli import main

    calls, assets = stub_simplify
    out = tmp_path / "out"
    (out / "spot").mkdir(parents=True)
    (out / "spot" / "metrics.json").write_text(json.dumps(_metrics(1000, 27.0, 31.0, baked=29.0)))
    judged = []
    monkeypatch.setattr(quality, "check_judge", lambda judge: None)
    monkeypatch.setattr(quality, "judged_row", lambda case, assets_dir, run_dir, baselines: judged.append(
        (case.name, run_dir, baselines)) or _judged(30.0, 28.5, 31.0, 29.5))
    assert main(["bench", "quality", "--asset", "spot", "--asset", "nefertiti", "--assets-dir", str(assets),
                 "--out", str(out), "--judge", "blender", "--reuse"]) == 0
    assert [c.outdir.name for c in calls] == ["nefertiti"]                     # spot was reused, not simplified again
    assert [(name, run.name, base) for name, run, base in judged] == [("nefertiti", "nefertiti", None),
                                                                       ("spot", "spot", None)]
    table = capsys.readouterr().out
    assert "Cycles, shadows" in table and "Cycles, no shadows" in table and "our renderer" in table
    assert "PSNR Blender" in table and "+1.50" in table and "judge bar" in table and "met" in table
    assert "spot: our renderer vs Cycles without shadows on the same file, PSNR dB: input 37.4, dec 37.4" in table
    result = quality.run(out=out, assets_dir=assets, assets=quality.select_assets(["spot"]), judge="blender", reuse=True)
    assert result["runs"][0]["judge"]["gain_over_blender_db"] == pytest.approx(1.5)
    json.dumps(result)


def test_judge_bar_counts_in_the_runs_bar(stub_simplify, tmp_path, monkeypatch):
    _, assets = stub_simplify
    monkeypatch.setattr(quality, "check_judge", lambda judge: None)
    monkeypatch.setattr(quality, "judged_row", lambda *args: _judged(29.0, 28.5, 31.0, 29.5))  # +0.5 dB over Blender
    result = quality.run(out=tmp_path, assets_dir=assets, assets=quality.select_assets(["nefertiti"]), judge="blender")
    assert result["runs"][0]["meets_bar"] and not result["runs"][0]["judge"]["meets_bar"]
    assert not result["all_meet_bar"]
    first, judged = quality.format_table(result).split("judge:")
    assert "MISSED" not in first and "MISSED" in judged and "judge bar" in judged and "NOT met" in judged


def test_ours_is_held_against_the_model_of_blenders_pipeline_its_user_keeps():
    from lookalike.jobs.judge import blender_baseline, users_blender

    judged = _judged(30.0, 28.5, 31.0, 29.5)
    assert blender_baseline(judged) == "blender"                               # a judging with one model of Blender's
    for renderer, psnr in (("cycles", 29.0), ("cycles_no_shadows", 29.0), ("ours", 25.0)):
        judged["scores"][renderer] = {**judged["scores"][renderer], "blender_by_angle": {"psnr": psnr, "flip": 0.025}}
    judged["blender_bake"]["chosen"] = users_blender(judged["scores"]["cycles"])
    assert blender_baseline(judged) == "blender_by_angle"                      # the better in Cycles with shadows
    assert users_blender(judged["scores"]["ours"]) == "blender"                # ours would have picked the other
    table = "\n".join(quality.judge_table({"runs": [{"asset": "gear", "judge": judged}], "bar": {}}))
    cycles_row = next(line for line in table.splitlines() if "Cycles, shadows" in line)
    assert " 29.00 " in cycles_row and "+1.00" in cycles_row and "+1.50" not in cycles_row
    assert "gear: Blender's decimate + bake, smooth by angle" in table


def test_judge_options_are_checked(tmp_path, monkeypatch):
    assets = tmp_path / "assets"
    assets.mkdir()
    monkeypatch.delenv(quality.OUT_ENVIRONMENT, raising=False)
    with pytest.raises(ConfigError, match="judges are blender, not 'mitsuba'"):
        quality.run(assets_dir=assets, judge="mitsuba")
    with pytest.raises(ConfigError, match="judges are blender, not 'three'"):  # three.js judges bench lod
        quality.run(assets_dir=assets, judge="three")
    with pytest.raises(ConfigError, match="--reuse judges earlier runs"):
        quality.run(assets_dir=assets, reuse=True)
