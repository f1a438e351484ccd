"""Textures held as resolution levels (``lookalike.fit.texture_pyramid``), constant channels of
untextured inputs, and the map-noise figure (``lookalike.report.map_noise``)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from lookalike.asset import Asset, Material, Mesh, Texture
from lookalike.fit.texture_pyramid import (
    TexturePyramid,
    compose,
    compose_python,
    level_sizes,
    upsample,
)
from lookalike.fit.textured_mesh import TexturedMesh, constant_channels
from lookalike.report.map_noise import laplacian_residual_rms, map_noise


def test_level_sizes_halve_rounding_up_and_stop_at_small_sides():
    assert level_sizes(1024, 1024, 4) == [(1024, 1024), (512, 512), (256, 256), (128, 128)]
    assert level_sizes(10, 7, 4) == [(10, 7), (5, 4), (3, 2)]
    assert level_sizes(1, 1, 4) == [(1, 1)]


def test_a_small_texture_s_coarsest_level_takes_the_scales_of_the_levels_it_lacks():
    assert TexturePyramid(torch.rand(1, 1, 3), (0.25, 0.25, 0.5)).scales == (1.0,)
    assert TexturePyramid(torch.rand(4, 4, 3), (0.25, 0.25, 0.25, 0.25)).scales == (0.25, 0.75)


def test_the_pyramid_starts_as_the_given_texture_and_sums_its_levels():
    texture = torch.rand(16, 12, 3)
    pyramid = TexturePyramid(texture, (0.25, 0.5, 1.0))
    assert torch.allclose(pyramid(), texture, atol=1e-6)
    with torch.no_grad():
        for level in pyramid.levels:
            level.normal_()
    expected = compose_python([p.detach() for p in pyramid.levels], pyramid.scales)
    assert torch.allclose(pyramid(), expected, atol=1e-6)


def test_upsampling_keeps_a_constant_and_aligns_texel_centres():
    assert torch.allclose(upsample(torch.full((3, 5, 2), 0.7), (6, 10)), torch.full((6, 10, 2), 0.7))
    ramp = torch.arange(4.0).reshape(1, 4, 1)  # texel centres at x = 0.5, 1.5, ... of a 4-wide image
    fine = upsample(ramp, (1, 8))[0, :, 0]
    # fine centres at 0.25, 0.75, ... in coarse texel units; linear between centres, clamped at the edges
    assert fine.tolist() == pytest.approx([0.0, 0.25, 0.75, 1.25, 1.75, 2.25, 2.75, 3.0])


@pytest.mark.parametrize("size", [(10, 7), (33, 64), (5, 5), (3, 2)])
def test_the_compiled_sum_matches_its_torch_twin_in_value_gradient_and_projection(size):
    torch.manual_seed(0)
    sizes = level_sizes(*size, 4)
    scales = (0.25, 0.5, 0.75, 1.0)[: len(sizes)]
    levels = [4 * torch.randn(h, w, 3) for h, w in sizes]
    low, high = torch.tensor([0.0, -0.5, -math.inf]), 0.8
    fast = [level.clone().requires_grad_() for level in levels]
    slow = [level.clone().requires_grad_() for level in levels]
    out_fast, out_slow = compose(fast, scales, low, high), compose_python(slow, scales, low, high)
    torch.testing.assert_close(out_fast, out_slow)
    assert out_fast.max() == 0.8 and out_fast[..., 2].min() < -0.5  # the bounds were active
    torch.testing.assert_close(fast[0].detach(), slow[0].detach())  # the same excess taken off the finest level
    weights = torch.randn_like(out_fast)
    for a, b in zip(torch.autograd.grad(out_fast, fast, weights), torch.autograd.grad(out_slow, slow, weights)):
        torch.testing.assert_close(a, b)


def test_the_compiled_sum_s_gradient_agrees_with_finite_differences():
    levels = [torch.randn(h, w, 2, dtype=torch.float64, requires_grad=True) for h, w in level_sizes(9, 7, 3)]
    assert torch.autograd.gradcheck(lambda *ls: compose(list(ls), (0.5, 0.25, 1.0)), levels)


def test_a_coarse_level_spreads_one_texel_s_gradient_and_the_fine_level_is_scaled():
    pyramid = TexturePyramid(torch.zeros(8, 8, 1), (0.25, 1.0))
    pyramid()[3, 3, 0].backward()
    fine, coarse = (level.grad[..., 0] for level in pyramid.levels)
    assert fine[3, 3] == pytest.approx(0.25) and fine.count_nonzero() == 1
    assert coarse.sum() == pytest.approx(1.0) and coarse.count_nonzero() > 1  # bilinear weights


def test_reading_takes_the_excess_off_the_finest_level_only():
    pyramid = TexturePyramid(torch.full((8, 8, 1), 0.5), (0.5, 1.0), low=0.0, high=1.0)
    with torch.no_grad():
        pyramid.levels[1][0, 0, 0] = 2.0
    coarse = pyramid.levels[1].detach().clone()
    unbounded = compose_python([level.detach() for level in pyramid.levels], pyramid.scales)
    assert unbounded.max() > 1.5
    texture = pyramid()
    torch.testing.assert_close(texture, unbounded.clamp(0.0, 1.0))
    assert torch.equal(pyramid.levels[1].detach(), coarse)
    torch.testing.assert_close(compose_python([level.detach() for level in pyramid.levels], pyramid.scales), texture.detach())


def test_the_projection_passes_gradients_to_every_level_as_the_sum_does():
    pyramid = TexturePyramid(torch.full((8, 8, 1), 2.0), (0.5, 1.0), low=0.0, high=1.0)
    pyramid()[3, 3, 0].backward()
    unbounded = TexturePyramid(torch.full((8, 8, 1), 2.0), (0.5, 1.0))
    unbounded()[3, 3, 0].backward()
    for bounded_level, level in zip(pyramid.levels, unbounded.levels):
        torch.testing.assert_close(bounded_level.grad, level.grad)


def scan_like(colour=(0.75, 0.72, 0.68, 1.0), textured: bool = False) -> Asset:
    mesh = Mesh(v_pos=torch.tensor([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), t_pos_idx=torch.tensor([[0, 1, 2]]),
                uv=[(torch.tensor([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), torch.tensor([[0, 1, 2]]))])
    kd = Texture(torch.rand(4, 4, 4)) if textured else Texture.constant(colour)
    ks = Texture(torch.rand(4, 4, 3)) if textured else Texture.constant((0.0, 0.45, 0.0))
    return Asset(mesh=mesh, materials=[Material(kd=kd, ks=ks), Material(kd=Texture.constant(colour))])


def test_constant_channels_are_those_one_value_holds_everywhere():
    assert constant_channels(scan_like()) == {"kd", "ks"}
    assert constant_channels(scan_like(textured=True)) == set()
    other = scan_like()
    other.materials[1] = Material(kd=Texture.constant((0.1, 0.2, 0.3, 1.0)))
    assert constant_channels(other) == {"ks"}


def test_a_constant_channel_is_one_trainable_value():
    start = scan_like(textured=True)
    start.materials = start.materials[:1]
    latent = TexturedMesh.from_asset(start, torch.zeros(3), 1.0, limits=TexturedMesh(
        start.mesh, torch.rand(2, 2, 3), torch.rand(2, 2, 3), torch.tensor([0.0, 0, 1]).expand(2, 2, 3),
        torch.zeros(3), 1.0).limits, msaa=1, train_alpha=False, constant=frozenset({"kd"}))
    assert latent.kd().shape == (1, 1, 3) and latent.ks().shape == (4, 4, 3)
    assert torch.allclose(latent.kd().detach()[0, 0], start.materials[0].kd.data[..., :3].reshape(-1, 3).mean(0))


def test_the_noise_figure_measures_grain_inside_the_charts_only():
    rng = np.random.default_rng(0)
    covered = np.zeros((64, 64), bool)
    covered[8:56, 8:56] = True
    smooth = np.broadcast_to(np.linspace(0, 1, 64)[None, :, None], (64, 64, 3))
    assert laplacian_residual_rms(smooth, covered) == pytest.approx(0.0, abs=1e-9)
    noisy = smooth + rng.normal(scale=0.1, size=smooth.shape) * covered[..., None]
    assert laplacian_residual_rms(noisy, covered) == pytest.approx(0.1 * np.sqrt(1.25), rel=0.05)
    outside = smooth + rng.normal(scale=0.1, size=smooth.shape) * ~covered[..., None]
    assert laplacian_residual_rms(outside, covered) < 0.02  # only the chart's border texels see it


def test_map_noise_of_an_asset_reads_its_textures_through_its_uvs():
    mesh = Mesh(v_pos=torch.tensor([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]),
                t_pos_idx=torch.tensor([[0, 1, 2], [2, 1, 3]]),
                uv=[(torch.tensor([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]), torch.tensor([[0, 1, 2], [2, 1, 3]]))])
    grain = torch.from_numpy(np.random.default_rng(1).normal(0.5, 0.05, size=(32, 32, 4)).astype(np.float32))
    noisy = map_noise(Asset(mesh=mesh, materials=[Material(kd=Texture(grain))]))
    flat = map_noise(Asset(mesh=mesh, materials=[Material()]))
    assert noisy["base_color"] == pytest.approx(0.05 * np.sqrt(1.25), rel=0.1)
    assert flat == {"base_color": 0.0, "specular": 0.0, "normal": 0.0}
