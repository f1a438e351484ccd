"""``lookalike bench implicit``: its fields, its table, and the pipeline a user without
lookalike would run, Blender's decimate + bake of a fine marching-cubes mesh, scored against the
field (the tests that run Blender skip where ``bpy``, the ``judge`` extra, is not installed)."""

from __future__ import annotations

import json

import pytest

from field_factory import write_fields
from lookalike.bench import implicit
from lookalike.bench.quality import BenchAsset
from lookalike.blender import judge_available

needs_blender = pytest.mark.skipif(not judge_available(), reason='needs bpy: pip install -e ".[judge]"')


def test_every_field_runs_at_both_counts_from_its_file():
    assert {(case.path, case.triangles) for case in implicit.ASSETS} == {
        (file, count) for _, file in implicit.FIELDS for count in implicit.TRIANGLES}
    assert set(implicit.TRIANGLES) == {1000, 2000} and {"rook.py", "gear.glsl"} <= {f for _, f in implicit.FIELDS}
    assert len({case.name for case in implicit.ASSETS}) == len(implicit.ASSETS)
    assert all((implicit.EXAMPLES / case.path).is_file() for case in implicit.ASSETS)


def _judged_row(ours_field: float, ours_flip: float) -> dict:
    """A run's row as ``field_row`` and ``judged_field`` make it, with made-up scores."""
    def scores(ours):
        return {key: {"psnr": psnr, "flip": 0.02} for key, psnr in
                (("decimated", 24.0), ("baked", 30.0), ("blender", 31.0), ("ours", ours))}
    judge = {"scores": {"cycles": scores(32.5), "cycles_no_shadows": scores(32.0), "ours": scores(33.0)},
             "field": {"blender": {"psnr": 34.0, "flip": 0.015}, "ours": {"psnr": ours_field, "flip": ours_flip}}}
    judge["scores"]["cycles"]["ours"]["flip"] = 0.018
    judge["gain_over_blender_db"] = 1.5
    judge["field_gain_over_blender_db"] = ours_field - 34.0
    judge["meets_bar"] = judge["field_gain_over_blender_db"] >= 1.0 and ours_flip < 0.015
    metrics = {"triangles": {"input": 100_000, "output": 1000}, "iterations": 700,
               "seconds": {"total": 580.0, "per_iteration": 0.7},
               "heldout": {key: {"psnr": psnr, "flip": flip} for key, psnr, flip in
                           (("decimated", 25.0, 0.07), ("baked", 33.0, 0.014), ("ours", 35.2, 0.012))}}
    return {**implicit.field_row(BenchAsset("rook-1000", "rook.py", 1000, False), metrics), "judge": judge}


def test_the_judge_table_scores_blenders_pipeline_against_the_field_and_states_the_bar():
    rows = [_judged_row(35.2, 0.012), _judged_row(34.5, 0.016)]
    result = {"time_budget_s": 600.0, "runs": rows, "outputs": None,
              "all_meet_bar": all(r["meets_bar"] and r["judge"]["meets_bar"] for r in rows)}
    text = implicit.format_table(result)
    assert "against the field itself" in text and "PSNR Blender" in text and "+1.20" in text and "+0.50" in text
    assert "Blender's decimate + bake + 1 dB with lower FLIP, in Cycles" in text and "NOT met" in text
    assert [r["judge"]["meets_bar"] for r in rows] == [True, False]


@needs_blender
@pytest.mark.slow
def test_the_benchs_blender_baseline_runs_on_a_small_field(tmp_path):
    from lookalike.jobs.simplify import simplify
    from lookalike.settings import config_from_dict

    python, _ = write_fields(tmp_path)
    tiny = {"views": {"pool_size": 4, "heldout": 2, "batch_size": 1, "validation": 0}, "render": {"resolution": 48},
            "latent": {"texture_size": 32}, "optim": {"checkpoint_seconds": 1e9}}
    run_dir = tmp_path / "run"
    result = simplify(python, run_dir, triangles=200, iterations=2, config=config_from_dict(tiny), progress=False)
    case = BenchAsset("field-200", python.name, 200, False)
    judged = implicit.judged_field(case, tmp_path, run_dir, result.baselines, cells=48, resolution=32, views=1)
    assert abs(judged["blender_bake"]["triangles"] - 200) <= 10 and (run_dir / "judge" / "blender.glb").is_file()
    kept = judged["blender_bake"]["chosen"]                                    # smooth, or smooth by angle
    for renderer in ("cycles", "cycles_no_shadows", "ours"):
        assert {"baked", "blender", "blender_by_angle", "ours"} <= set(judged["scores"][renderer])
    assert judged["gain_over_blender_db"] == pytest.approx(judged["scores"]["cycles"]["ours"]["psnr"]
                                                           - judged["scores"]["cycles"][kept]["psnr"])
    field = judged["field"]
    assert set(field) == {"blender", "ours"}
    assert all(10 < s["psnr"] < 60 and 0 < s["flip"] < 0.5 for s in field.values())
    heldout = result.metrics["heldout"]["ours"]                                # the run's views, ours as written
    assert field["ours"]["psnr"] == pytest.approx(heldout["psnr"], abs=0.5)
    assert judged["field_gain_over_blender_db"] == pytest.approx(field["ours"]["psnr"] - field["blender"]["psnr"])
    assert isinstance(judged["meets_bar"], bool)
    json.dumps(judged)
