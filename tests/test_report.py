"""The HTML report and its pictures, from synthetic data."""

from __future__ import annotations

import re

import numpy as np
import pytest
from PIL import Image

from lookalike.report import RunRecord, score_method, write_report
from lookalike.report.pictures import image_grid, signed_difference, to_srgb_uint8
from lookalike.report.plot import plot_loss, smooth


def _views(rng, n=3, size=24, blur=0.0):
    y, x = np.mgrid[0:size, 0:size] / size
    images = np.stack([np.stack([0.5 + 0.4 * np.sin(7 * x + i + c) * np.cos(5 * y) for c in range(3)], -1)
                       for i in range(n)])
    return (images + blur * rng.normal(size=images.shape)).clip(0).astype(np.float32)


def _data(asset_name="bunny", baked=False) -> RunRecord:
    rng = np.random.default_rng(0)
    reference = _views(rng)
    methods = [score_method("decimated", "Plain decimation", reference, _views(rng, blur=0.3), 1500)]
    if baked:
        methods.append(score_method("baked", "Classic bake", reference, _views(rng, blur=0.2), 1500, 512))
    methods.append(score_method("ours", "Ours", reference, _views(rng, blur=0.05), 1500, 1024))
    return RunRecord(
        asset_name=asset_name, input=f"{asset_name}.obj", reference=reference,
        silhouette=np.zeros(reference.shape[:3], bool), methods=methods, input_triangles=69451,
        output_triangles=1500, texture_size=1024, resolution=24,
        loss_history=np.exp(-np.arange(300) / 80) + 0.01 * rng.random(300),
        validation_history=np.array([[0, 30.0], [300, 33.0]]), validation_views=4, iterations=300, rollbacks=0,
        interrupted=False, wall_time=432.0, seconds_per_iteration=1.25,
        config={"seed": 7, "optim": {"lr_positions": 0.002, "batch": 4}},
        timings={"reference views": 12.5, "optimisation": 375.0}, notes=["the input has no UVs"],
    )


@pytest.mark.parametrize("baked", [False, True])
def test_report_shows_the_numbers_and_every_picture_exists(tmp_path, baked):
    data = _data(baked=baked)
    path = write_report(tmp_path, data)
    assert path == tmp_path / "report.html"
    page = path.read_text(encoding="utf-8")
    assert "<title>bunny" in page and "<h1>bunny</h1>" in page
    for method in data.methods:
        assert f"{method.psnr:.2f}" in page and f"{method.flip:.4f}" in page
        assert method.label in page
    gain = data.ours.psnr - data.baseline.psnr
    assert f"+{gain:.2f} dB" in page
    assert "69,451" in page and "1,500" in page and "1024²" in page
    assert "7.2 min" in page and "1.25 s/iteration" in page
    assert "optim.lr_positions" in page and "0.002" in page
    assert "the input has no UVs" in page
    sources = re.findall(r'src="([^"]+)"', page)
    assert len(sources) == 1 + 2 * (1 + len(data.methods)) * data.num_views      # loss + views
    for source in sources + ["report_files/comparison.png"]:
        assert (tmp_path / source).is_file(), source
    assert "http://" not in page and "https://" not in page and "<script" not in page


def test_the_table_shows_the_error_near_the_outline_where_it_was_measured(tmp_path):
    data = _data()
    assert "Error near outline" not in write_report(tmp_path / "a", data).read_text(encoding="utf-8")
    data.methods[-1].silhouette_error = 0.537
    page = write_report(tmp_path / "b", data).read_text(encoding="utf-8")
    assert "Error near outline" in page and "<td>54 %</td>" in page and "<td>—</td></tr>" in page


def test_report_escapes_text(tmp_path):
    page = write_report(tmp_path, _data(asset_name="<b>&model")).read_text(encoding="utf-8")
    assert "<b>&model" not in page and "&lt;b&gt;&amp;model" in page


def test_report_overwrites_an_earlier_one(tmp_path):
    write_report(tmp_path, _data())
    write_report(tmp_path, _data(asset_name="second"))
    assert "<h1>second</h1>" in (tmp_path / "report.html").read_text(encoding="utf-8")
    assert not list(tmp_path.glob("*.partial"))


def test_display_images_use_the_tone_map():
    linear = np.array([[[0.0, np.e - 1, 100.0]]], dtype=np.float32)
    np.testing.assert_array_equal(to_srgb_uint8(linear), [[[0, 255, 255]]])


def test_signed_difference_colours():
    reference = np.full((1, 1, 3, 3), 0.5, dtype=np.float32)
    test = reference.copy()
    test[0, 0, 0] = 2.0                      # too bright
    test[0, 0, 1] = 0.0                      # too dim
    picture = signed_difference(reference, test)[0, 0].astype(int)
    red, blue, same = picture
    assert red[0] > red[2] + 100 and blue[2] > blue[0] + 100
    np.testing.assert_array_equal(same, [255, 255, 255])


def test_image_grid_lays_out_cells():
    cells = [[np.full((20, 30, 3), 40 * (r + c), np.uint8) for c in range(3)] for r in range(2)]
    grid = image_grid(cells, ["a", "b", "c"], ["row 1", "row 2"])
    assert grid.width > 3 * 30 and grid.height > 2 * 20
    assert np.asarray(grid).reshape(-1, 3).tolist().count([120, 120, 120]) >= 20 * 30


