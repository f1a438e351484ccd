"""The classic bake of lighting (``lookalike.init.lighting_bake``) and the radiance it bakes
(``lookalike.shading.surface_radiance``): against what is known in closed form, against what
Mitsuba's own camera sees at the same points, and as the start of an unlit fit."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from io_factory import uv_sphere

pytest.importorskip("mitsuba", reason="the lighting bake needs Mitsuba 3 (pip install -e \".[pathtrace]\")")

from lookalike.asset import Asset, Material, Texture  # noqa: E402
from lookalike.shading.camera import Camera  # noqa: E402
from lookalike.shading.path_tracing import TracedScene, mitsuba, mitsuba_scene, render_path_traced  # noqa: E402
from lookalike.shading.surface_radiance import cosine_directions, mean_outgoing_radiance  # noqa: E402

llvm = pytest.mark.skipif(not mitsuba().variant().startswith("llvm"),
                          reason="the lighting bake needs Mitsuba's LLVM variant (Debian's libllvm19)")


def test_cosine_directions_lie_on_the_normals_hemisphere_with_mean_cosine_two_thirds():
    rng = np.random.default_rng(1)
    normals = rng.normal(size=(20_000, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    directions = cosine_directions(normals, rng)
    cosine = (directions * normals).sum(-1)
    assert np.allclose(np.linalg.norm(directions, axis=1), 1.0, atol=1e-9) and cosine.min() >= 0
    assert abs(cosine.mean() - 2 / 3) < 0.01  # E[cos] under p = cos / pi; 1/2 for uniform directions


@llvm
def test_a_white_lambertian_ball_under_a_white_sky_leaves_its_albedo():
    """Under uniform radiance 1, a convex Lambertian surface of albedo ``a`` sends ``a`` towards
    every direction (nothing of it sees itself)."""
    mi = mitsuba()
    albedo = [0.7, 0.4, 0.2]
    scene = mi.load_dict({"type": "scene", "integrator": {"type": "path", "max_depth": 6, "hide_emitters": True},
                          "ball": {"type": "sphere", "bsdf": {"type": "diffuse",
                                                              "reflectance": {"type": "rgb", "value": albedo}}},
                          "sky": {"type": "constant", "radiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}}})
    rng = np.random.default_rng(2)
    points = rng.normal(size=(500, 3))
    points /= np.linalg.norm(points, axis=1, keepdims=True)
    radiance = mean_outgoing_radiance(TracedScene(scene), points, points, 256, 1.0, seed=3)
    assert np.allclose(radiance.mean(axis=0), albedo, rtol=0.01) and np.allclose(radiance, albedo, rtol=0.1)
    inward = mean_outgoing_radiance(TracedScene(scene), points, -points, 16, 1.0, seed=3)
    assert np.abs(inward).max() < 1e-3  # rays from inside leave the ball's inner side unlit: the sign matters
    again = mean_outgoing_radiance(TracedScene(scene), points, points, 256, 1.0, seed=3)
    assert np.array_equal(radiance, again)


def ball_on_floor() -> Asset:
    from test_path_traced import shadowed_scene

    return shadowed_scene()


def sky_lighting(folder, asset):
    from test_path_traced import sky_map

    from lookalike.jobs.path_traced import fixed_lighting
    from lookalike.settings import config_from_dict

    return fixed_lighting(config_from_dict({"reference": {"lighting": str(sky_map(folder))}}), asset)


def camera_from_above(height: float = 6.0) -> Camera:
    """One camera looking straight down at the origin from ``height``, 40 degrees of view."""
    from lookalike.shading.camera import look_at, perspective

    eye = torch.tensor([[0.0, height, 1e-3]])
    return Camera(mv=look_at(eye, torch.zeros(1, 3), torch.tensor([[0.0, 0.0, -1.0]])),
                  proj=perspective(np.radians(40.0), 1.0, 0.1, 20.0).expand(1, 4, 4).contiguous(), position=eye)


@llvm
def test_the_radiance_at_floor_points_is_what_a_camera_above_sees_there(tmp_path):
    """The floor is nearly Lambertian (roughness 0.8): the light leaving a point, averaged over
    directions, is what Mitsuba's own camera sees there; beside the ball, its shadow."""
    asset = ball_on_floor()
    scene = mitsuba_scene(asset, sky_lighting(tmp_path, asset), 6)
    camera, size = camera_from_above(), 64
    picture = render_path_traced(scene, camera, size, 256, seed=4)[0]
    xs = np.array([1.0, -1.0, 1.9, -1.8, 0.0, 1.3])  # beside the ball (seen from above), then in the open
    zs = np.array([0.0, 0.0, 0.0, 0.4, 1.8, -1.5])
    points = np.stack([xs, np.full_like(xs, -1.0), zs], axis=1)
    radiance = mean_outgoing_radiance(scene, points, np.tile([0.0, 1.0, 0.0], (len(xs), 1)), 4096, 2.0, seed=5)
    clip = torch.cat([torch.from_numpy(points).float(), torch.ones(len(xs), 1)], 1) @ (camera.proj[0] @ camera.mv[0]).T
    ndc = clip[:, :2] / clip[:, 3:]
    cols = ((ndc[:, 0] + 1) / 2 * size).long()
    rows = ((1 - ndc[:, 1]) / 2 * size).long()
    seen = np.stack([picture[r - 1:r + 2, c - 1:c + 2, :3].reshape(-1, 3).mean(0).numpy() for r, c in zip(rows, cols)])
    shadowed, open_floor = radiance[:2].mean(), radiance[2:].mean()
    assert shadowed < 0.97 * open_floor  # the ball's shadow is baked in
    assert np.allclose(radiance, seen, rtol=0.12, atol=0.01)


