"""Every compiled kernel against its plain-torch twin: values and gradients (float64)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
import torch
from mesh_factory import bumpy_sphere_clip

import lookalike.render as dr
from lookalike.render.antialias import (
    neighbour_pairs_python,
    outline_walk_python,
    silhouette_edges_python,
)
from lookalike.render.antialias_kernels import outline_crossings
from lookalike.render.barycentrics import (
    barycentrics_python,
    constant_triangle_coefficients,
    pixel_ndc,
    triangle_coefficients,
)
from lookalike.render.interpolate import interpolate_python
from lookalike.render.mipmap import texture_pyramid
from lookalike.render.texture import texture_python
from lookalike.render.window import covered_window


def random_mesh(n_views: int = 2, n_verts: int = 40, n_tris: int = 60):
    pos = torch.randn(n_views, n_verts, 4, dtype=torch.float64)
    pos[..., 3] = pos[..., 3].abs() + 1.0
    pos[..., 2] = pos[..., 2].clamp(-0.9, 0.9)
    return pos, torch.randint(0, n_verts, (n_tris, 3))


def gradients(outputs, inputs, seed: int = 1):
    """Gradients of a fixed random weighting of ``outputs`` with respect to ``inputs``."""
    generator = torch.Generator().manual_seed(seed)
    loss = sum((o * torch.randn(o.shape, generator=generator, dtype=o.dtype)).sum() for o in outputs)
    return torch.autograd.grad(loss, inputs, allow_unused=True, materialize_grads=True)


def test_pixel_barycentrics_match_torch_twin():
    pos, tri = random_mesh()
    pos.requires_grad_(True)
    rast, rast_db = dr.rasterize(None, pos, tri, (18, 22))
    flat = torch.nonzero(rast[..., 3].detach().reshape(-1)).squeeze(1)
    tri_idx = rast[..., 3].detach().reshape(-1)[flat].long() - 1
    uv, db = barycentrics_python(pos, tri, flat // (18 * 22), tri_idx, pixel_ndc(flat, 18, 22, torch.float64), (18, 22))
    torch.testing.assert_close(rast.reshape(-1, 4)[flat, :2], uv)
    torch.testing.assert_close(rast_db.reshape(-1, 4)[flat], db)
    fast = gradients([rast.reshape(-1, 4)[flat, :2], rast_db.reshape(-1, 4)[flat]], pos)
    slow = gradients([uv, db], pos)
    torch.testing.assert_close(fast, slow)


@pytest.mark.parametrize("dtype", [torch.float64, torch.float32])
def test_constant_triangle_coefficients_match_the_differentiable_ones(dtype):
    pos, tri = random_mesh(n_views=3)
    pos = pos.to(dtype)
    slow = triangle_coefficients(pos, tri)
    fast = constant_triangle_coefficients(pos, tri)
    assert fast.shape == (3, 60, 9) and fast.dtype == dtype
    torch.testing.assert_close(fast, slow)
    with torch.no_grad():                   # a reference's render takes the compiled coefficients
        rast_fast, db_fast = dr.rasterize(None, pos, tri, (18, 22))
    tri_id = rast_fast[..., 3].numpy().astype(np.int32)
    shown = np.zeros((3, 60), dtype=bool)
    for b in range(3):
        shown[b, tri_id[b][tri_id[b] > 0] - 1] = True
    assert 0 < shown.sum() < shown.size
    some = constant_triangle_coefficients(pos, tri, torch.from_numpy(tri_id))      # only the rows pixels look up
    torch.testing.assert_close(some[torch.from_numpy(shown)], slow[torch.from_numpy(shown)])
    assert not some[torch.from_numpy(~shown)].any()
    rast_slow, db_slow = dr.rasterize(None, pos.clone().requires_grad_(True), tri, (18, 22))
    torch.testing.assert_close(rast_fast, rast_slow.detach())
    torch.testing.assert_close(db_fast, db_slow.detach())


@pytest.mark.parametrize(("shared_attr", "diff_attrs"), [(True, None), (True, "all"), (False, [2, 0])])
def test_interpolate_matches_torch_twin(shared_attr, diff_attrs):
    pos, tri = random_mesh()
    rast, rast_db = dr.rasterize(None, pos, tri, (16, 20))
    rast, rast_db = rast.requires_grad_(True), rast_db.requires_grad_(True)
    attr = torch.randn(*(() if shared_attr else (2,)), 40, 3, dtype=torch.float64, requires_grad=True)
    fast = dr.interpolate(attr, rast, tri, rast_db, diff_attrs=diff_attrs)
    slow = interpolate_python(attr, rast, tri, rast_db, diff_attrs=diff_attrs)
    torch.testing.assert_close(fast, slow)
    torch.testing.assert_close(gradients(fast, (attr, rast, rast_db)), gradients(slow, (attr, rast, rast_db)))


@pytest.mark.parametrize(("shared_attr", "diff_attrs"), [(True, None), (True, "all"), (False, [1])])
def test_interpolate_at_pixels_matches_torch_twin(shared_attr, diff_attrs):
    """A shuffled list of some covered pixels (and background ones, which read 0): the rows of
    the twin's images, with the same gradients (the other pixels' never touched)."""
    pos, tri = random_mesh()
    rast, rast_db = dr.rasterize(None, pos, tri, (16, 20))
    rast, rast_db = rast.requires_grad_(True), rast_db.requires_grad_(True)
    attr = torch.randn(*(() if shared_attr else (2,)), 40, 3, dtype=torch.float64, requires_grad=True)
    generator = torch.Generator().manual_seed(4)
    pixels = torch.randperm(2 * 16 * 20, generator=generator)[:300]
    covered = rast[..., 3].detach().reshape(-1)[pixels] > 0
    assert covered.sum() > 50 and (~covered).any()
    fast = dr.interpolate_at(attr, rast, tri, pixels, rast_db, diff_attrs=diff_attrs)
    slow = [image.reshape(2 * 16 * 20, image.shape[-1])[pixels]
            for image in interpolate_python(attr, rast, tri, rast_db, diff_attrs=diff_attrs)]
    torch.testing.assert_close(fast, slow)
    fast_grads = gradients(fast, (attr, rast, rast_db))
    torch.testing.assert_close(fast_grads, gradients(slow, (attr, rast, rast_db)))
    assert fast_grads[1].abs().sum() > 0


def test_interpolate_at_rejects_pixels_outside_the_images():
    pos, tri = random_mesh()
    rast, _ = dr.rasterize(None, pos, tri, (16, 20))
    with pytest.raises(ValueError, match="outside"):
        dr.interpolate_at(torch.randn(40, 3, dtype=torch.float64), rast, tri, torch.tensor([2 * 16 * 20]))


@pytest.mark.parametrize(
    ("filter_mode", "boundary_mode", "per_view", "user_mips"),
    list(itertools.product(["nearest", "linear", "linear-mipmap-nearest", "linear-mipmap-linear"], ["wrap", "clamp", "zero"], [False, True], [False, True])),
)
def test_texture_matches_torch_twin(filter_mode, boundary_mode, per_view, user_mips):
    tex = torch.rand(2 if per_view else 1, 6, 8, 3, dtype=torch.float64, requires_grad=True)
    mips = [m.detach().clone().requires_grad_(True) for m in dr.texture_construct_mip(tex)] if user_mips else None
    uv = (torch.rand(2, 5, 4, 2, dtype=torch.float64) * 1.4 - 0.2).requires_grad_(True)
    scale = torch.exp2(torch.rand(2, 5, 4, 1, dtype=torch.float64) * 3.5) / 8
    uv_da = (torch.randn(2, 5, 4, 4, dtype=torch.float64) * scale).requires_grad_(True)
    bias = (torch.rand(2, 5, 4, dtype=torch.float64) - 0.5).requires_grad_(True)
    inputs = [tex, uv, uv_da, bias, *(mips or [])]
    args = dict(mip=mips, filter_mode=filter_mode, boundary_mode=boundary_mode)
    fast = dr.texture(tex, uv, uv_da, bias, **args)
    slow = texture_python(tex, uv, uv_da, bias, **args)
    torch.testing.assert_close(fast, slow)
    torch.testing.assert_close(gradients([fast], inputs), gradients([slow], inputs))


def test_compiled_pyramid_matches_area_mips():
    tex = torch.rand(2, 12, 7, 3, dtype=torch.float64, requires_grad=True)
    pyramid = texture_pyramid(tex)
    levels = [tex, *dr.texture_construct_mip(tex)]
    expected = torch.cat([level.reshape(-1, 3) for level in levels])
    torch.testing.assert_close(pyramid.table, expected)
    assert pyramid.heights.tolist() == [12, 6, 3, 1] and pyramid.widths.tolist() == [7, 3, 1, 1]
    torch.testing.assert_close(gradients([pyramid.table], tex), gradients([expected], tex))


def test_a_prebuilt_pyramid_serves_lookups_as_a_pyramid_built_per_call():
    tex = torch.rand(1, 16, 8, 3, dtype=torch.float64, requires_grad=True)
    uv = torch.rand(2, 5, 4, 2, dtype=torch.float64, requires_grad=True)
    uv_da = (torch.randn(2, 5, 4, 4, dtype=torch.float64) / 6).requires_grad_(True)
    pyramid = dr.texture_pyramid(tex)
    shared = dr.texture(tex, uv, uv_da, mip=pyramid)
    per_call = dr.texture(tex, uv, uv_da)
    twin = texture_python(tex, uv, uv_da, mip=pyramid)
    torch.testing.assert_close(shared, per_call)
    torch.testing.assert_close(twin, per_call)
    inputs = [tex, uv, uv_da]
    torch.testing.assert_close(gradients([shared], inputs), gradients([per_call], inputs))
    with pytest.raises(ValueError, match="pyramid"):
        dr.texture(tex[..., :2], uv, uv_da, mip=pyramid)


@pytest.mark.parametrize(("dtype", "open_border"), [(torch.float64, False), (torch.float32, False),
                                                     (torch.float64, True)])
def test_outline_kernel_matches_torch_twin(dtype, open_border):
    """The compiled walk, which tests the edges it crosses for silhouettes as it goes, finds the
    same outlines as the twin's walk over ``silhouette_edges_python`` of every edge (in
    float64, as the kernel): on the closed bumpy sphere, and with five triangles cut out, where
    every border edge is a silhouette."""
    pos, tri = bumpy_sphere_clip()
    pos = pos.to(dtype)
    tri = tri[:-5] if open_border else tri
    height, width = 40, 52
    rast, _ = dr.rasterize(None, pos, tri, (height, width))
    topology = dr.antialias_construct_topology_hash(tri)
    assert (topology.opposite < 0).any() == open_border
    silhouette = silhouette_edges_python(pos.double(), tri, topology.opposite)
    assert 0 < silhouette.sum() < silhouette.numel() // 2    # some edges are outlines, most are not
    fast = outline_crossings(rast.numpy(), pos[..., [0, 1, 3]].double().contiguous().numpy(), tri.numpy(),
                             topology.neighbour.numpy(), topology.opposite.numpy())
    front, other, start_tri, horizontal = neighbour_pairs_python(rast[..., 3].long(), rast[..., 2])
    assert torch.equal(rast[..., 3].reshape(-1)[front].long() - 1, start_tri)
    edge_tri, edge = outline_walk_python(pos, tri, topology.neighbour, silhouette, front, other, start_tri,
                                         height, width)
    hit = edge >= 0
    slow = (front[hit], other[hit], horizontal[hit], edge_tri[hit], edge[hit])
    assert sorted(zip(*(a.tolist() for a in fast))) == sorted(zip(*(a.tolist() for a in slow)))
    walked = (edge_tri[hit] != start_tri[hit]).sum().item()
    assert hit.sum() > 100 and walked > 20 and (~hit).sum() > 100  # outlines found beyond the first triangle
    assert silhouette[front[hit] // (height * width), edge_tri[hit], edge[hit]].all()


def test_antialiasing_a_window_equals_the_window_of_the_antialiased_frame():
    """Of the bumpy sphere, rasterized at 48 x 60: the compiled outline search and its twin
    agree on a window of the frame (its pixel centres the frame's), and antialiasing that
    window (with ``covered_window``'s margin) gives the frame's antialiased pixels there, bit
    for bit, with the same position gradients."""
    pos, tri = bumpy_sphere_clip()
    pos = (pos * torch.tensor([0.5, 0.6, 1.0, 1.0], dtype=pos.dtype)).requires_grad_()
    height, width = 48, 60
    rast, _ = dr.rasterize(None, pos, tri, (height, width))
    window = covered_window(rast[..., 3], 2)
    assert window.height < height and window.width < width
    topology = dr.antialias_construct_topology_hash(tri)
    part = window.crop(rast).contiguous()
    fast = outline_crossings(part.detach().numpy(), pos[..., [0, 1, 3]].detach().contiguous().numpy(), tri.numpy(),
                             topology.neighbour.numpy(), topology.opposite.numpy(), window)
    front, other, start_tri, horizontal = neighbour_pairs_python(part[..., 3].long(), part[..., 2])
    silhouette = silhouette_edges_python(pos.detach(), tri, topology.opposite)
    edge_tri, edge = outline_walk_python(pos, tri, topology.neighbour, silhouette, front, other, start_tri,
                                         window.height, window.width, window)
    hit = edge >= 0
    slow = (front[hit], other[hit], horizontal[hit], edge_tri[hit], edge[hit])
    assert hit.sum() > 50 and sorted(zip(*(a.tolist() for a in fast))) == sorted(zip(*(a.tolist() for a in slow)))
    colour = torch.rand(*rast.shape[:3], 3, dtype=pos.dtype, generator=torch.Generator().manual_seed(2))
    whole = dr.antialias(colour, rast, pos, tri, topology)
    windowed = dr.antialias(window.crop(colour).contiguous(), part, pos, tri, topology, window=window)
    assert torch.equal(window.crop(whole), windowed)
    weights = torch.rand_like(colour)
    full_grad, = torch.autograd.grad((whole * weights).sum(), pos)
    part_grad, = torch.autograd.grad((windowed * window.crop(weights)).sum(), pos)
    assert torch.equal(full_grad, part_grad)
