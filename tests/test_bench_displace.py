"""``bench displace``'s rows and bar (the runs themselves are ``lookalike bench displace``)."""

from __future__ import annotations

from lookalike.bench.displace import ASSETS, format_table, level_rows


def _metrics(minutes: float, ours: list[float], bakes: list[float]) -> dict:
    levels = [{"level": k, "triangles": 1000 * 4 ** k, "bytes": 500_000, "psnr": p, "flip": 0.05 - k / 100,
               "bake_triangles": 1000 * 4 ** k, "bake_bytes": 200_000 * 2 ** k, "bake_psnr": b,
               "bake_flip": 0.05 - k / 100 + 0.001}
              for k, (p, b) in enumerate(zip(ours, bakes))]
    return {"seconds": {"total": 60 * minutes}, "levels": levels}


def _simplified(psnr: float) -> dict:
    return {"heldout": {"ours": {"psnr": psnr, "flip": 0.04}}}


def test_every_level_from_1_up_needs_the_gain_over_the_classic_bake_and_a_lower_flip():
    rows = level_rows(ASSETS[0], _metrics(9.0, [20.0, 30.6, 40.4], [25.0, 30.0, 40.0]),
                      {k: _simplified(30.0) for k in range(3)})
    assert [r["meets_bar"] for r in rows] == [True, True, False]  # level 0 is not held to it; +0.4 < +0.5
    assert rows[1]["gain_over_bake_db"] == 30.6 - 30.0 and rows[1]["simplify_psnr"] == 30.0
    slow = level_rows(ASSETS[0], _metrics(11.0, [20.0, 31.0], [25.0, 30.0]), {})
    assert [r["meets_bar"] for r in slow] == [False, False]  # over 10 minutes


def test_the_table_lists_each_level_with_bytes_scores_and_the_bar():
    rows = level_rows(ASSETS[0], _metrics(9.0, [20.0, 31.0], [25.0, 30.0]), {1: _simplified(29.5)})
    text = format_table({"runs": rows, "all_meet_bar": False, "judged": {}, "outputs": None})
    lines = text.splitlines()
    assert "nefertiti" in lines[2] and "500,000" in lines[2] and "—" in lines[2]  # no simplify run at level 0
    assert "+1.00" in lines[3] and "29.50" in lines[3] and lines[3].split()[-1] == "ok"
    assert "NOT met" in text


def test_a_stopped_run_stops_the_benchmark_instead_of_starting_the_next():
    from types import SimpleNamespace

    import pytest

    from lookalike.bench.quality import stop_if_interrupted

    stop_if_interrupted(SimpleNamespace(interrupted=False))
    with pytest.raises(KeyboardInterrupt):
        stop_if_interrupted(SimpleNamespace(interrupted=True))
