"""The Blender judge: exact conversion of our views, Cycles against the analytic radiance and
our renderer, Blender's classic pipeline. The tests that run Blender skip where ``bpy`` (the
``judge`` extra) is not installed."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import torch

from io_factory import box, gradient_texture, plane, uv_sphere
from lookalike import io
from lookalike.asset import Animation, Asset, Channel, Material, Mesh, Texture
from lookalike.asset.pose import REST, Poses
from lookalike.errors import ConfigError
from lookalike.blender import INSTALL_HINT, judge_available, require_judge
from lookalike.blender.conversion import GLTF_TO_BLENDER, blender_cameras, blender_point_lights, projection_parameters
from lookalike.shading.camera import Camera, perspective
from lookalike.shading.light import PointLight
from lookalike.shading.pipeline import render, render_coverage
from mesh_factory import icosphere
from skin_factory import bent_cylinder, z_rotation

needs_blender = pytest.mark.skipif(not judge_available(), reason='needs bpy: pip install -e ".[judge]"')

LAMBERTIAN = [1.0, 1.0, 0.0]
"""ks = (gamma 1: no specular lobe, roughness 1, metalness 0): a Lambertian surface in both
renderers (glTF specularFactor 0 -> Blender's Specular IOR Level 0)."""


def _camera(eye, target, fovy_deg: float, aspect: float = 1.0) -> Camera:
    eye = torch.tensor(eye, dtype=torch.float32).reshape(-1, 3)
    target = torch.tensor(target, dtype=torch.float32).reshape(-1, 3).expand_as(eye)
    return Camera.looking_at(eye, target.contiguous(), fovy=math.radians(fovy_deg), aspect=aspect, near=0.5, far=20.0)


def _save(asset: Asset, path) -> str:
    io.save(asset, path)
    return str(path)


def _swaying_cylinder() -> Asset:
    """``bent_cylinder`` (clip 0: the elbow bends 100 degrees over 1 s) with a second clip,
    "sway": the shoulder turns by -90 degrees about z within one frame at 24 fps, the elbow not
    animated (it keeps its rest pose, straight)."""
    asset = bent_cylinder()
    sway = Animation("sway", [Channel(0, "rotation", torch.tensor([0.0, 1 / 24]),
                                      torch.tensor([z_rotation(0.0), z_rotation(math.radians(-90))]))])
    return dataclasses.replace(asset, animations=[*asset.animations, sway])


# --- conversions (no Blender needed) -------------------------------------------------------


def test_projection_parameters_come_back_from_the_matrix():
    p = projection_parameters(perspective(math.radians(37.0), 1.5, 0.25, 40.0))
    assert p["fovy"] == pytest.approx(math.radians(37.0), rel=1e-6)
    assert p["aspect"] == pytest.approx(1.5, rel=1e-6)
    assert p["near"] == pytest.approx(0.25, rel=1e-4) and p["far"] == pytest.approx(40.0, rel=1e-4)


def test_blender_camera_sits_at_the_eye_in_blender_axes_and_looks_at_the_target():
    camera = _camera([[1.0, 2.0, 3.0]], [[0.0, 0.5, 0.0]], 40.0, aspect=4 / 3)
    (view,) = blender_cameras(camera, width=64, height=48)
    world = np.array(view["matrix_world"])
    assert np.allclose(world[:3, 3], [1.0, -3.0, 2.0], atol=1e-5)            # glTF (x, y, z) -> (x, -z, y)
    forward = -world[:3, 2]                                                  # a Blender camera looks down -z
    expected = GLTF_TO_BLENDER[:3, :3] @ (np.array([0.0, 0.5, 0.0]) - [1.0, 2.0, 3.0])
    assert np.allclose(forward, expected / np.linalg.norm(expected), atol=1e-5)
    assert view["angle_y"] == pytest.approx(math.radians(40.0), rel=1e-6)
    with pytest.raises(ValueError, match="aspect"):
        blender_cameras(camera, width=48, height=48)


def test_point_light_power_is_four_pi_times_the_intensity():
    light = PointLight(position=torch.tensor([[0.0, 1.0, 2.0]]), intensity=torch.tensor([[2.0, 4.0, 1.0]]))
    (converted,) = blender_point_lights(light, 1)
    assert converted["energy"] == pytest.approx(4 * math.pi * 4.0)
    assert converted["color"] == pytest.approx([0.5, 1.0, 0.25])
    assert converted["location"] == pytest.approx([0.0, -2.0, 1.0])
    assert len(blender_point_lights(light, 3)) == 3                          # one light shared by every view


def test_a_missing_bpy_is_a_one_line_config_error(monkeypatch):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "bpy" else real(name, *a))
    assert not judge_available()
    with pytest.raises(ConfigError, match='pip install -e ".\\[judge\\]"') as error:
        require_judge()
    assert str(error.value) == INSTALL_HINT and "\n" not in INSTALL_HINT


