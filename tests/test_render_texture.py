"""Texture filtering: values, boundary modes, mip pyramids, gradients against finite
differences in every filter mode, and the grazing-plane mipmapping test."""

from __future__ import annotations

import math

import pytest
import torch
import torch.nn.functional as F
from torch.autograd import gradcheck

import lookalike.render as dr
from lookalike.render.mipmap import footprint_level, mip_sizes


def texel_centre_uv(row: int, col: int, height: int, width: int) -> torch.Tensor:
    return torch.tensor([(col + 0.5) / width, (row + 0.5) / height], dtype=torch.float64)


def test_bilinear_hits_texel_centres_and_nearest_picks_containing_texel():
    tex = torch.rand(1, 4, 5, 3, dtype=torch.float64)
    uv = torch.stack([texel_centre_uv(r, c, 4, 5) for r in range(4) for c in range(5)]).reshape(1, 4, 5, 2)
    torch.testing.assert_close(dr.texture(tex, uv, filter_mode="linear"), tex)
    shifted = uv + torch.tensor([0.45 / 5, -0.45 / 4], dtype=torch.float64)
    torch.testing.assert_close(dr.texture(tex, shifted, filter_mode="nearest"), tex)
    # half way between texels (0, 0) and (0, 1): their mean
    mid = ((texel_centre_uv(0, 0, 4, 5) + texel_centre_uv(0, 1, 4, 5)) / 2).reshape(1, 1, 1, 2)
    torch.testing.assert_close(dr.texture(tex, mid)[0, 0, 0], (tex[0, 0, 0] + tex[0, 0, 1]) / 2)


@pytest.mark.parametrize(
    ("boundary_mode", "expected"),
    [("wrap", lambda t: (t[0, 0] + t[0, -1]) / 2), ("clamp", lambda t: t[0, 0]), ("zero", lambda t: t[0, 0] / 2)],
)
def test_boundary_modes(boundary_mode, expected):
    tex = torch.rand(1, 3, 4, 2, dtype=torch.float64)
    uv = torch.tensor([0.0, 0.5 / 3], dtype=torch.float64).reshape(1, 1, 1, 2)  # left border of row 0
    torch.testing.assert_close(dr.texture(tex, uv, boundary_mode=boundary_mode)[0, 0, 0], expected(tex[0]))


def test_mip_pyramid_is_a_box_filter_down_to_one_texel():
    tex = torch.rand(2, 8, 4, 3, dtype=torch.float64)
    mips = dr.texture_construct_mip(tex)
    assert [m.shape[1:3] for m in mips] == [(4, 2), (2, 1), (1, 1)]
    torch.testing.assert_close(mips[0], tex.reshape(2, 4, 2, 2, 2, 3).mean((2, 4)))
    torch.testing.assert_close(mips[-1][:, 0, 0], tex.mean((1, 2)))
    assert mip_sizes(5, 3, max_mip_level=1) == [(2, 1)]


def test_footprint_level_is_log2_of_the_largest_singular_value():
    uv_da = torch.randn(50, 4, dtype=torch.float64) * 0.05
    jac = torch.stack([uv_da[:, 0:2] * 64, uv_da[:, 2:4] * 32], 1)  # rows ds, dt
    expected = torch.log2(torch.linalg.svdvals(jac)[:, 0])
    torch.testing.assert_close(footprint_level(uv_da, 32, 64), expected)


def _lookup_inputs(n: int = 3):
    """uv spread over and beyond [0, 1], footprints spanning levels 0..3 of a 6x8 texture."""
    uv = (torch.rand(1, n, n, 2, dtype=torch.float64) * 1.4 - 0.2).requires_grad_(True)
    scale = torch.exp2(torch.rand(1, n, n, 1, dtype=torch.float64) * 3.5) / 8
    uv_da = (torch.randn(1, n, n, 4, dtype=torch.float64) * scale).requires_grad_(True)
    bias = (torch.rand(1, n, n, dtype=torch.float64) - 0.5).requires_grad_(True)
    tex = torch.rand(1, 6, 8, 2, dtype=torch.float64, requires_grad=True)
    return tex, uv, uv_da, bias


@pytest.mark.parametrize("boundary_mode", ["wrap", "clamp", "zero"])
@pytest.mark.parametrize("filter_mode", ["nearest", "linear", "linear-mipmap-nearest", "linear-mipmap-linear"])
def test_texture_gradients(filter_mode, boundary_mode):
    tex, uv, uv_da, bias = _lookup_inputs()
    if filter_mode == "nearest":
        inputs, run = (tex,), lambda t: dr.texture(t, uv, filter_mode="nearest", boundary_mode=boundary_mode)
    elif filter_mode == "linear":
        inputs, run = (tex, uv), lambda t, u: dr.texture(t, u, boundary_mode=boundary_mode)
    else:
        inputs = (tex, uv, uv_da, bias)
        run = lambda t, u, d, b: dr.texture(t, u, d, b, filter_mode=filter_mode, boundary_mode=boundary_mode)  # noqa: E731
    assert gradcheck(run, inputs)


