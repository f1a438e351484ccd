"""Deep opacity shadow maps (``lookalike.shading.shadow_maps``) on scenes with known shadows: an
occluder above a floor lit from straight above, seen by a camera between them (the occluder
is behind it), so that every pixel is floor and the occluder changes it only by its shadow."""

from __future__ import annotations

import dataclasses
import math

import pytest
import torch

from lookalike.asset import Asset, Material, Texture
from lookalike.errors import ConfigError
from lookalike.fit.reference import MeshReference
from lookalike.jobs.reference_kinds import run_reference
from lookalike.jobs.run import mesh_latent, scoring_draw
from lookalike.settings import config_from_dict
from lookalike.shading import Camera, PointLight, render
from lookalike.shading.shadow_maps import ShadowMapping
from field_factory import sphere_field
from test_pipeline import NO_SPECULAR, merge, quad, uv_sphere

SIZE = 32
"""Pixels per side of the floor's pictures."""

HEIGHT, OCCLUDER, LIGHT = 0.8, 0.4, 4.0
"""The camera's height above the floor (z = 0), the occluder's half-size (at z = 1), the light's height."""

SHADOW = OCCLUDER * LIGHT / (LIGHT - 1.0)
"""Half-size of the occluder's shadow on the floor."""

EDGE = 0.15
"""Distance from the shadow's edge within which the tests leave the floor alone: a light pixel
of the 64-pixel maps is 0.075 wide on the floor, an image pixel 0.05."""

MAPS = ShadowMapping(layers=2, resolution=64)


def grey(double_sided: bool = False, dtype=torch.float32, **options) -> Material:
    return Material(kd=Texture(torch.tensor([[[0.8, 0.8, 0.8, 1.0]]], dtype=dtype)),
                    ks=Texture(torch.tensor([[NO_SPECULAR]], dtype=dtype)), double_sided=double_sided, **options)


def scene(occluder: Material, floor: Material | None = None, dtype=torch.float32) -> Asset:
    """A floor of half-size 1.2 at z = 0 facing up and an occluder quad of half-size
    ``OCCLUDER`` at z = 1 (``u`` runs along +x)."""
    mesh = merge([quad(0.0, 1.2, material=0), quad(1.0, OCCLUDER, material=1)])
    mesh = dataclasses.replace(mesh, v_pos=mesh.v_pos.to(dtype), uv=[(mesh.uv[0][0].to(dtype), mesh.uv[0][1])])
    return Asset(mesh, [floor or grey(), occluder])


def below(dtype=torch.float32) -> tuple[Camera, PointLight]:
    """The camera ``HEIGHT`` above the floor looking down (90 degrees: it sees
    ``|x|, |y| < HEIGHT``), and the light ``LIGHT`` above the floor's centre."""
    camera = Camera.looking_at(torch.tensor([[0.0, 0.0, HEIGHT]], dtype=dtype), torch.zeros(1, 3, dtype=dtype),
                               fovy=math.radians(90.0), near=0.05, far=5.0)
    return camera, PointLight(torch.tensor([[0.0, 0.0, LIGHT]], dtype=dtype), torch.full((1, 3), 16.0, dtype=dtype))


def floor_distance() -> torch.Tensor:
    """``[SIZE, SIZE]`` distance of each pixel's floor point from the floor's centre, in the
    max norm (the shadow is a square): row 0 is +y."""
    centre = ((torch.arange(SIZE) + 0.5) / SIZE * 2.0 - 1.0) * HEIGHT
    return torch.maximum(centre[:, None].abs(), centre[None, :].abs())


def test_an_opaque_occluder_darkens_the_floor_beneath_it_and_nothing_else():
    asset, (camera, light) = scene(grey(double_sided=True)), below()
    off = render(asset, camera, light, SIZE)
    on = render(asset, camera, light, SIZE, shadows=MAPS)
    distance = floor_distance()
    under, beside = distance < SHADOW - EDGE, distance > SHADOW + EDGE
    assert off[0, ..., 3].min() == 1 and off[0, ..., :3].min() > 0.1  # floor everywhere, lit everywhere
    assert on[0][under][:, :3].max() <= 1e-6 * off.max()
    torch.testing.assert_close(on[0][beside], off[0][beside], rtol=1e-6, atol=0.0)
    assert on[0, ..., 3].equal(off[0, ..., 3])


def test_a_half_transparent_occluder_lets_half_the_light_through():
    half = Material(kd=Texture.constant([0.8, 0.8, 0.8, 0.5]), ks=Texture.constant(NO_SPECULAR), alpha_mode="BLEND",
                    double_sided=True)
    asset, (camera, light) = scene(half), below()
    ratio = render(asset, camera, light, SIZE, shadows=MAPS)[0, ..., 0] / render(asset, camera, light, SIZE)[0, ..., 0]
    under = floor_distance() < SHADOW - EDGE
    torch.testing.assert_close(ratio[under], torch.full_like(ratio[under], 0.5), rtol=0.0, atol=1e-3)