def test_simplify_judge_without_bpy_stops_before_simplifying(monkeypatch, tmp_path, capsys):
    import importlib.util

    from lookalike.cli import main

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "bpy" else real(name, *a))
    assert main(["simplify", str(tmp_path / "missing.obj"), "--judge", "blender"]) == 2
    assert INSTALL_HINT in capsys.readouterr().err                             # not "no such file"


def test_judge_summary_names_every_renderer_and_method():
    from lookalike.jobs.judge import judge_summary

    scores = {key: {"psnr": 30.0, "flip": 0.01} for key in ("decimated", "ours")}
    text = judge_summary({"views": 16, "resolution": 384, "labels": {"decimated": "Plain decimation", "ours": "Ours"},
                          "scores": {"ours": scores, "cycles": scores, "cycles_no_shadows": scores}})
    assert "16 held-out views at 384 px" in text and "Cycles, no shadows: Plain decimation 30.00 dB / 0.0100" in text


def test_judged_views_are_the_reports_heldout_views():
    from lookalike.fit.reference import MeshReference
    from lookalike.fit.training_views import view_sampler
    from lookalike.report.heldout import HeldoutViews
    from lookalike.jobs.judge_scores import heldout_views

    asset = Asset(mesh=icosphere(1, center=(0.3, -0.2, 5.0), radius=2.0))
    reference = MeshReference(asset)
    heldout = HeldoutViews(reference, view_sampler(*reference.bounding_sphere()), 3, 1234, 8, 1)
    views = heldout_views(reference, 3, 1234)
    assert torch.equal(views.camera.mv, heldout.camera.mv) and torch.equal(views.camera.proj, heldout.camera.proj)
    assert torch.equal(views.light.position, heldout.light.position) and views.pose is None


def test_judged_views_of_an_animated_run_carry_its_poses():
    from lookalike.fit.reference import SkinnedReference
    from lookalike.fit.training_views import view_sampler
    from lookalike.jobs.animated import heldout_poses
    from lookalike.report.heldout import HeldoutViews
    from lookalike.jobs.judge_scores import heldout_views

    asset = _swaying_cylinder()
    reference = SkinnedReference(asset)
    sampler = view_sampler(*reference.bounding_sphere(), poses=heldout_poses(asset))   # as simplify draws them
    heldout = HeldoutViews(reference, sampler, 4, 99, 8, 1)
    views = heldout_views(reference, 4, 99, heldout_poses(asset))
    assert torch.equal(views.camera.mv, heldout.camera.mv) and torch.equal(views.light.position, heldout.light.position)
    assert torch.equal(views.pose.clip, heldout.pose.clip) and torch.equal(views.pose.time, heldout.pose.time)
    assert set(views.pose.clip.tolist()) == {0, 1}                           # every clip shown


# --- Cycles --------------------------------------------------------------------------------