def test_user_mip_levels_each_get_their_own_gradient():
    tex, uv, uv_da, bias = _lookup_inputs(4)
    mips = [m.detach().clone().requires_grad_(True) for m in dr.texture_construct_mip(tex)]
    assert gradcheck(lambda t, m1, m2, m3, d: dr.texture(t, uv, d, mip=[m1, m2, m3]), (tex, *mips, uv_da))
    out = dr.texture(tex, uv, uv_da, mip=mips)
    out.sum().backward()
    assert all(m.grad.abs().sum() > 0 for m in mips[:2])
    # the same pyramid given or built gives the same values
    torch.testing.assert_close(out, dr.texture(tex, uv, uv_da))


def test_max_mip_level_and_bias_choose_levels():
    tex = torch.zeros(1, 4, 4, 1, dtype=torch.float64)
    mips = [torch.full((1, 2, 2, 1), 1.0, dtype=torch.float64), torch.full((1, 1, 1, 1), 2.0, dtype=torch.float64)]
    uv = torch.full((1, 1, 1, 2), 0.3, dtype=torch.float64)
    level = lambda b, **kw: dr.texture(tex, uv, mip_level_bias=torch.tensor([[[b]]], dtype=torch.float64), mip=mips, **kw)  # noqa: E731
    assert level(1.25).item() == pytest.approx(1.25)
    assert level(5.0).item() == pytest.approx(2.0)
    assert level(5.0, max_mip_level=1).item() == pytest.approx(1.0)
    assert level(1.4, filter_mode="linear-mipmap-nearest").item() == pytest.approx(1.0)
    with pytest.raises(ValueError, match="uv_da or mip_level_bias"):
        dr.texture(tex, uv, filter_mode="linear-mipmap-linear")


def test_grazing_plane_trilinear_is_close_to_supersampled_bilinear():
    """A checkerboard floor seen at a grazing angle: 1 sample per pixel with trilinear
    filtering approaches a 16x supersampled bilinear render; plain bilinear at 1 spp aliases."""
    checks = (torch.arange(64)[:, None] // 8 + torch.arange(64)[None, :] // 8) % 2
    tex = checks.float()[None, :, :, None].repeat(1, 1, 1, 3)
    f, near, far = 1.0 / math.tan(0.5), 0.1, 100.0
    proj = torch.tensor(
        [[f, 0, 0, 0], [0, f, 0, 0], [0, 0, (far + near) / (near - far), 2 * far * near / (near - far)], [0, 0, -1, 0]]
    )
    floor = torch.tensor([[-6.0, -1.0, -1.0, 1.0], [6.0, -1.0, -1.0, 1.0], [-6.0, -1.0, -40.0, 1.0], [6.0, -1.0, -40.0, 1.0]])
    pos = (floor @ proj.T)[None]
    tri = torch.tensor([[0, 1, 2], [2, 1, 3]], dtype=torch.int32)
    uv = torch.tensor([[0.0, 0.0], [2.0, 0.0], [0.0, 5.0], [2.0, 5.0]])

    def render(size: int, **texture_args) -> torch.Tensor:
        rast, rast_db = dr.rasterize(None, pos, tri, (size, size))
        texc, texd = dr.interpolate(uv, rast, tri, rast_db, diff_attrs="all")
        color = dr.texture(tex, texc, texd if texture_args.pop("mipmapped") else None, **texture_args)
        return torch.where(rast[..., 3:] > 0, color, 0.0)

    truth = F.avg_pool2d(render(256, mipmapped=False).permute(0, 3, 1, 2), 4).permute(0, 2, 3, 1)
    trilinear = render(64, mipmapped=True, filter_mode="linear-mipmap-linear")
    aliased = render(64, mipmapped=False, filter_mode="linear")
    floor_rows = slice(0, 32)  # the floor fills the lower half (row 0 = bottom)
    error = (trilinear - truth)[:, floor_rows].abs().mean()
    aliased_error = (aliased - truth)[:, floor_rows].abs().mean()
    assert error < 0.07 and error < 0.7 * aliased_error
    # locally averaged (4x4 pixels), trilinear keeps the brightness; aliasing does not
    pool = lambda img: F.avg_pool2d(img[:, floor_rows].permute(0, 3, 1, 2), 4)  # noqa: E731
    pooled_error = (pool(trilinear) - pool(truth)).abs().mean()
    assert pooled_error < 0.025 and pooled_error < 0.5 * (pool(aliased) - pool(truth)).abs().mean()
