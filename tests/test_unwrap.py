"""UV atlases from xatlas: charts do not overlap, UVs stay in range, positions stay welded."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.ndimage import binary_dilation
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from lookalike.errors import ConfigError
from lookalike.init import decimate, unwrap
from mesh_factory import icosphere


def _texel_coverage(uv_corners: np.ndarray, size: int, shrink: float = 1e-3) -> np.ndarray:
    """How many triangles cover each texel centre of a ``size``-square grid.

    ``uv_corners [T, 3, 2]`` in [0, 1]; a texel centre counts as inside a triangle when all its
    barycentric coordinates exceed ``shrink`` (so texels on a shared edge are not counted twice).
    """
    corners = uv_corners * size - 0.5                                  # texel-centre coordinates
    lo = np.floor(corners.min(axis=1)).astype(np.int64)               # [T, 2]
    extent = int((np.ceil(corners.max(axis=1)) - lo).max()) + 1
    offsets = np.stack(np.meshgrid(np.arange(extent), np.arange(extent), indexing="ij"), -1).reshape(-1, 2)
    texels = lo[:, None, :] + offsets[None]                            # [T, E^2, 2]
    a, b, c = corners[:, None, 0], corners[:, None, 1], corners[:, None, 2]
    cross = lambda p, q, r: (q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1]) - (q[..., 1] - p[..., 1]) * (r[..., 0] - p[..., 0])
    area = cross(a, b, c)
    w0, w1, w2 = cross(texels, b, c) / area, cross(a, texels, c) / area, cross(a, b, texels) / area
    inside = (w0 > shrink) & (w1 > shrink) & (w2 > shrink) & (np.abs(area) > 0)
    inside &= np.all((texels >= 0) & (texels < size), axis=-1)
    hit = texels[inside]
    return np.bincount(hit[:, 0] * size + hit[:, 1], minlength=size * size).reshape(size, size)


def test_atlas_has_no_overlaps_and_uvs_in_range():
    sphere = icosphere(3)
    mesh = decimate(sphere, 600)
    out = unwrap(mesh, texture_size=256, padding=2)
    assert torch.equal(out.t_pos_idx, mesh.t_pos_idx)
    assert torch.equal(out.v_pos, mesh.v_pos)
    assert len(out.uv) == 1 and out.t_tex_idx.shape == mesh.t_pos_idx.shape
    assert out.v_tex.min() >= 0 and out.v_tex.max() <= 1
    coverage = _texel_coverage(out.v_tex.double().numpy()[out.t_tex_idx.numpy()], 256)
    assert coverage.max() == 1
    assert (coverage > 0).mean() > 0.3                                 # the atlas is not wastefully small


def _charts(t_tex_idx: np.ndarray, count: int) -> np.ndarray:
    """Chart of each triangle: connected components of triangles sharing a UV vertex."""
    rows = np.repeat(t_tex_idx[:, :1], 2, axis=1).ravel()
    graph = coo_matrix((np.ones(len(rows)), (rows, t_tex_idx[:, 1:].ravel())), shape=(count, count))
    return connected_components(graph, directed=False)[1][t_tex_idx[:, 0]]


def test_charts_keep_their_padding_in_texels_of_the_requested_size():
    size, padding = 256, 4
    out = unwrap(decimate(icosphere(4), 1500), texture_size=size, padding=padding)
    uv = out.v_tex.double().numpy()[out.t_tex_idx.numpy()]
    chart = _charts(out.t_tex_idx.numpy(), len(out.v_tex))
    assert len(np.unique(chart)) > 1
    grown = sum(binary_dilation(_texel_coverage(uv[chart == c], size, shrink=-1e-3) > 0,
                                structure=np.ones((3, 3)), iterations=padding - 1)
                for c in np.unique(chart))
    assert grown.max() == 1                                            # charts stay apart after growing


def test_overlap_check_can_fail():
    """The coverage raster sees overlap where there is some: the same triangle twice."""
    uv = np.array([[[0.1, 0.1], [0.9, 0.1], [0.1, 0.9]]] * 2)
    assert _texel_coverage(uv, 64).max() == 2


def test_one_uv_vertex_per_position_and_chart():
    mesh = unwrap(decimate(icosphere(3), 400), texture_size=128, padding=2)
    pairs = np.stack([mesh.t_tex_idx.numpy().ravel(), mesh.t_pos_idx.numpy().ravel()], axis=1)
    pairs = np.unique(pairs, axis=0)
    assert len(np.unique(pairs[:, 0])) == len(pairs)                   # a UV vertex belongs to one position


def test_replaces_existing_uv_sets_and_keeps_materials():
    mesh = decimate(icosphere(3), 300)
    mesh.uv = [(torch.zeros(1, 2), torch.zeros_like(mesh.t_pos_idx))] * 2
    mesh.t_mat_idx = torch.arange(mesh.num_triangles) % 2
    out = unwrap(mesh, texture_size=64, padding=1)
    assert len(out.uv) == 1
    assert torch.equal(out.t_mat_idx, mesh.t_mat_idx)


@pytest.mark.parametrize("size, padding, message", [
    (4, 1, "texture size"), (512.0, 4, "texture size"), (256, -1, "padding"), (256, 64, "padding"),
])
def test_bad_settings_are_refused(size, padding, message):
    with pytest.raises(ConfigError, match=message):
        unwrap(icosphere(1), texture_size=size, padding=padding)


def _tetrahedra(count: int, seed: int = 0):
    """``count`` separate small tetrahedra scattered in a cube: a mesh of many small parts."""
    from lookalike.asset import Mesh

    rng = np.random.default_rng(seed)
    tet = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64) * 0.05
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    v_pos = np.concatenate([tet + rng.uniform(-1, 1, 3) for _ in range(count)])
    t_pos_idx = np.concatenate([faces + 4 * i for i in range(count)])
    return Mesh(v_pos=torch.tensor(v_pos, dtype=torch.float32), t_pos_idx=torch.tensor(t_pos_idx))


def test_many_small_parts_fit_a_small_texture_with_less_padding():
    """20 tetrahedra in 64 texels: their 4-texel padding alone fills the texture at any density
    (an error before), so the gap narrows and every chart still gets a texel of its own."""
    size = 64
    out = unwrap(_tetrahedra(20), texture_size=size, padding=4)
    uv = out.v_tex.double().numpy()[out.t_tex_idx.numpy()]
    assert out.v_tex.min() >= 0 and out.v_tex.max() <= 1
    assert _texel_coverage(uv, size).max() == 1
    chart = _charts(out.t_tex_idx.numpy(), len(out.v_tex))
    assert all(_texel_coverage(uv[chart == c], size, shrink=-1e-3).any() for c in np.unique(chart))


def test_a_mesh_no_padding_fits_is_refused_in_one_line():
    with pytest.raises(ConfigError, match="no UV atlas of 64 texels with 4 texels of padding"):
        unwrap(_tetrahedra(50), texture_size=64, padding=4)