@llvm
def test_the_baked_ball_drawn_unlit_looks_like_its_path_traced_views(tmp_path):
    """Baked onto the asset's own atlas and drawn unlit by our rasterizer, the lighting looks as
    the path tracer shows it; a texture in the wrong place (UVs flipped) does not."""
    from lookalike.asset.material import unlit_material
    from lookalike.init.lighting_bake import bake_lighting
    from lookalike.shading.light import PointLight
    from lookalike.shading.pipeline import render
    from lookalike.shading.view_sampling import random_views

    mesh = uv_sphere(24, 48)
    asset = Asset(mesh=mesh, materials=[Material(kd=Texture(_stripes(64)), ks=Texture.constant([0.0, 0.9, 0.0]))])
    scene = mitsuba_scene(asset, sky_lighting(tmp_path, asset), 6)
    emission = bake_lighting(asset, mesh, scene, texture_size=64, samples=64, seed=6)
    camera = random_views(torch.zeros(3), 1.0, 4, np.random.default_rng(7))
    traced = render_path_traced(scene, camera, 48, 144, seed=8)
    dark = PointLight(position=camera.position, intensity=torch.zeros(4, 3))

    def drawn(texture):
        baked = Asset(mesh=mesh, materials=[unlit_material(asset.materials[0], texture)])
        return render(baked, camera, dark, (48, 48), spp=2)

    def psnr(image):
        covered = (traced[..., 3] > 0.99) & (image[..., 3] > 0.99)
        error = ((image[..., :3] - traced[..., :3])[covered] ** 2).mean()
        return float(10 * torch.log10(traced[..., :3][covered].max() ** 2 / error))

    flipped = Texture(emission.data.flip(0))
    assert psnr(drawn(emission)) > 28.0
    assert psnr(drawn(emission)) > psnr(drawn(flipped)) + 6.0


def _stripes(size: int) -> torch.Tensor:
    """``[size, size, 4]`` base colour: eight red and white bands along ``v``, opaque."""
    band = (torch.arange(size) * 8 // size) % 2 == 0
    colour = torch.where(band[:, None, None], torch.tensor([0.8, 0.15, 0.1]), torch.tensor([0.8, 0.8, 0.8]))
    return torch.cat([colour.expand(size, size, 3), torch.ones(size, size, 1)], -1).contiguous()


def test_a_small_atlas_gets_more_samples_per_texel_within_bounds():
    from lookalike.init.lighting_bake import SAMPLE_BUDGET, SAMPLES_PER_TEXEL, samples_per_texel

    low, high = SAMPLES_PER_TEXEL
    assert samples_per_texel(10) == high and samples_per_texel(10 ** 9) == low
    assert samples_per_texel(SAMPLE_BUDGET // 200) == 200


def test_a_few_glints_do_not_set_the_unit_of_the_emission_steps():
    from lookalike.fit.textured_mesh import emission_scale

    dim = torch.full((100, 100, 3), 0.1)
    dim[:2, :20] = 50.0  # 0.4 % of the texels: a sun's glints
    assert emission_scale(dim) == 1.0
    assert emission_scale(torch.full((8, 8, 3), 3.0)) == 3.0


def test_the_emission_steps_warm_where_it_starts_as_the_lighting_baked():
    from lookalike.settings import COLD_START, WARM_START, config_from_dict, emissive_learning_rate

    def rate(**reference):
        return emissive_learning_rate(config_from_dict({"reference": {"renderer": "mitsuba", **reference}}))

    assert rate() == COLD_START.lr_textures  # the studio's key light is drawn: the emission starts black
    assert rate(unlit=True) == rate(lighting="sky.hdr") == WARM_START.lr_textures
