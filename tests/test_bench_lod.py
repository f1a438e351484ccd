"""``bench lod``'s rows and bar (the chain itself runs in ``lookalike bench lod``, not here)."""

from __future__ import annotations

from lookalike.bench.lod import format_table, level_row


def _scores(classic_psnr, ours_psnr, ours_flicker=1.1):
    return {"reference": {"flicker": 0.01}, "input": {"psnr": 19.0, "flip": 0.25, "flicker": 2.0},
            "classic": {"psnr": classic_psnr, "flip": 0.2, "flicker": 1.6},
            "ours": {"psnr": ours_psnr, "flip": 0.15, "flicker": ours_flicker}}


LEVEL = {"level": 1, "triangles": 2000, "pixels": 128, "texture_size": 512}


def test_a_level_meets_the_bar_only_with_the_gain_its_size_asks_for():
    sizes = {"classic": 1000, "ours": 900}
    assert level_row("a", LEVEL, 14.0, _scores(20.0, 21.6), sizes, largest=False)["meets_bar"]
    assert not level_row("a", LEVEL, 14.0, _scores(20.0, 21.4), sizes, largest=False)["meets_bar"]
    assert level_row("a", {**LEVEL, "level": 0}, 14.0, _scores(20.0, 21.1), sizes, largest=True)["meets_bar"]
    assert not level_row("a", LEVEL, 16.0, _scores(20.0, 22.0), sizes, largest=False)["meets_bar"]  # chain too slow
    assert not level_row("a", LEVEL, 14.0, _scores(20.0, 22.0, ours_flicker=1.4), sizes, largest=False)["meets_bar"]


def test_the_table_lists_each_level_with_its_bytes_and_the_bar():
    row = level_row("nefertiti", LEVEL, 14.0, _scores(20.0, 21.6), {"classic": 2048, "ours": 1024}, largest=False)
    text = format_table({"runs": [row], "all_meet_bar": True, "time_budget_s": 900.0, "outputs": None})
    assert "nefertiti" in text and "+1.60" in text and text.splitlines()[2].split()[-3:-1] == ["2", "1"]
    assert row["psnr_input"] == 19.0 and "2.00x" in text
    assert "1.60x" in text and "bar: chain <= 15 min" in text and ": met" in text
