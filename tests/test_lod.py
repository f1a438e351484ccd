"""The LOD chain: levels as given and by default, each level's settings, and a short chain run
and resumed through the shared run."""

from __future__ import annotations

import dataclasses
import json

import pytest
from pygltflib import GLTF2

from lookalike.errors import ConfigError
from lookalike.init import decimate
from lookalike.jobs import lod as lod_job
from lookalike.jobs.lod import LEVEL, Level, default_levels, level_settings, lod, parse_levels, switch_distance
from lookalike.settings import WARM_START, Config, config_from_dict, load_config
from lookalike.shading.view_sampling import FRAMING
from test_fit_simplify import TINY, bumpy_sphere
from test_io_gltf import assert_valid


def test_levels_are_read_finest_first_and_bad_ones_named():
    assert parse_levels("500@32, 8000@512,2000@128") == [Level(8000, 512), Level(2000, 128), Level(500, 32)]
    for bad in ("8000", "8000@", "x@512", "0@64", "100@4"):
        with pytest.raises(ConfigError, match="TRIANGLES@PIXELS"):
            parse_levels(bad)
    with pytest.raises(ConfigError, match="size of its own"):
        parse_levels("800@64,200@64")


def test_the_default_chain_halves_the_size_and_quarters_the_triangles():
    assert default_levels(100_000, 0.02) == [Level(2000, 512), Level(500, 256), Level(125, 128)]
    assert default_levels(1000, 0.02) == [Level(100, 512)]


def test_the_switch_distance_puts_the_sphere_at_the_level_s_size():
    """At the switch distance a sphere of radius 1 spans ``pixels`` of the viewport's height."""
    import math

    d = switch_distance(1.0, 128, fovy_degrees=60.0, viewport_height=1080)
    assert 1080 * 2.0 / (2 * d * math.tan(math.radians(30.0))) == pytest.approx(128)


def test_the_chain_s_budget_follows_the_levels_sizes():
    from lookalike.jobs.lod import level_budgets

    budgets = level_budgets([Level(8000, 512), Level(2000, 128), Level(500, 32)], 900.0)
    assert budgets == pytest.approx([900 * 512 / 704, 900 * 128 / 704, 900 * 64 / 704])


