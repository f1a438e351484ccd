"""Texture-space rasterisation, bilinear sampling, dilation, and merging materials into one atlas."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from io_factory import two_material_asset
from lookalike.asset.frames import our_corner_frame, texel_frames
from lookalike.asset.uv_raster import dilate, rasterize_uv, sample_bilinear
from lookalike.init.atlas import merge_materials


def naive_rasterize(uv, height, width):
    covered = {}
    for f, tri in enumerate(uv.tolist()):
        (ax, ay), (bx, by), (cx, cy) = [(u * width - 0.5, v * height - 0.5) for u, v in tri]
        area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
        if area == 0:
            continue
        for row in range(-2 * height, 3 * height):
            for col in range(-2 * width, 3 * width):
                l0 = ((cx - bx) * (row - by) - (cy - by) * (col - bx)) / area
                l1 = ((ax - cx) * (row - cy) - (ay - cy) * (col - cx)) / area
                l2 = 1 - l0 - l1
                if min(l0, l1, l2) >= -1e-9:
                    covered[(row % height, col % width, f)] = (l0, l1, l2)
    return covered


def test_rasterize_uv_matches_naive_loop():
    g = np.random.default_rng(3)
    uv = g.uniform(0, 1, size=(6, 3, 2))
    uv[5] = [[0.1, 0.2], [0.1, 0.2], [0.7, 0.9]]  # degenerate: covers nothing
    rows, cols, tri, bary = rasterize_uv(uv, 9, 11)
    expected = naive_rasterize(uv, 9, 11)
    got = {(r, c, f): tuple(b) for r, c, f, b in zip(rows.tolist(), cols.tolist(), tri.tolist(), bary)}
    assert got.keys() == expected.keys() and len(got) == len(rows) > 0
    assert max(np.abs(np.array(got[k]) - np.array(expected[k])).max() for k in got) < 1e-9
    # UVs shifted by whole tiles cover the same texels (wrapping).
    shifted = rasterize_uv(uv + np.array([2.0, -1.0]), 9, 11)
    assert all(np.array_equal(a, b) for a, b in zip(shifted[:3], (rows, cols, tri)))


def test_sample_bilinear_matches_hand_computation():
    texture = np.arange(12, dtype=np.float32).reshape(3, 4, 1)
    # Texel centres: (col + 0.5) / 4, (row + 0.5) / 3; halfway between (0, 0) and (0, 1), a third to row 1.
    uv = np.array([[1.0 / 4, (0.5 + 1 / 3) / 3], [0.0, 0.5 / 3], [0.999, 0.5 / 3]])
    wrapped = sample_bilinear(texture, uv, "wrap")[:, 0]
    clamped = sample_bilinear(texture, uv, "clamp")[:, 0]
    assert np.allclose(wrapped[0], 0.5 * 0 + 0.5 * 1 + (1 / 3) * 4, atol=1e-5)
    assert np.allclose(wrapped[1], 0.5 * 3 + 0.5 * 0) and np.allclose(clamped[1], 0.0)
    assert np.allclose(clamped[2], 3.0)


def test_dilate_grows_covered_region_by_mean_of_neighbours():
    values = np.zeros((5, 5, 1), np.float32)
    covered = np.zeros((5, 5), bool)
    values[2, 2], covered[2, 2] = 4.0, True
    values[2, 3], covered[2, 3] = 2.0, True
    out, grown = dilate(values, covered, 1)
    assert grown.sum() == 2 + 6
    assert out[1, 2, 0] == 4.0 and out[2, 4, 0] == 2.0 and out[2, 1, 0] == 4.0
    assert out[0, 0, 0] == 0.0 and not grown[0, 0]


def _centroid_lookup(mesh, texture, tri):
    """Texture values at triangle centroids via its own UVs (and transform)."""
    v_tex, t_tex_idx = mesh.uv[texture.uv_set]
    uv = v_tex.double()[t_tex_idx].mean(1).numpy()[tri]
    return sample_bilinear(texture.data.numpy(), uv, texture.wrap)


def test_merge_materials_keeps_appearance_at_surface_points():
    asset = two_material_asset(normal_map=True)
    merged = merge_materials(asset, size=256, padding=4)
    assert len(merged.materials) == 1 and (merged.mesh.t_mat_idx == 0).all()
    assert torch.equal(merged.mesh.t_pos_idx, asset.mesh.t_pos_idx) and len(merged.mesh.uv) == 1
    m = merged.materials[0]
    assert m.alpha_mode == "BLEND" and m.double_sided
    assert torch.isfinite(m.kd.data).all() and torch.isfinite(m.normal.data).all()
    # Interior triangles only: their centroids are well inside the charts.
    tri = np.arange(asset.mesh.num_triangles)
    owner = asset.mesh.t_mat_idx.numpy()
    for name in ("kd", "ks"):
        after = _centroid_lookup(merged.mesh, getattr(m, name), tri)
        before = np.stack([_centroid_lookup(asset.mesh, getattr(asset.materials[o], name), [t])[0]
                           for t, o in zip(tri, owner)])
        assert np.abs(after - before).max() < 0.03, name
    # Shading normals agree: old map in our frame of the old UVs vs the atlas map in the atlas frame.
    bary = np.full((len(tri), 3), 1 / 3)
    textured = owner == 0
    old_n = _centroid_lookup(asset.mesh, asset.materials[0].normal, tri)
    new_n = _centroid_lookup(merged.mesh, m.normal, tri)
    t1, b1, n1 = texel_frames(*our_corner_frame(asset.mesh, 0), tri, bary)
    t2, b2, n2 = texel_frames(*our_corner_frame(merged.mesh, 0), tri, bary)
    world_old = old_n[:, :1] * t1 + old_n[:, 1:2] * b1 + old_n[:, 2:] * n1
    world_new = new_n[:, :1] * t2 + new_n[:, 1:2] * b2 + new_n[:, 2:] * n2
    world_old /= np.linalg.norm(world_old, axis=-1, keepdims=True)
    world_new /= np.linalg.norm(world_new, axis=-1, keepdims=True)
    assert (world_old * world_new).sum(-1)[textured].min() > 0.995
    assert np.allclose(world_new[~textured], n2[~textured], atol=0.02)  # flat where no map was


@pytest.mark.parametrize("mode, alpha, expected", [("OPAQUE", 0.3, 1.0), ("MASK", 0.6, 1.0), ("MASK", 0.4, 0.0),
                                                   ("BLEND", 0.3, 0.3)])
def test_merged_alpha_keeps_each_part_looking_the_same(mode, alpha, expected):
    asset = two_material_asset(normal_map=False)
    asset.materials[0].kd.data[..., 3] = alpha
    asset.materials[0].alpha_mode = mode
    merged = merge_materials(asset, size=64, padding=2)
    m = merged.materials[0]
    assert m.alpha_mode == "BLEND"  # material 1 blends
    tri = np.flatnonzero(asset.mesh.t_mat_idx.numpy() == 0)
    got = _centroid_lookup(merged.mesh, m.kd, tri)[:, 3]
    assert np.allclose(got, expected, atol=1e-4)