def _plane_radiance(camera: Camera, light: PointLight, albedo, height: int, width: int) -> np.ndarray:
    """``[H, W, 3]`` analytic radiance ``a I cos(theta) / (pi d^2)`` of the plane z = 0 (normal
    +z) seen through each pixel centre of view 0."""
    proj, mv = camera.proj[0].double().numpy(), camera.mv[0].double().numpy()
    ys, xs = np.mgrid[0:height, 0:width]
    ndc = np.stack([(xs + 0.5) / width * 2 - 1, 1 - (ys + 0.5) / height * 2], -1)
    direction_view = np.concatenate([ndc[..., :1] / proj[0, 0], ndc[..., 1:] / proj[1, 1], -np.ones_like(ndc[..., :1])], -1)
    inverse = np.linalg.inv(mv)
    direction = direction_view @ inverse[:3, :3].T
    origin = inverse[:3, 3]
    point = origin + direction * (-origin[2] / direction[..., 2:3])
    to_light = light.position[0].double().numpy() - point
    d2 = (to_light ** 2).sum(-1, keepdims=True)
    cosine = np.clip(to_light[..., 2:3] / np.sqrt(d2), 0, None)
    return np.asarray(albedo) * light.intensity[0].double().numpy() * cosine / (math.pi * d2)


@needs_blender
def test_cycles_lambertian_radiance_is_the_analytic_one(tmp_path):
    from lookalike.blender.cycles import render_cycles_views

    quad = plane(3)
    quad = Mesh(v_pos=quad.v_pos * 4 - torch.tensor([2.0, 2.0, 0.0]), t_pos_idx=quad.t_pos_idx, uv=quad.uv)
    albedo = [0.6, 0.45, 0.3]
    asset = Asset(mesh=quad, materials=[Material(kd=Texture.constant([*albedo, 1.0]), ks=Texture.constant(LAMBERTIAN))])
    glb = _save(asset, tmp_path / "quad.glb")
    height, width = 24, 40                                                    # not square: checks the aspect
    camera = _camera([[0.3, -0.4, 3.0]], [[0.0, 0.0, 0.0]], 40.0, aspect=width / height)
    light = PointLight(position=torch.tensor([[0.6, 0.5, 1.2]]), intensity=torch.tensor([[3.0, 2.0, 2.5]]))
    cycles = render_cycles_views(glb, camera, light, (height, width), (True,), samples=4).images[True][0].numpy()
    ours = render(asset, camera, light, (height, width), spp=2)[0].numpy()
    expected = _plane_radiance(camera, light, albedo, height, width)
    assert cycles.shape == (height, width, 4)
    inside = (cycles[..., 3] > 0.999) & (ours[..., 3] > 0.999)
    assert inside.mean() > 0.9
    np.testing.assert_allclose(cycles[inside][:, :3], expected[inside], rtol=0.03)
    np.testing.assert_allclose(ours[inside][:, :3], expected[inside], rtol=0.03)


@needs_blender
def test_silhouettes_land_on_the_same_pixels(tmp_path):
    from lookalike.fit.training_views import view_sampler
    from lookalike.blender.cycles import render_cycles_views

    mesh = icosphere(3)                                                       # an off-centre, lopsided blob
    v_pos = mesh.v_pos * torch.tensor([1.6, 0.7, 1.0]) + 0.4 * mesh.v_pos[:, :1] ** 2 + torch.tensor([0.5, 2.0, -1.0])
    asset = Asset(mesh=Mesh(v_pos=v_pos, t_pos_idx=mesh.t_pos_idx),
                  materials=[Material(kd=Texture.constant([0.8, 0.8, 0.8, 1.0]), ks=Texture.constant(LAMBERTIAN))])
    glb = _save(asset, tmp_path / "blob.glb")
    views = view_sampler(*asset.mesh.bounding_sphere())(np.random.default_rng(3), 3)
    camera, light = views.camera, views.light
    cycles = render_cycles_views(glb, camera, light, 64, (False,), samples=4).images[False]
    ours = render(asset, camera, light, 64, spp=2)
    a, b = cycles[..., 3] > 0.5, ours[..., 3] > 0.5
    iou = (a & b).sum(dim=(1, 2)) / (a | b).sum(dim=(1, 2))
    assert iou.min() > 0.97, iou


