"""``bench displace``'s rows and bar (the runs themselves are ``lookalike bench displace``)."""

from __future__ import annotations

import numpy as np

from lookalike.bench.displace import ASSETS, format_table, level_rows


def _metrics(minutes: float, ours: list[float], starts: list[float], bakes: list[float]) -> dict:
    """Levels 0.. with ours, the classic displacement bake (FLIP 0.001 above ours) and the
    classic decimate + bake at each level's count (bytes doubling per level)."""
    levels = [{"level": k, "triangles": 1000 * 4 ** k, "bytes": 500_000, "psnr": p, "flip": 0.05 - k / 100,
               "start_psnr": s, "start_flip": 0.05 - k / 100 + 0.001, "bake_triangles": 1000 * 4 ** k,
               "bake_bytes": 200_000 * 2 ** k, "bake_psnr": b, "bake_flip": 0.05 - k / 100 + 0.001}
              for k, (p, s, b) in enumerate(zip(ours, starts, bakes))]
    return {"seconds": {"total": 60 * minutes}, "levels": levels}


def test_every_level_needs_the_gain_over_the_classic_displacement_bake_and_a_lower_flip():
    rows = level_rows(ASSETS[0], _metrics(9.0, [30.0, 31.0, 33.5, 34.0], [29.5, 30.6, 33.0, 33.0],
                                          [30.0, 35.0, 40.0, 45.0]))
    assert [r["meets_bar"] for r in rows] == [True, False, True, True]  # +0.4 < +0.5 at level 1
    assert rows[2]["gain_over_start_db"] == 33.5 - 33.0 and rows[2]["gain_over_base_bake_db"] == 3.5
    slow = level_rows(ASSETS[0], _metrics(11.0, [30.0, 31.0], [29.0, 30.0], [29.0, 30.0]))
    assert [r["meets_bar"] for r in slow] == [False, False]  # over 10 minutes


def test_a_level_below_the_one_under_it_or_level_2_near_the_base_bake_misses_the_bar():
    falling = level_rows(ASSETS[0], _metrics(9.0, [30.0, 32.0, 33.5, 33.3], [29.0, 31.0, 32.0, 32.0],
                                             [30.0, 35.0, 40.0, 45.0]))
    assert [r["meets_bar"] for r in falling] == [True, True, True, False]  # 0.2 dB below level 2
    near = level_rows(ASSETS[0], _metrics(9.0, [30.0, 31.0, 32.9, 33.0], [29.0, 30.0, 32.0, 32.0],
                                          [30.0, 35.0, 40.0, 45.0]))
    assert [r["meets_bar"] for r in near] == [True, True, False, True]  # level 2 only +2.9 over the base's bake


def test_the_same_bytes_buy_the_plain_mesh_interpolated_in_log_bytes():
    rows = level_rows(ASSETS[0], _metrics(9.0, [30.0, 31.0, 32.0], [29.0, 30.0, 31.0], [30.0, 36.0, 42.0]))
    assert abs(rows[0]["same_bytes_psnr"] - (36.0 + 6.0 * np.log(500_000 / 400_000) / np.log(2))) < 1e-9


def test_the_table_lists_each_level_with_bytes_scores_and_the_bar():
    rows = level_rows(ASSETS[0], _metrics(9.0, [30.0, 31.0], [29.0, 30.0], [30.0, 35.0]))
    text = format_table({"runs": rows, "all_meet_bar": False, "judged": {}, "outputs": None})
    lines = text.splitlines()
    assert "nefertiti" in lines[2] and "500,000" in lines[2]
    assert "+1.00" in lines[3] and "29.00" not in lines[3] and lines[3].split()[-1] == "ok"
    assert "NOT met" in text


def test_a_stopped_run_stops_the_benchmark_instead_of_starting_the_next():
    from types import SimpleNamespace

    import pytest

    from lookalike.bench.quality import stop_if_interrupted

    stop_if_interrupted(SimpleNamespace(interrupted=False))
    with pytest.raises(KeyboardInterrupt):
        stop_if_interrupted(SimpleNamespace(interrupted=True))