def test_smoothing_keeps_constants_and_follows_steps():
    np.testing.assert_allclose(smooth(np.full(50, 3.0)), 3.0)
    step = smooth(np.r_[np.ones(100), np.zeros(100)])
    assert np.all(np.diff(step[100:]) <= 0) and step[-1] < 0.2 and step[99] == pytest.approx(1.0)


def test_loss_plot_is_written(tmp_path):
    path = plot_loss(np.exp(-np.arange(200) / 50) + 0.01, tmp_path / "loss.png")
    with Image.open(path) as image:
        assert image.width > 600 and image.height > 300


def test_the_validation_curve_is_drawn_on_the_loss_plot(tmp_path):
    history = np.exp(-np.arange(200) / 50) + 0.01
    validation = np.array([[0, 20.0], [50, 25.0], [100, 27.0], [200, 28.0]])
    plain = np.asarray(Image.open(plot_loss(history, tmp_path / "plain.png")).convert("RGB")).astype(int)
    both = np.asarray(Image.open(plot_loss(history, tmp_path / "both.png", validation=validation)).convert("RGB")).astype(int)
    orange = np.array([0xc0, 0x56, 0x2b])
    assert (np.abs(both - orange).sum(axis=-1) < 30).sum() > 200
    assert (np.abs(plain - orange).sum(axis=-1) < 30).sum() == 0


def test_metrics_are_the_records_figures():
    """``metrics.json`` is read off the same record as the page: the same scores per method, in
    the record's order, and the last finite loss."""
    record = _data(baked=True)
    record.loss_history = np.array([3.0, 2.0, np.nan])
    metrics = record.metrics()
    assert metrics["methods"] == ["decimated", "baked", "ours"]
    for method in record.methods:
        assert metrics["heldout"][method.key]["psnr"] == method.psnr
        assert metrics["heldout"][method.key]["label"] == method.label
    assert metrics["final_loss"] == 2.0 and metrics["heldout"]["views"] == 3
    assert metrics["validation"] == {"views": 4, "iterations": [0, 300], "metric": "PSNR", "psnr": [30.0, 33.0],
                                     "written": {}, "written_alpha": {}, "written_model": "ours"}
    record.validation_metric = "score (PSNR and FLIP, FLIP's share 0.5)"     # where FLIP weighs in, not a PSNR
    assert record.metrics()["validation"]["score"] == [30.0, 33.0] and "psnr" not in record.metrics()["validation"]
    assert metrics["seconds"]["total"] == 432.0 and metrics["seconds"]["optimisation"] == 375.0


def test_the_judges_scores_fill_the_reports_slot_and_replace_an_earlier_judging(tmp_path):
    from lookalike.report.html import add_judge_section, judge_section
    from lookalike.jobs.judge_scores import RENDERERS
    path = write_report(tmp_path, _data())
    empty = path.read_text(encoding="utf-8")
    assert "Scores in Blender Cycles" not in empty

    def result(psnr: float) -> dict:
        scores = {r: {k: {"psnr": psnr + i, "flip": 0.01 * (i + 1)} for i, k in enumerate(["baked", "ours"])}
                  for r in RENDERERS}
        return {"scores": scores, "labels": {"baked": "Our classic bake", "ours": "Ours <fit>"}, "views": 16,
                "resolution": 384, "map_noise": {"ours": {"base_color": 0.0012, "specular": 0.0, "normal": 0.0034}}}

    add_judge_section(path, judge_section(result(30.0), RENDERERS, "judge/views.png"))
    page = path.read_text(encoding="utf-8")
    assert "Scores in Blender Cycles" in page and "Cycles, no shadows" in page and "Ours &lt;fit&gt;" in page
    assert "31.00" in page and "0.0200" in page and "0.0012 / 0.0000 / 0.0034" in page
    assert page.index("Scores in Blender Cycles") < page.index("Held-out views") and 'href="judge/views.png"' in page
    add_judge_section(path, judge_section(result(20.0), RENDERERS, None))
    again = path.read_text(encoding="utf-8")
    assert again.count("Scores in Blender Cycles") == 1 and "21.00" in again and "31.00" not in again
    assert again.replace(judge_section(result(20.0), RENDERERS, None), "") == empty


def test_the_starts_distance_reaches_the_metrics_and_the_page(tmp_path):
    """How far the start strays (``RunRecord.start_distance``): in ``metrics.json`` as given
    (``None`` where not measured) and one line of the page."""
    record = _data()
    assert record.metrics()["start_distance"] is None
    assert "How far the start strays" not in write_report(tmp_path, record).read_text()
    record.start_distance = {"of": "our decimation", "setting": "meshoptimizer", "triangles": 1500,
                             "far_area": 0.0012, "mean": 0.0019, "p99": 0.0071, "far": 0.03}
    assert record.metrics()["start_distance"]["far_area"] == 0.0012
    page = write_report(tmp_path, record).read_text()
    assert ("How far the start strays: our decimation by meshoptimizer, 1,500 triangles: 0.12 % of the area lies "
            "farther than 3 % of the bounding radius") in page
