"""The real-time judge: three.js in headless Chromium draws our glTF as our renderer does."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
import torch
from io_factory import gradient_texture, npm_package, plane, uv_sphere

from lookalike import io
from lookalike.asset import Asset, Material, Mesh, PunctualLight, Texture
from lookalike.errors import ConfigError
from lookalike.shading.light import PointLight
from lookalike.shading.pipeline import render
from lookalike.shading.view_sampling import random_views
from lookalike.webgl import render_threejs, require_threejs

pytestmark = pytest.mark.timeout(300)
"""Each test's limit, far above its few seconds (the npm packages' first install included): node
and Chromium never hold up the suite."""


@pytest.fixture(scope="module")
def modules():
    if shutil.which("chromium") is None:
        pytest.skip("the three.js judge needs Debian's chromium (apt-get install chromium)")
    npm_package("three@0.170.0")
    return npm_package("puppeteer-core@23.11.1")


def lit_ball() -> Asset:
    kd = torch.cat([gradient_texture(32, 3, 4), torch.ones(32, 32, 1)], -1)
    material = Material(kd=Texture(kd), ks=Texture.constant([0.0, 0.6, 0.0]),
                        emissive=Texture(0.2 * gradient_texture(32, 3, 5)))
    light = PunctualLight(position=torch.tensor([2.0, 2.5, 3.0]), intensity=torch.tensor([20.0, 18.0, 16.0]))
    return Asset(mesh=uv_sphere(24, 48), materials=[material], lights=[light])


def psnr(a: torch.Tensor, b: torch.Tensor) -> float:
    a, b = a[..., :3].clamp(0, 1), b[..., :3].clamp(0, 1)
    return float(-10 * torch.log10(((a - b) ** 2).mean()))


def test_threejs_draws_our_glb_with_its_own_light_as_we_draw_it(modules, tmp_path):
    asset = lit_ball()
    io.save(asset, tmp_path / "ball.glb")
    camera = random_views(torch.zeros(3), 1.0, 2, np.random.default_rng(1))
    light = PointLight(position=asset.lights[0].position[None], intensity=asset.lights[0].intensity[None])
    ours = torch.cat([render(asset, camera[k], light, (64, 64), spp=2) for k in range(2)])
    theirs = render_threejs(tmp_path / "ball.glb", camera, 64, modules=modules)
    assert psnr(ours, theirs) > 30.0
    assert (ours[..., 3] - theirs[..., 3]).abs().mean() < 0.01


def test_each_view_s_own_light_replaces_the_file_s(modules, tmp_path):
    asset = lit_ball()
    io.save(asset, tmp_path / "ball.glb")
    camera = random_views(torch.zeros(3), 1.0, 2, np.random.default_rng(1))
    lights = PointLight(position=torch.tensor([[3.0, 0.0, 1.0], [-1.0, 3.0, 0.5]]), intensity=torch.tensor(
        [[30.0, 10.0, 10.0], [0.0, 0.0, 0.0]]))  # a red light, then none: the emission alone
    ours = torch.cat([render(asset, camera[k], lights[k], (64, 64), spp=2) for k in range(2)])
    theirs = render_threejs(tmp_path / "ball.glb", camera, 64, light=lights, modules=modules)
    assert psnr(ours[:1], theirs[:1]) > 30.0 and psnr(ours[1:], theirs[1:]) > 30.0


def test_threejs_reads_our_ktx2_mips_where_the_png_gives_box_filtered_ones(modules, tmp_path, monkeypatch):
    from test_io_ktx2 import _asset_with_fitted_mips, _basisu

    _basisu(monkeypatch)
    asset = _asset_with_fitted_mips()
    io.save(asset, tmp_path / "mips.glb")
    monkeypatch.setenv("LOOKALIKE_BASISU", str(tmp_path / "no-such-encoder"))
    io.save(asset, tmp_path / "png.glb")
    # the 16-texel quad seen 4 pixels wide: a GPU's trilinear lookup reads mip level 2, whose fitted
    # colour is (0.5, 0.4, 0.6) where the box-filtered level 2 of the ramp is grey
    eye, centre = torch.tensor([[0.5, 0.5, 10.2]]), torch.tensor([[0.5, 0.5, 0.0]])
    camera = type(random_views(centre[0], 1.0, 1, np.random.default_rng(0))).looking_at(eye, centre, fovy=0.75)
    light = PointLight(position=eye, intensity=torch.full((1, 3), 300.0))

    def red_over_green(path) -> float:
        picture = render_threejs(path, camera, 32, light=light, samples=0, modules=modules)[0]
        covered = picture[..., 3] > 0.99
        return float(picture[..., 0][covered].mean() / picture[..., 1][covered].mean())

    assert red_over_green(tmp_path / "mips.glb") > 1.15
    assert abs(red_over_green(tmp_path / "png.glb") - 1.0) < 0.03


def test_the_engine_footprint_reads_the_mip_levels_three_js_reads(modules, tmp_path, monkeypatch):
    from test_io_ktx2 import _asset_with_fitted_mips, _basisu

    from lookalike.shading.texturing import ENGINE_FOOTPRINT, FOOTPRINT_SCALE

    _basisu(monkeypatch)
    asset = _asset_with_fitted_mips()  # each mip level its own colour: the colour says the level
    io.save(asset, tmp_path / "mips.glb")
    centre = torch.tensor([[0.5, 0.5, 0.0]])

    def red_over_green(picture: torch.Tensor) -> float:
        covered = picture[0, ..., 3] > 0.99
        return float(picture[0, ..., 0][covered].mean() / picture[0, ..., 1][covered].mean())

    for distance in (6.0, 20.0):
        eye = torch.tensor([[0.5, 0.5, distance]])
        camera = type(random_views(centre[0], 1.0, 1, np.random.default_rng(0))).looking_at(eye, centre, fovy=0.75)
        light = PointLight(position=eye, intensity=torch.full((1, 3), 300.0))
        three = red_over_green(render_threejs(tmp_path / "mips.glb", camera, 32, light=light, samples=0,
                                              modules=modules))
        engine = red_over_green(render(asset, camera, light, (32, 32), spp=1, footprint=ENGINE_FOOTPRINT))
        supersampled = red_over_green(render(asset, camera, light, (32, 32), spp=1, footprint=FOOTPRINT_SCALE))
        assert abs(engine - three) < 0.03 and abs(supersampled - three) > 0.2  # 0.79 levels finer


def test_the_written_light_is_a_khr_point_light_read_back_where_it_was(tmp_path):
    asset = lit_ball()
    io.save(asset, tmp_path / "ball.glb")
    data = (tmp_path / "ball.glb").read_bytes()
    document = json.loads(data[20:20 + int.from_bytes(data[12:16], "little")])
    (written,) = document["extensions"]["KHR_lights_punctual"]["lights"]
    assert written["type"] == "point" and written["intensity"] == pytest.approx(20.0)
    (light,) = io.load(tmp_path / "ball.glb").lights
    assert torch.allclose(light.position, asset.lights[0].position)
    assert torch.allclose(light.intensity, asset.lights[0].intensity)


def test_a_missing_three_js_is_one_line_naming_what_to_install(tmp_path):
    with pytest.raises(ConfigError, match="npm install"):
        require_threejs(tmp_path / "node_modules")


LAMBERTIAN = Texture.constant([1.0, 1.0, 0.0])
"""A specular map of no specular (glTF's occlusion, roughness, metalness: 1, 1, 0)."""


def white_card(cut_out: bool) -> Asset:
    """A white card (y = 1, 1 x 1, double-sided, alpha-tested), its half x < 0 cut away where
    ``cut_out``."""
    card = plane(2)
    card.v_pos = torch.stack([card.v_pos[:, 0] - 0.5, torch.ones(4), 0.5 - card.v_pos[:, 1]], -1)
    kd = torch.ones(16, 16, 4)
    if cut_out:
        kd[:, :8, 3] = 0.0                                                    # u < 0.5: x < 0
    return Asset(mesh=card, materials=[Material(name="card", kd=Texture(kd), ks=LAMBERTIAN, alpha_mode="MASK",
                                                alpha_cutoff=0.5, double_sided=True)])


def card_over_floor(cut_out: bool) -> Asset:
    """A grey floor (y = 0, 4 x 4) under ``white_card(cut_out)``, lit from straight above."""
    floor, card = plane(2), white_card(cut_out)
    floor.v_pos = torch.stack([4 * floor.v_pos[:, 0] - 2, torch.zeros(4), 2 - 4 * floor.v_pos[:, 1]], -1)
    t_pos_idx = torch.cat([floor.t_pos_idx, card.mesh.t_pos_idx + 4])
    uv = torch.cat([floor.uv[0][0], card.mesh.uv[0][0]])
    mesh = Mesh(v_pos=torch.cat([floor.v_pos, card.mesh.v_pos]), t_pos_idx=t_pos_idx, uv=[(uv, t_pos_idx.clone())],
                t_mat_idx=torch.tensor([0, 0, 1, 1]))
    return Asset(mesh=mesh, materials=[Material(name="floor", kd=Texture.constant([0.5, 0.5, 0.5, 1.0]), ks=LAMBERTIAN),
                                       *card.materials])


def test_threejs_shadows_fall_through_the_cut_outs(modules, tmp_path):
    from lookalike.shading.camera import Camera

    camera = Camera.looking_at(torch.tensor([[0.0, 3.0, 4.0]]), torch.zeros(1, 3))
    light = PointLight(position=torch.tensor([[0.0, 5.0, 0.0]]), intensity=torch.tensor([[40.0, 40.0, 40.0]]))
    floor = {}
    for name, cut_out, shadows in (("unshadowed", False, False), ("opaque", False, True), ("cut out", True, True)):
        io.save(card_over_floor(cut_out), tmp_path / f"{name}.glb")
        picture = render_threejs(tmp_path / f"{name}.glb", camera, 96, light=light, samples=0, modules=modules,
                                 shadows=shadows)[0]
        floor[name] = picture[48:58, :, :3].mean().item()    # the floor's strip across the shadow's near half
    assert floor["opaque"] < 0.9 * floor["unshadowed"], floor                 # the card's shadow on the floor
    assert floor["opaque"] < floor["cut out"] < floor["unshadowed"], floor    # half of it lets the light through
    half = (floor["unshadowed"] + floor["opaque"]) / 2
    assert floor["cut out"] == pytest.approx(half, rel=0.15), floor


def test_threejs_shadows_leave_either_side_of_a_lone_card_lit_and_a_sphere_without_acne(modules, tmp_path):
    """A double-sided card alone, lit and seen from above and from below, and a lit sphere: with
    shadows on, each is as bright as with them off (within 2 %) where the light reaches it
    (nothing stands between them: a receiver offset along the vertex normal would put the card's
    lit back face in its own shadow, and too small a bias stripes the sphere with acne)."""
    from lookalike.shading.camera import Camera

    io.save(white_card(False), tmp_path / "card.glb")
    io.save(Asset(mesh=uv_sphere(32, 64), materials=[Material(kd=Texture.constant([0.8, 0.8, 0.8, 1.0]), ks=LAMBERTIAN)]),
            tmp_path / "ball.glb")
    for name, side in (("card", 1.0), ("card", -1.0), ("ball", 1.0)):
        camera = Camera.looking_at(torch.tensor([[0.3, 1.0 + 3.0 * side, 0.4]]), torch.tensor([[0.0, 1.0, 0.0]]))
        light = PointLight(position=torch.tensor([[-0.5, 1.0 + 4.0 * side, 0.5]]),
                           intensity=torch.tensor([[30.0, 30.0, 30.0]]))
        plain, shadowed = (render_threejs(tmp_path / f"{name}.glb", camera, 64, light=light, samples=0, modules=modules,
                                          shadows=shadows)[0] for shadows in (False, True))
        lit = (plain[..., 3] > 0.99) & (plain[..., :3].mean(-1) > 0.2 * plain[..., :3].mean(-1).max())
        assert lit.sum() > 100, (name, side)
        ratio = shadowed[..., :3][lit].mean() / plain[..., :3][lit].mean()
        assert ratio.item() == pytest.approx(1.0, abs=0.02), (name, side)