@needs_blender
def test_cycles_agrees_with_our_renderer_on_a_smooth_textured_sphere(tmp_path):
    from lookalike.fit.training_views import view_sampler
    from lookalike.blender.cycles import render_cycles_views
    from lookalike.jobs.judge_scores import score_renders

    kd = gradient_texture(64, 4, seed=1)
    kd[..., 3] = 1.0
    asset = Asset(mesh=uv_sphere(24, 48), materials=[Material(kd=Texture(kd), ks=Texture.constant([0.0, 0.6, 0.0]))])
    glb = _save(asset, tmp_path / "sphere.glb")
    views = view_sampler(*asset.mesh.bounding_sphere())(np.random.default_rng(5), 3)
    camera, light = views.camera, views.light
    cycles = render_cycles_views(glb, camera, light, 64, samples=16)
    ours = render(io.load(glb), camera, light, 64, spp=4)
    for shadows in (True, False):                                             # a convex sphere shadows nothing
        score = score_renders(cycles.images[shadows], ours)
        assert score["psnr"] > 35.0 and score["flip"] < 0.06, score


@needs_blender
def test_cycles_lights_by_an_environment_map_from_where_mitsuba_does(tmp_path, monkeypatch):
    """A grey ball under a map with a warm spot up one side and a blue one low on another:
    Cycles' world, turned by ``ENVIRONMENT_TURN``, lights it as Mitsuba's ``envmap`` does in our
    frame (the turn a quarter off lights it from elsewhere, far worse)."""
    pytest.importorskip("mitsuba", reason="needs Mitsuba 3 (the pathtrace extra)")
    from lookalike.blender import cycles as cycles_module
    from lookalike.io.environment_map import write_environment_map
    from lookalike.jobs.judge_scores import score_renders
    from lookalike.shading.fixed_lighting import environment_lighting
    from lookalike.shading.path_tracing import mitsuba_scene, render_path_traced

    rows, columns = np.mgrid[0:32, 0:64]
    sky = np.full((32, 64, 3), 0.02, dtype=np.float32)
    sky += 20 * np.exp(-((columns - 10) ** 2 + (rows - 10) ** 2) / 12.0)[..., None] * np.float32([1.0, 0.6, 0.2])
    sky += 10 * np.exp(-((columns - 38) ** 2 + (rows - 19) ** 2) / 12.0)[..., None] * np.float32([0.2, 0.4, 1.0])
    environment = write_environment_map(tmp_path / "sky.exr", sky)
    asset = Asset(mesh=uv_sphere(24, 48), materials=[Material(kd=Texture.constant([0.8, 0.8, 0.8, 1.0]),
                                                              ks=Texture.constant(LAMBERTIAN))])
    glb = _save(asset, tmp_path / "ball.glb")
    camera = _camera([[0.0, 0.5, 3.5], [3.0, -0.5, -1.5]], [[0.0, 0.0, 0.0]] * 2, 40.0)
    dark = PointLight(position=torch.zeros(1, 3), intensity=torch.zeros(1, 3))
    mitsuba = render_path_traced(mitsuba_scene(asset, environment_lighting(environment, torch.zeros(3)), 2), camera,
                                 32, 64)
    right, scores = cycles_module.ENVIRONMENT_TURN, {}
    for turn in (right, right - math.pi / 2):
        monkeypatch.setattr(cycles_module, "ENVIRONMENT_TURN", turn)
        pictures = cycles_module.render_cycles_views(glb, camera, dark, 32, (True,), samples=64,
                                                     environment=environment).images[True]
        scores[turn] = score_renders(mitsuba, pictures)["psnr"]
    assert scores[right] > 28.0 and scores[right - math.pi / 2] < scores[right] - 8, scores