def test_a_level_is_fitted_at_its_size_as_an_engine_draws_it():
    settings = level_settings(Level(500, 32), 60.0)
    assert settings["resolution"] == max(16, -(-32 * FRAMING // 1))
    assert settings["texture_size"] == 128 and settings["time_budget"] == 60.0
    assert level_settings(Level(8000, 512), 1.0)["texture_size"] == 2048


def test_a_small_level_steps_and_validates_in_proportion_to_its_pixels():
    """A vertex steps the same share of a pixel at every size, and a small level, whose views
    are cheap, validates and is scored on as many more of them."""
    large, small = level_settings(Level(8000, 512), 1.0), level_settings(Level(500, 32), 1.0)
    assert not {"lr_positions", "validation", "heldout"} & set(large)
    assert small["lr_positions"] == pytest.approx(16 * WARM_START.lr_positions)
    assert small["validation"] == 16 * Config().views.validation and small["heldout"] == 16 * Config().views.heldout
    assert config_from_dict({"views": {"validation": small["validation"]}}).views.validation == small["validation"]


def test_a_chain_runs_each_level_at_its_size_and_resumes_past_finished_levels(tmp_path, monkeypatch):
    config = config_from_dict({**TINY, "views": {"pool_size": 2, "heldout": 2, "batch_size": 1, "validation": 0},
                               "optim": {"iterations": 2, "checkpoint_seconds": 1e9}}, base=LEVEL.defaults)
    levels = [Level(200, 48), Level(100, 24)]
    rows = lod(bumpy_sphere(), tmp_path / "chain", levels, config=config, progress=False)
    assert [(r["level"], r["pixels"], r["triangles"]) for r in rows] == [(0, 48, 200), (1, 24, 100)]
    chain = json.loads((tmp_path / "chain" / "lods.json").read_text())
    radius = float(bumpy_sphere().mesh.bounding_sphere()[1])
    assert chain["levels"] == rows and rows[0]["switch_distance"] == 0.0
    for row in rows:
        model = tmp_path / "chain" / row["folder"] / "model.glb"
        assert row["file_bytes"] == model.stat().st_size
        textures = row["gpu_bytes"]["textures"]
        assert textures >= round(row["texture_size"] ** 2 * 4 * 4 / 3) and row["gpu_bytes"]["buffers"] >= row["triangles"] * 3 * 4
    assert rows[1]["switch_distance"] == pytest.approx(switch_distance(radius, (48 * 24) ** 0.5))
    gltf = GLTF2().load(str(tmp_path / "chain" / "lods.glb"))
    top = gltf.nodes[gltf.scenes[0].nodes[0]]
    assert [gltf.nodes[i].name for i in top.extensions["MSFT_lod"]["ids"]] == [top.name.replace("LOD0", "LOD1")]
    assert_valid(tmp_path / "chain" / "lods.glb")
    for row in rows:  # lodK.glb beside the chain; the classic level kept and scored for the chain's page
        assert (tmp_path / "chain" / f"lod{row['level']}.glb").read_bytes() == \
            (tmp_path / "chain" / row["folder"] / "model.glb").read_bytes()
        assert (tmp_path / "chain" / row["folder"] / "classic.glb").is_file() and row["classic"]["psnr"] > 10
    page = (tmp_path / "chain" / "report.html").read_text()
    for name in ("lod0_reference.png", "lod0_classic.png", "lod1_ours.png", "lod1_orbit.gif", "psnr_triangles.png"):
        assert f"report_files/{name}" in page and (tmp_path / "chain" / "report_files" / name).is_file()
    from PIL import Image

    from lookalike.jobs.lod_page import ORBIT_FRAMES
    size = level_settings(levels[1], 1.0)["resolution"]
    with Image.open(tmp_path / "chain" / "report_files" / "lod1_orbit.gif") as orbit:  # reference | classic | ours
        assert orbit.n_frames == ORBIT_FRAMES and orbit.size == (3 * size + 4, size)
    for row, level in zip(rows, levels):
        cfg = load_config(tmp_path / "chain" / row["folder"] / "config.toml")
        assert cfg.render.resolution == level_settings(level, 1.0)["resolution"] and cfg.render.latent_msaa == 1
        assert cfg.render.target_spp == 8 and cfg.latent.triangles == level.triangles
        assert cfg.views.distance_spread == 1.0
        assert cfg.io.level_above == (str(tmp_path / "chain" / "lod0" / "model.glb") if row["level"] else "")
    with pytest.raises(ConfigError, match="not empty"):
        lod(bumpy_sphere(), tmp_path / "chain", levels, config=config, progress=False)

    def no_run(*args, **kwargs):
        raise AssertionError("a finished level ran again")

    monkeypatch.setattr(lod_job, "run", no_run)
    assert lod(bumpy_sphere(), tmp_path / "chain", levels, config=config, resume=True, progress=False) == rows


def test_a_level_is_offered_the_level_above_decimated_and_settled_onto_the_surface(tmp_path, monkeypatch):
    """Beside the classic bake, a level gets the fitted level above, decimated to its count and
    put back on the input's surface with the few rounds a fitted model needs (``on_surface``)."""
    from lookalike import io
    from lookalike.jobs.run import run_settings

    sphere = bumpy_sphere()
    io.save(dataclasses.replace(sphere, mesh=decimate(sphere.mesh, 400)), tmp_path / "above.glb")
    offered, settle = [], lod_job.initial_guess_from_mesh
    monkeypatch.setattr(lod_job, "initial_guess_from_mesh",
                        lambda *args, **kw: offered.append(kw) or settle(*args, **kw))
    cfg = run_settings(LEVEL, None, {"level_above": str(tmp_path / "above.glb"), "texture_size": 64})
    guess = lod_job.level_guess(sphere, cfg, 100)
    assert offered == [{"on_surface": True}]
    assert [name for name, _ in guess.alternatives] == ["the level above (400 triangles) decimated"]
    assert guess.alternatives[0][1].mesh.num_triangles == guess.start.mesh.num_triangles
    # each start says how far it strays from the input: our decimation, the level above settled
    assert guess.start_distance["of"] == "our decimation" and guess.start_distance["triangles"] == 100
    settled = guess.alternative_distances["the level above (400 triangles) decimated"]
    assert settled["of"] == "the level above, fitted onto the input's surface" and settled["far_area"] < 0.005


def test_a_run_starts_from_the_alternative_that_scores_higher_on_its_validation_views():
    from lookalike.init.initial_guess import InitialGuess
    from lookalike.jobs.run import take_best_start

    def score(asset):  # each start's score is its number of triangles
        return asset.mesh.num_triangles

    small, large = (dataclasses.replace(bumpy_sphere(), mesh=decimate(bumpy_sphere().mesh, n)) for n in (100, 200))
    guess = InitialGuess(start=small, baseline=small, bake=None, notes=[], alternatives=[("the larger", large)],
                         start_distance={"of": "the smaller"},
                         alternative_distances={"the larger": {"of": "the larger"}})
    take_best_start(guess, score)
    assert guess.start is large and guess.alternatives == [] and "started from the larger" in guess.notes[-1]
    assert guess.start_distance == {"of": "the larger"}
    kept = InitialGuess(start=large, baseline=large, bake=None, notes=[], alternatives=[("the smaller", small)])
    take_best_start(kept, score)
    assert kept.start is large and kept.alternatives == []
    assert kept.notes == ["started from the usual start: it scored higher on the validation views (200.00 dB) than "
                          "the smaller (100.00 dB)"]
    unjudged = InitialGuess(start=small, baseline=small, bake=None, notes=[], alternatives=[("the larger", large)])
    take_best_start(unjudged, None)  # no validation views: the start stays, unremarked
    assert unjudged.start is small and unjudged.alternatives == [] and unjudged.notes == []


def test_simplify_prefilters_one_model_for_a_screen_size(tmp_path, capsys):
    """``simplify --screen-size PX`` runs with a level's settings for that size; a size too small
    is a one-line error."""
    from lookalike import io
    from lookalike.cli import main

    io.save(bumpy_sphere(), tmp_path / "ball.glb")
    (tmp_path / "run.toml").write_text("[views]\npool_size = 2\nheldout = 2\nvalidation = 0\nbatch_size = 1\n")
    assert main(["simplify", str(tmp_path / "ball.glb"), "-o", str(tmp_path / "out"), "--screen-size", "32",
                 "--triangles", "100", "--iterations", "1", "--config", str(tmp_path / "run.toml"), "--quiet"]) == 0
    cfg = load_config(tmp_path / "out" / "config.toml")
    expected = level_settings(Level(100, 32), 1.0)
    assert (cfg.render.resolution, cfg.latent.texture_size) == (expected["resolution"], expected["texture_size"])
    assert (cfg.render.target_spp, cfg.render.latent_msaa) == (LEVEL.defaults.render.target_spp, 1) != (2, 2)
    capsys.readouterr()
    assert main(["simplify", str(tmp_path / "ball.glb"), "-o", str(tmp_path / "small"), "--screen-size", "3"]) == 2
    assert "at least 8 pixels" in capsys.readouterr().err


def test_training_views_spread_the_distance_around_the_level_s_size():
    """With a spread of one octave the cameras stand between 0.71 and 1.41 times the framing
    distance, in the directions they would have without it."""
    import numpy as np
    import torch

    from lookalike.shading.view_sampling import framing_distance, random_views

    plain = random_views(torch.zeros(3), 2.0, 400, np.random.default_rng(3))
    spread = random_views(torch.zeros(3), 2.0, 400, np.random.default_rng(3), distance_spread=1.0)
    ratio = spread.position.norm(dim=1) / framing_distance(2.0)
    assert plain.position.norm(dim=1).sub(framing_distance(2.0)).abs().max() < 1e-4
    assert ratio.min() >= 2 ** -0.5 - 1e-5 and ratio.max() <= 2 ** 0.5 + 1e-5
    assert ratio.min() < 0.75 and ratio.max() > 1.35
    assert torch.allclose(torch.nn.functional.normalize(spread.position, dim=1),
                          torch.nn.functional.normalize(plain.position, dim=1), atol=1e-5)
    points = torch.tensor([[0.0, 0.0, 2.0], [0.0, 0.0, -2.0]])  # the sphere stays between near and far
    depth = spread.clip(points)[..., 2] / spread.clip(points)[..., 3]
    assert depth.abs().max() < 1


def test_a_small_level_s_reference_is_converged_at_8x8_samples():
    """The reference of a 32-pixel level at 8 x 8 samples per pixel is within a small tolerance
    of 16 x 16 (it is free of aliasing), where one sample per pixel is far from it."""
    import numpy as np
    import torch

    from lookalike.fit.reference import MeshReference
    from lookalike.report.metrics import psnr
    from lookalike.shading.view_sampling import random_lights, random_views

    asset = bumpy_sphere()
    reference = MeshReference(asset)
    centre, radius = reference.bounding_sphere()
    rng = np.random.default_rng(5)
    camera = random_views(centre, radius, 3, rng)
    light = random_lights(camera, centre, rng)
    resolution = level_settings(Level(100, 32), 1.0)["resolution"]
    images = {spp: reference.render(camera, light, resolution, spp)[..., :3] for spp in (1, 8, 16)}
    assert psnr(images[16], images[8]) > 38.0
    assert psnr(images[16], images[1]) < psnr(images[16], images[8]) - 8.0
    assert torch.isfinite(images[8]).all()


def test_an_orbit_turns_slowly_around_the_object_under_a_fixed_light():
    import math

    import torch

    from lookalike.shading.view_sampling import framing_distance, orbit_views

    camera, light = orbit_views(torch.tensor([1.0, 2.0, 3.0]), 0.5, 12, 30.0)
    offsets = camera.position - torch.tensor([1.0, 2.0, 3.0])
    assert torch.allclose(offsets.norm(dim=1), torch.full((12,), framing_distance(0.5)), rtol=1e-5)
    flat = torch.nn.functional.normalize(offsets[:, [0, 2]], dim=1)
    steps = torch.rad2deg(torch.acos((flat[1:] * flat[:-1]).sum(dim=1).clamp(-1, 1)))
    assert torch.allclose(steps, torch.full((11,), 2.5), atol=1e-2)
    assert torch.allclose(offsets[:, 1], torch.full((12,), framing_distance(0.5) * math.sin(math.radians(20))), rtol=1e-4)
    assert (light.position == light.position[:1]).all() and (light.intensity == light.intensity[:1]).all()


def test_heavily_supersampled_references_render_fewer_views_at_a_time(monkeypatch):
    """A 512-pixel level's views at 16 x 16 samples are rendered one at a time (a chunk of four
    would hold a billion samples); small ones four at a time; the split does not change them."""
    import numpy as np
    import torch

    from lookalike.fit.reference import RENDER_CHUNK, MeshReference, render_in_chunks, views_per_chunk
    from lookalike.shading.view_sampling import random_lights, random_views

    assert views_per_chunk(538, 16) == 1 and views_per_chunk(538, 8) == 3 and views_per_chunk(34, 16) == RENDER_CHUNK
    reference = MeshReference(bumpy_sphere())
    centre, radius = reference.bounding_sphere()
    rng = np.random.default_rng(2)
    camera = random_views(centre, radius, 3, rng)
    light = random_lights(camera, centre, rng)
    together = reference.render(camera, light, 24, 2)
    monkeypatch.setattr("lookalike.fit.reference.CHUNK_SAMPLES", 48 ** 2)      # one view at a time
    assert views_per_chunk(24, 2) == 1
    assert torch.allclose(render_in_chunks(reference, camera, light, 24, 2), together, atol=1e-6)