def test_an_alpha_tested_occluder_half_cut_away_casts_half_the_shadow_on_its_own_side():
    texels = torch.full((8, 8, 4), 0.8)
    texels[..., 3] = 0.0
    texels[:, :4, 3] = 1.0  # u < 1/2, the occluder's -x half
    texels.requires_grad_(True)
    cut = Material(kd=Texture(texels), ks=Texture.constant(NO_SPECULAR), alpha_mode="MASK", alpha_cutoff=0.5,
                   double_sided=True)
    camera, light = below()
    shade = {}
    for name, occluder in (("whole", grey(double_sided=True)), ("cut", cut)):
        asset = scene(occluder)
        lit = render(asset, camera, light, SIZE)[0, ..., 0]
        shade[name] = 1.0 - render(asset, camera, light, SIZE, shadows=MAPS)[0, ..., 0] / lit.detach()
    assert shade["whole"].sum() > 0.2 * SIZE ** 2
    assert shade["cut"].sum().item() / shade["whole"].sum().item() == pytest.approx(0.5, abs=0.06)
    assert shade["cut"][:, SIZE // 2:].sum() < 0.05 * shade["cut"].sum()  # the +x half of the floor stays lit
    gradient, = torch.autograd.grad(shade["cut"].sum(), texels)
    assert gradient[..., 3].sum() > 0  # the test's straight-through gradient: more alpha, more shade


def test_emission_is_not_shadowed():
    glowing = grey(emissive=Texture.constant([0.3, 0.2, 0.1]))
    asset, (camera, light) = scene(grey(double_sided=True), floor=glowing), below()
    under = floor_distance() < SHADOW - EDGE
    on = render(asset, camera, light, SIZE, shadows=MAPS)[0][under][:, :3]
    torch.testing.assert_close(on, torch.tensor([0.3, 0.2, 0.1]).expand_as(on), rtol=1e-6, atol=1e-6)


def test_a_lit_sphere_does_not_shadow_its_own_lit_side():
    """No acne: on the side facing the light, shadows change nothing (the comparison's offset
    covers the surface's own depths around each point)."""
    asset = Asset(uv_sphere(rings=24, segments=48), [grey()])
    camera = Camera.looking_at(torch.tensor([[0.0, 0.5, 3.5]]), torch.zeros(1, 3), fovy=math.radians(45.0))
    light = PointLight(torch.tensor([[2.0, 2.5, 2.0]]), torch.full((1, 3), 12.0))
    off = render(asset, camera, light, 48)
    on = render(asset, camera, light, 48, shadows=ShadowMapping(layers=2, resolution=32))
    lit = off[0, ..., 0] > 0.2 * off[0, ..., 0].max()
    assert lit.sum() > 300
    assert (on[0][lit] - off[0][lit]).abs().max() <= 1e-6 * off.max()


def test_each_view_has_its_own_light_map():
    """A batch of views under different lights shades each as it shades alone."""
    asset, (camera, light) = scene(grey(double_sided=True)), below()
    lights = PointLight(torch.tensor([[0.0, 0.0, LIGHT], [0.6, 0.0, LIGHT]]), torch.full((2, 3), 16.0))
    cameras = Camera.cat([camera, camera])
    both = render(asset, cameras, lights, SIZE, shadows=MAPS)
    for view in range(2):
        torch.testing.assert_close(both[view:view + 1], render(asset, camera, lights[view], SIZE, shadows=MAPS))
    assert (both[0] - both[1]).abs().max() > 0.1  # the second light moves the shadow


def test_the_floor_gradient_in_the_occluders_alpha_matches_finite_differences():
    """Float64: the floor's radiance depends on the occluder's texels only through its shadow
    (the camera does not see the occluder)."""
    camera, light = below(torch.float64)
    colour = torch.tensor([0.5, 0.5, 0.5], dtype=torch.float64)

    def image(alpha):
        texels = torch.cat([colour.expand(2, 2, 3), alpha[..., None]], dim=-1)
        occluder = Material(kd=Texture(texels), ks=Texture(torch.tensor([[NO_SPECULAR]], dtype=torch.float64)),
                            alpha_mode="BLEND", double_sided=True)
        floor = grey(dtype=torch.float64)
        return render(scene(occluder, floor, dtype=torch.float64), camera, light, 16, shadows=MAPS)

    alpha = torch.tensor([[0.2, 0.4], [0.6, 0.9]], dtype=torch.float64, requires_grad=True)
    gradient, = torch.autograd.grad(image(alpha)[..., 0].sum(), alpha)
    assert (gradient < 0).all()  # more alpha, more shadow, wherever it lies
    assert torch.autograd.gradcheck(image, (alpha,), fast_mode=True, atol=1e-6)


def test_render_shadows_reach_the_reference_the_latent_and_the_scoring_of_a_run():
    mesh = scene(grey()).mesh
    asset = Asset(dataclasses.replace(mesh, t_mat_idx=torch.zeros_like(mesh.t_mat_idx)), [grey(double_sided=True)])
    camera, light = below()
    under = floor_distance() < SHADOW - EDGE
    for shadows in (False, True):
        cfg = config_from_dict({"render": {"resolution": SIZE, "shadows": shadows, "shadow_layers": 2,
                                           "shadow_resolution": 64}})
        reference = run_reference(asset, cfg, moving=False).renderer
        assert isinstance(reference, MeshReference)
        pictures = {"reference": reference.render(camera, light, SIZE, 1),
                    "latent": mesh_latent(asset, asset, cfg, False).render(camera, light, SIZE).detach(),
                    "scoring": scoring_draw(cfg)(asset, camera, light)}
        for name, picture in pictures.items():
            dark = picture[0, ..., 0][under].max() <= 1e-6
            assert dark == shadows, name
    with pytest.raises(ConfigError, match="implicit surface"):  # sphere tracing casts none
        run_reference(dataclasses.replace(asset, field=sphere_field()), cfg, moving=False)
    with pytest.raises(ConfigError, match="relight"):
        config_from_dict({"render": {"shadows": True}, "views": {"relight": True}})