@needs_blender
def test_shadows_off_lights_what_the_occluder_shades(tmp_path):
    from lookalike.blender.cycles import render_cycles_views

    quad = plane(3)
    floor = Mesh(v_pos=quad.v_pos * 4 - torch.tensor([2.0, 2.0, 0.0]), t_pos_idx=quad.t_pos_idx)
    ball = icosphere(2, center=(0.0, 0.0, 0.8), radius=0.4)
    mesh = Mesh(v_pos=torch.cat([floor.v_pos, ball.v_pos]),
                t_pos_idx=torch.cat([floor.t_pos_idx, ball.t_pos_idx + floor.num_vertices]))
    asset = Asset(mesh=mesh, materials=[Material(kd=Texture.constant([0.7, 0.7, 0.7, 1.0]), ks=Texture.constant(LAMBERTIAN))])
    glb = _save(asset, tmp_path / "ball.glb")
    camera = _camera([[0.0, -2.5, 2.5]], [[0.0, 0.0, 0.0]], 50.0)
    light = PointLight(position=torch.tensor([[0.0, 0.0, 2.5]]), intensity=torch.tensor([[4.0, 4.0, 4.0]]))
    images = render_cycles_views(glb, camera, light, 48, samples=4).images
    ours = render(asset, camera, light, 48, spp=2)[0]
    ball_pixels = render_coverage(ball, camera, 48)[0] > 0
    floor = ~torch.nn.functional.max_pool2d(ball_pixels[None].float(), 3, 1, 1)[0].bool() & (ours[..., 3] > 0.999)
    shadowed = floor & (images[True][0, ..., :3].mean(-1) < 0.02)
    assert shadowed.sum() > 10                                                # the ball's shadow on the floor
    lit = images[False][0][shadowed][:, :3]
    np.testing.assert_allclose(lit, ours[shadowed][:, :3], rtol=0.05)         # ours never shadows


@needs_blender
def test_cycles_poses_a_skinned_glb_as_our_skinning_does(tmp_path):
    from lookalike.fit.reference import SkinnedReference
    from lookalike.blender.cycles import render_cycles_views
    from lookalike.jobs.judge_scores import score_renders

    glb = _save(_swaying_cylinder(), tmp_path / "character.glb")
    reference = SkinnedReference(io.load(glb))
    camera = _camera([[0.4, 0.9, 6.0]] * 4, [[0.4, 0.9, 0.0]], 40.0)          # facing the plane the joints turn in
    light = PointLight(position=torch.tensor([[2.0, 3.0, 5.0]] * 4), intensity=torch.full((4, 3), 30.0))
    # halfway through the bend (where Blender's normalised lerp of the rotation keys meets the
    # slerp), its end, half a frame into the sway (a subframe; the elbow back at rest), the rest pose
    pose = Poses.of([0, 0, 1, REST], [0.5, 1.0, 0.5 / 24, 0.0])
    cycles = render_cycles_views(glb, camera, light, 48, (False,), samples=16, pose=pose).images[False]
    ours = reference.render(camera, light, 48, 4, pose)
    a, b = cycles[..., 3] > 0.5, ours[..., 3] > 0.5
    iou = (a & b).sum(dim=(1, 2)) / (a | b).sum(dim=(1, 2))
    assert iou.min() > 0.97, iou
    rest = b[3:]
    iou_with_rest = (a & rest).sum(dim=(1, 2)) / (a | rest).sum(dim=(1, 2))
    assert iou_with_rest[:3].max() < 0.7, iou_with_rest                      # the poses are not the rest pose
    assert score_renders(cycles, ours)["psnr"] > 32.0                         # both shade the posed normals


# --- Blender's classic pipeline ------------------------------------------------------------


