"""``lookalike bench scaling`` runs each size in a child process and reads its profile."""

from __future__ import annotations

from lookalike.bench import scaling
from lookalike.jobs.demo import demo_asset


def test_demo_asset_scales_to_a_triangle_count():
    for triangles in (20_000, 400_000):
        mesh = demo_asset(triangles).mesh
        assert abs(mesh.num_triangles - triangles) < 0.02 * triangles


def test_rows_profile_and_peak_memory(tmp_path):
    settings = tmp_path / "tiny.toml"
    settings.write_text("[views]\npool_size = 2\nheldout = 1\nbatch_size = 1\nvalidation = 1\n"
                        "[render]\nresolution = 64\n[latent]\ntexture_size = 256\n")
    result = scaling.run(out=tmp_path / "out", sizes=(6_000, 24_000), steps=2, config=settings)
    small, large = result["rows"]
    assert abs(small["triangles"] - 6_000) < 300 and abs(large["triangles"] - 24_000) < 1_200
    for row in result["rows"]:
        assert row["steps"] == 2 and row["seconds_per_step"] > 0 and 0.05 < row["peak_rss_gb"] < 24
        assert row["startup_seconds"] >= row["stages"]["load and initial guess"] > 0
        assert "load and initial guess > decimation" in row["profile"]
    assert result["bars"]["step_ratio"] > 0
    table = scaling.format_table(result)
    assert f"{large['triangles']:,}" in table and "decimation" in table
