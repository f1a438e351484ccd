"""A captured view lit again (``lookalike.shading.relight``) is the picture ``render`` draws, and
a pool of captured views relights each drawn view (``ViewPool(relight=...)``)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from test_pipeline import light_at, uv_sphere

from lookalike.asset import Asset, Material, Texture
from lookalike.fit.reference import MeshReference
from lookalike.fit.training_views import ViewPool, light_sampler, view_sampler
from lookalike.shading import Camera, pipeline, render
from lookalike.shading.relight import capture_view


def bumpy_textured_sphere() -> Asset:
    """A textured sphere with a wavy normal map, specular and emission, seen with silhouettes."""
    generator = torch.Generator().manual_seed(5)
    texels = torch.rand(32, 32, 4, generator=generator)
    texels[..., 3] = 1.0
    u = torch.linspace(0, 8 * math.pi, 32)
    tilt = 0.4 * torch.sin(u)[None, :].expand(32, 32)
    normal = torch.stack([tilt, torch.zeros_like(tilt), torch.ones_like(tilt)], dim=-1)
    material = Material(kd=Texture(texels), ks=Texture.constant([0.0, 0.35, 0.3]),
                        normal=Texture(torch.nn.functional.normalize(normal, dim=-1)),
                        emissive=Texture.constant([0.02, 0.01, 0.0]))
    return Asset(uv_sphere(1.0, 24, 48), [material])


def oblique_camera() -> Camera:
    return Camera.looking_at(torch.tensor([[1.5, 1.0, 2.5]]), torch.zeros(1, 3), fovy=math.radians(50),
                             near=0.5, far=20.0)


@pytest.mark.parametrize("horizon", [False, True])
def test_a_captured_view_lit_again_is_what_render_draws(horizon):
    asset, camera = bumpy_textured_sphere(), oblique_camera()
    captured = capture_view(asset, camera, 40, spp=2, dtype=torch.float32)
    for position in ([2.0, 2.0, 2.0], [-2.5, 0.5, 1.0]):
        light = light_at(position, 15.0)
        light.horizon = torch.tensor([horizon])
        expected = render(asset, camera, light, 40, spp=2)
        assert torch.allclose(captured.light(light), expected, atol=1e-5)
    half = capture_view(asset, camera, 40, spp=2)  # float16 storage
    relit = half.light(light)
    assert torch.allclose(relit, expected, atol=1e-3, rtol=3e-3)
    assert (relit - expected).abs().mean() < 1e-3 * expected.abs().mean() + 1e-4
    assert half.nbytes < 0.7 * captured.nbytes


def test_the_outline_blend_is_kept_with_the_capture():
    """The silhouette pixels of the relit image carry the analytic antialiasing: a white
    sphere's edge pixels are fractional, as render's are."""
    asset, camera = Asset(uv_sphere(1.0, 24, 48), [Material()]), oblique_camera()
    image = capture_view(asset, camera, 32, spp=1, dtype=torch.float32).light(light_at([0.0, 0.0, 4.0], 9.0))
    alpha = image[0, ..., 3]
    assert ((alpha > 0.05) & (alpha < 0.95)).sum() > 20
    assert torch.allclose(image, render(asset, camera, light_at([0.0, 0.0, 4.0], 9.0), 32), atol=1e-5)


def test_a_relit_pool_draws_fresh_lights_and_renders_them():
    asset = bumpy_textured_sphere()
    reference = MeshReference(asset)
    centre, radius = reference.bounding_sphere()
    pool = ViewPool(reference, view_sampler(centre, radius), 3, seed=1, refresh_every=2, resolution=24, spp=2,
                    relight=light_sampler(centre, 0.5))
    rng = np.random.default_rng(0)
    lights = []
    for _ in range(6):
        batch = pool.sample(rng, 2)
        expected = torch.cat([render(asset, batch.camera[k], batch.light[k], 24, spp=2) for k in range(2)])
        assert torch.allclose(batch.target, expected, atol=1e-3, rtol=3e-3)
        lights.append(batch.light.position)
    assert len({tuple(p[0].tolist()) for p in lights}) == 6           # a new light at every draw
    assert pool.nbytes > 0
    again = ViewPool(reference, view_sampler(centre, radius), 3, seed=1, refresh_every=2, resolution=24, spp=2,
                     relight=light_sampler(centre, 0.5))
    again.load_state_dict(pool.state_dict())
    one, other = pool.sample(np.random.default_rng(7), 2), again.sample(np.random.default_rng(7), 2)
    assert torch.equal(one.target, other.target) and torch.equal(one.light.position, other.light.position)


def test_capture_takes_one_camera():
    with pytest.raises(ValueError, match="one camera"):
        capture_view(bumpy_textured_sphere(), Camera.cat([oblique_camera(), oblique_camera()]), 16)


def test_a_fixed_asset_shares_its_texture_stacks_across_renders(monkeypatch):
    """A reference's material stacks and mip pyramids are built at its first render and reused
    by the next ones, which draw what a plain render draws; above the byte bound each render
    builds its own."""
    asset, camera = bumpy_textured_sphere(), oblique_camera()
    fixed = pipeline.FixedAsset.of(asset)
    stacks = []
    for position in ([2.0, 2.0, 2.0], [-2.5, 0.5, 1.0]):
        light = light_at(position, 15.0)
        torch.testing.assert_close(render(fixed, camera, light, 40, spp=2), render(asset, camera, light, 40, spp=2))
        stacks.append(list(fixed.sampler._stacks.values()))
    assert len(stacks[0]) == 1 and stacks[0][0] is stacks[1][0] and stacks[1][0].mips is not None
    maps = 32 * 32 * 4 + 32 * 32 * 3 + 3 + 3   # base colour, normal map, constant specular and emission
    assert pipeline.texel_bytes(asset.materials) == 4 * maps

    monkeypatch.setattr(pipeline, "SHARED_SAMPLER_TEXEL_BYTES", 4 * maps - 1)
    assert pipeline.FixedAsset.of(asset).sampler is None