@needs_blender
def test_blender_bake_round_trips_through_our_loader(tmp_path):
    from lookalike.blender.decimate_bake import blender_classic_bake

    source = Asset(mesh=uv_sphere(24, 48), materials=[
        Material(kd=Texture.constant([0.5, 0.25, 0.1, 1.0]), ks=Texture.constant([0.0, 0.3, 0.7]))])
    reference = _save(source, tmp_path / "reference.glb")
    result = blender_classic_bake(reference, tmp_path / "blender.glb", triangles=300, texture_size=64, samples=1)
    assert result.input_triangles == source.mesh.num_triangles and abs(result.triangles - 300) <= 10
    assert {"decimate", "unwrap", "bake normal", "bake base colour", "bake roughness", "bake metalness",
            "export", "total"} <= set(result.seconds)
    baked = io.load(result.path)
    assert baked.mesh.num_triangles == result.triangles and len(baked.materials) == 1
    material = baked.materials[0]
    assert material.normal is not None and material.ks.data.shape[:2] == (64, 64)
    covered = material.ks.data[..., 1] > 0.05                                 # texels the bake reached
    assert covered.float().mean() > 0.4
    roughness, metalness = material.ks.data[covered][:, 1].median(), material.ks.data[covered][:, 2].median()
    assert roughness == pytest.approx(0.3, abs=0.02) and metalness == pytest.approx(0.7, abs=0.02)
    base = material.kd.data[covered][:, :3].median(dim=0).values
    np.testing.assert_allclose(base, [0.5, 0.25, 0.1], rtol=0.03)             # 8-bit sRGB steps
    normal = material.normal.data[covered].median(dim=0).values
    assert normal[2] > 0.99                                                   # a sphere onto a sphere: flat


@needs_blender
def test_blender_bake_smooth_by_angle_keeps_a_boxs_faces_flat(tmp_path):
    from lookalike.blender.decimate_bake import SHARP_ANGLE, blender_classic_bake

    source = Asset(mesh=box(7), materials=[Material(kd=Texture.constant([0.5, 0.5, 0.5, 1.0]),
                                                     ks=Texture.constant([0.0, 0.5, 0.0]))])
    reference = _save(source, tmp_path / "box.glb")
    turn = {}
    for angle in (None, SHARP_ANGLE):
        baked = io.load(blender_classic_bake(reference, tmp_path / f"{angle}.glb", triangles=200, texture_size=32,
                                             samples=1, sharp_angle=angle).path).mesh
        corners = baked.v_pos[baked.t_pos_idx]
        face = torch.nn.functional.normalize(torch.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0],
                                                         dim=1), dim=1)
        slots = torch.nn.functional.normalize(baked.v_nrm[baked.t_nrm_idx], dim=-1)
        turn[angle] = torch.rad2deg(torch.acos((slots * face[:, None]).sum(-1).abs().clamp(max=1.0))).max()
    assert turn[None] > 30.0                                   # shaded smooth: the corners' normals lean over
    assert turn[SHARP_ANGLE] < 1.0, turn                       # smooth by angle: every face's own normal


COVERAGE_AGREEMENT = 0.05
"""Largest relative difference between Cycles' and our coverage of the same alpha-tested foliage
(the generated broadleaf tree, 6 views at 384²: 0.2243 against 0.2191)."""

FOLIAGE_NOISE_FLOOR_DB, FOLIAGE_NOISE_FLOOR_FLIP = 30.0, 0.02
"""Least PSNR and most FLIP of Cycles' picture of foliage against itself drawn with another seed
(the broadleaf tree at 384², 32 samples: 37.65 dB, FLIP 0.0060): the judge's own noise."""


def _small_tree() -> Asset:
    """A generated broadleaf tree, small: 150 alpha-tested leaf cards sharing one leaf texture on
    bark of 3 main branches."""
    from lookalike.samples.foliage import broadleaf_tree

    return broadleaf_tree(0, cards=150, branches=3)


@needs_blender
def test_the_judge_sees_alpha_tested_foliage_as_our_renderer_does(tmp_path):
    from lookalike.fit.training_views import view_sampler
    from lookalike.blender.cycles import render_cycles_views
    from lookalike.jobs.judge_scores import score_renders

    tree = _small_tree()
    glb = _save(tree, tmp_path / "tree.glb")
    views = view_sampler(*tree.mesh.bounding_sphere())(np.random.default_rng(2), 3)
    cycles = {seed: render_cycles_views(glb, views.camera, views.light, 96, (True,), seed=seed).images[True]
              for seed in (0, 1)}
    ours = render(tree, views.camera, views.light, 96, spp=2, layers=16)
    coverage = {"cycles": float(cycles[0][..., 3].mean()), "ours": float(ours[..., 3].mean())}
    assert coverage["cycles"] == pytest.approx(coverage["ours"], rel=COVERAGE_AGREEMENT), coverage
    floor = score_renders(cycles[0], cycles[1])                    # the same tree, another noise
    assert floor["psnr"] > FOLIAGE_NOISE_FLOOR_DB and floor["flip"] < FOLIAGE_NOISE_FLOOR_FLIP, floor
    empty = score_renders(cycles[0], torch.zeros_like(cycles[0]))  # the least any model scores
    assert empty["psnr"] < floor["psnr"] - 10.0, (empty, floor)


