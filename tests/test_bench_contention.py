"""``lookalike bench contention`` times a run alone and beside a second ``simplify``."""

from __future__ import annotations

from lookalike import io
from lookalike.bench import contention
from lookalike.jobs.demo import demo_asset


def test_alone_and_beside_a_second_run(tmp_path):
    source = tmp_path / "knot.glb"
    io.save(demo_asset(6_000), source)
    settings = tmp_path / "tiny.toml"
    settings.write_text("[views]\npool_size = 2\nheldout = 1\nbatch_size = 1\nvalidation = 0\n"
                        "[render]\nresolution = 32\n[latent]\ntexture_size = 128\n")
    result = contention.run(out=tmp_path / "out", steps=3, source=source, triangles=300, config=settings)
    assert result["asset"] == "knot" and result["steps"] == 3
    assert result["alone_seconds_per_step"] > 0 and result["loaded_seconds_per_step"] > 0
    assert result["ratio"] == result["loaded_seconds_per_step"] / result["alone_seconds_per_step"]
    assert (tmp_path / "out" / "second").is_dir()        # the second run ran beside the measured one
    table = contention.format_table(result)
    assert "knot" in table and f"{result['ratio']:.2f}" in table