@needs_blender
def test_blender_decimate_keeps_the_leaf_texture_whole(tmp_path):
    from lookalike.blender.decimate_bake import blender_decimate_glb

    tree = _small_tree()
    reference = _save(tree, tmp_path / "tree.glb")
    target = tree.mesh.num_triangles // 10
    result = blender_decimate_glb(reference, tmp_path / "decimated.glb", target)
    assert result.input_triangles == tree.mesh.num_triangles and abs(result.triangles - target) <= 0.1 * target
    decimated = io.load(result.path)
    leaves = next(m for m in tree.materials if m.alpha_mode == "MASK")
    kept = [m for m in decimated.materials if m.alpha_mode == "MASK"]
    assert len(kept) == 1 and kept[0].kd.data.shape == leaves.kd.data.shape
    assert torch.equal(kept[0].kd.data, io.load(reference).materials[tree.materials.index(leaves)].kd.data)


@needs_blender
def test_blender_decimates_a_flat_shaded_mesh_as_one_surface(tmp_path):
    """Every edge of the flat-shaded sphere is a hard edge, so the glTF importer leaves every
    triangle apart (it merges a position's vertices only where their normals agree); merged
    again, the decimation keeps a closed surface."""
    from lookalike.asset.normals import face_normals
    from lookalike.blender.decimate_bake import blender_decimate_glb

    sphere = icosphere(3)
    triangles = sphere.num_triangles
    normals = torch.nn.functional.normalize(face_normals(sphere.v_pos, sphere.t_pos_idx), dim=1)
    flat = dataclasses.replace(sphere, v_nrm=normals.repeat_interleave(3, dim=0),
                               t_nrm_idx=torch.arange(3 * triangles).reshape(-1, 3))
    reference = _save(Asset(mesh=flat, materials=[Material()]), tmp_path / "flat.glb")
    result = blender_decimate_glb(reference, tmp_path / "decimated.glb", triangles // 4)
    faces = io.load(result.path).mesh.t_pos_idx
    edges = torch.sort(torch.cat([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), dim=1).values
    _, uses = torch.unique(edges, dim=0, return_counts=True)
    assert abs(result.triangles - triangles // 4) <= 0.1 * triangles // 4 and bool((uses == 2).all())


# --- judging a simplify run ----------------------------------------------------------------


@needs_blender
@pytest.mark.slow
def test_judge_run_scores_every_method_in_every_renderer(tmp_path):
    import json

    from lookalike.settings import config_from_dict
    from lookalike.jobs.judge import judge_run
    from lookalike.jobs.simplify import simplify

    mesh = icosphere(4)                                                        # far from the origin, large units
    p = mesh.v_pos
    mesh.v_pos = p * (1 + 0.08 * torch.sin(6 * p[:, 0]) * torch.sin(6 * p[:, 1]))[:, None] * 250.0 \
        + torch.tensor([1000.0, -40.0, 7.0])
    asset = Asset(mesh=mesh, materials=[Material(kd=Texture.constant([0.6, 0.5, 0.4, 1.0]),
                                                 ks=Texture.constant([0.0, 0.4, 0.0]))])
    cfg = config_from_dict({"views": {"pool_size": 2, "heldout": 3, "batch_size": 1, "validation": 0},
                            "render": {"resolution": 48}, "latent": {"texture_size": 64},
                            "optim": {"checkpoint_seconds": 1e9}})
    outdir = tmp_path / "run"
    result = simplify(asset, outdir, triangles=200, iterations=2, config=cfg, progress=False)
    judged = judge_run(outdir, asset, result.baselines, resolution=40, views=2)
    assert judged["views"] == 2 and judged["resolution"] == 40
    for renderer in ("ours", "cycles", "cycles_no_shadows"):
        assert set(judged["scores"][renderer]) == {"decimated", "baked", "blender", "blender_by_angle", "ours"}
        assert all(10 < s["psnr"] < 60 and 0 < s["flip"] < 0.5 for s in judged["scores"][renderer].values())
    assert set(judged["agreement"]) == {"reference", "decimated", "baked", "blender", "blender_by_angle", "ours"}
    cycles = judged["scores"]["cycles"]                                        # the user keeps the better one
    kept = judged["blender_bake"]["chosen"]
    assert cycles[kept]["psnr"] == max(cycles["blender"]["psnr"], cycles["blender_by_angle"]["psnr"])
    assert judged["agreement"]["reference"]["psnr"] > 30                     # the same file in both renderers
    coverage = judged["reference_coverage"]
    assert coverage["ours"] > 0.2 and coverage["cycles"] == pytest.approx(coverage["ours"], rel=0.03)
    assert abs(judged["blender_bake"]["triangles"] - 200) <= 10
    names = {p.name for p in (outdir / "judge").iterdir()}
    assert {"reference.glb", "decimated.glb", "baked.glb", "blender.glb", "blender_by_angle.glb", "judge.json",
            "views.png"} <= names
    metrics = json.loads((outdir / "metrics.json").read_text())
    assert metrics["judge"]["scores"]["cycles"]["ours"]["psnr"] == pytest.approx(judged["scores"]["cycles"]["ours"]["psnr"])


@needs_blender
@pytest.mark.slow
def test_judge_run_judges_an_animated_run_in_motion(tmp_path):
    import json

    from lookalike.settings import config_from_dict
    from lookalike.jobs.judge import judge_run, reference_of_run
    from lookalike.jobs.simplify import simplify

    glb = _save(bent_cylinder(), tmp_path / "character.glb")
    cfg = config_from_dict({"views": {"pool_size": 8, "heldout": 3, "validation": 0}, "render": {"resolution": 48},
                            "latent": {"texture_size": 64}, "optim": {"checkpoint_seconds": 1e9}})
    outdir = tmp_path / "run"
    result = simplify(glb, outdir, triangles=100, iterations=5, config=cfg, compare_static=True, progress=False)
    judged = judge_run(outdir, reference_of_run(outdir), result.baselines, resolution=48)
    methods = {"decimated", "baked", "bind_pose", "ours"}
    for renderer in ("ours", "cycles", "cycles_no_shadows"):
        assert set(judged["scores"][renderer]) == methods
        assert all(10 < s["psnr"] < 60 and 0 < s["flip"] < 0.5 for s in judged["scores"][renderer].values())
    assert "skipped" in judged["blender_bake"]                                # a still-model pipeline
    assert judged["poses"] == result.metrics["heldout"]["poses"]              # the run's views, in its poses
    heldout = result.metrics["heldout"]
    for key in methods:                                                       # at the run's resolution: its report's
        assert judged["scores"]["ours"][key]["flip"] == pytest.approx(heldout[key]["flip"], rel=0.05, abs=0.002)
    coverage = judged["reference_coverage"]
    assert coverage["cycles"] == pytest.approx(coverage["ours"], rel=0.05)   # posed alike in both renderers
    assert judged["agreement"]["reference"]["psnr"] > 25                     # the same file, posed alike, in both
    judge = outdir / "judge"
    assert {"reference.glb", "decimated.glb", "baked.glb", "bind_pose.glb", "judge.json", "views.png"} <= {
        p.name for p in judge.iterdir()} and not (judge / "blender.glb").exists()
    assert all(io.load(judge / f"{key}.glb").animations for key in ("reference", "decimated", "baked", "bind_pose"))
    metrics = json.loads((outdir / "metrics.json").read_text())
    assert set(metrics["judge"]["scores"]["cycles"]) == methods
