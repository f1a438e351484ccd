"""The compiled visibility kernel against its plain-torch twin, and rasterize's
conventions (pixel centres, row order, clipping, batching modes)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from numba import njit

import lookalike.render as dr
from lookalike.render import visibility
from lookalike.render.visibility import TILE, visible_layers, visible_triangles
from lookalike.render.visibility_python import visible_layers_python, visibility_python
from lookalike.render.window import Window


def perspective(fovy: float = 1.0, near: float = 0.1, far: float = 100.0) -> torch.Tensor:
    """OpenGL perspective matrix ``[4, 4]`` for aspect 1."""
    f = 1.0 / math.tan(fovy / 2)
    return torch.tensor(
        [[f, 0, 0, 0], [0, f, 0, 0], [0, 0, (far + near) / (near - far), 2 * far * near / (near - far)], [0, 0, -1, 0]]
    )


def random_scene(n_views: int, n_tris: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Random triangles (3 own vertices each) seen by a perspective camera at the origin:
    some cross the near plane, some lie behind the eye (w < 0), some are off screen, some
    are degenerate (a repeated vertex; a triangle whose plane passes through the eye)."""
    centres = torch.randn(n_views, n_tris, 1, 3) * torch.tensor([1.5, 1.5, 1.5]) - torch.tensor([0.0, 0.0, 1.5])
    eye_space = (centres + 0.4 * torch.randn(n_views, n_tris, 3, 3)).reshape(n_views, -1, 3)
    homogeneous = torch.cat([eye_space, torch.ones(n_views, 3 * n_tris, 1)], -1)
    pos = homogeneous @ perspective().T
    tri = torch.arange(3 * n_tris).reshape(n_tris, 3)
    tri[:5, 2] = tri[:5, 1]
    pos[:, 17] = pos[:, 15] * 2.0
    pos[:, 16] = pos[:, 15] * 0.5 + pos[:, 16] * 0.0  # triangle 5 lies on a line through the eye
    pos[:, 20, :2] = pos[:, 20, 3:4] * 3.0  # triangle 6 partly off screen
    return pos, tri


def test_kernel_agrees_with_python_twin_on_random_scenes():
    pos, tri = random_scene(3, 150)
    w_signs = pos[:, tri, 3].gt(0).sum(-1)
    near = (pos[:, tri, 2] + pos[:, tri, 3]).gt(0).sum(-1)
    assert (w_signs == 0).any() and ((near > 0) & (near < 3) & (w_signs == 3)).any()
    tri_range = torch.tensor([[0, 150]] * 3)
    ids, depth = visible_triangles(pos.numpy(), tri.int().numpy(), tri_range.numpy(), 70, 90)
    ref_ids, ref_depth = visibility_python(pos, tri, (70, 90))
    ids, depth = torch.from_numpy(ids), torch.from_numpy(depth)
    agree = ids == ref_ids
    assert agree.float().mean() >= 0.999
    assert 0.2 < (ref_ids > 0).float().mean() < 0.95 and ref_ids.unique().numel() > 50  # a busy scene
    covered = agree & (ids > 0)
    torch.testing.assert_close(depth[covered], ref_depth[covered], atol=1e-4, rtol=1e-4)


def test_single_view_uses_tiles_and_matches_python_twin():
    pos, tri = random_scene(1, 400)
    height, width = 3 * TILE + 5, 2 * TILE + 7  # partial tiles on both axes
    rast, _ = dr.rasterize(None, pos, tri.int(), (height, width))
    ref_ids, _ = visibility_python(pos, tri, (height, width))
    assert (rast[..., 3].int() == ref_ids).float().mean() >= 0.999


def test_triangle_crossing_near_plane_draws_its_visible_part():
    # a floor under the camera reaching from behind the eye far into the scene
    floor = torch.tensor([[-50.0, -1.0, 5.0, 1.0], [50.0, -1.0, 5.0, 1.0], [0.0, -1.0, -50.0, 1.0]])
    pos = (floor @ perspective().T)[None]
    assert pos[0, :2, 3].lt(0).all() and pos[0, 2, 3] > 0
    rast, _ = dr.rasterize(dr.RasterizeContext(), pos, torch.tensor([[0, 1, 2]], dtype=torch.int32), (32, 32))
    ref_ids, ref_depth = visibility_python(pos, torch.tensor([[0, 1, 2]]), (32, 32))
    assert torch.equal(rast[..., 3].int(), ref_ids)
    # below the horizon (row 0 = bottom) the floor is seen, above it nothing
    assert rast[0, :8, :, 3].eq(1).all() and rast[0, 16:, :, 3].eq(0).all()
    covered = ref_ids > 0
    torch.testing.assert_close(rast[..., 2][covered], ref_depth[covered])
    assert (rast[..., 2][covered] >= -1).all()


def test_pixel_centres_and_row_order():
    # a triangle covering exactly the half y < 0 of the screen in a 4x4 image (edges between
    # pixel centres) lands in rows 0 and 1
    quad = torch.tensor([[[-3.0, -3.0, 0.0, 1.0], [3.0, -3.0, 0.0, 1.0], [-3.0, 0.0, 0.0, 1.0], [3.0, 0.0, 0.0, 1.0]]])
    rast, _ = dr.rasterize(None, quad, torch.tensor([[0, 1, 2], [1, 3, 2]]), (4, 4))
    covered = rast[0, :, :, 3] > 0
    assert covered[:2].all() and not covered[2:].any()
    # pixel (0, 0) has centre (-0.75, -0.75), inside triangle 1 = vertices
    # (3, -3), (3, 0), (-3, 0) with weights 0.25, 0.125, 0.625
    assert rast[0, 0, 0, 3] == 2
    torch.testing.assert_close(rast[0, 0, 0, :2], torch.tensor([0.25, 0.125]))


def test_equal_depths_pick_lower_triangle_index():
    pos = torch.tensor([[[-1.0, -1.0, 0.5, 1.0], [3.0, -1.0, 0.5, 1.0], [-1.0, 3.0, 0.5, 1.0]]])
    rast, _ = dr.rasterize(None, pos, torch.tensor([[2, 1, 0], [0, 1, 2]]), (8, 8))
    assert rast[..., 3].eq(1).all()


def test_far_plane_clips_per_pixel():
    # depth z/w runs from -0.5 at the left edge to 1.5 at the right edge: right quarter clipped
    pos = torch.tensor([[[-1.0, -3.0, -0.5, 1.0], [-1.0, 3.0, -0.5, 1.0], [1.0, 0.0, 1.5, 1.0]]])
    rast, _ = dr.rasterize(None, pos, torch.tensor([[0, 1, 2]]), (16, 16))
    ref_ids, _ = visibility_python(pos, torch.tensor([[0, 1, 2]]), (16, 16))
    assert torch.equal(rast[..., 3].int(), ref_ids)
    row = rast[0, 8, :, 3]
    assert row[:11].eq(1).all() and row[13:].eq(0).all()


def test_range_mode_equals_instanced_subsets_and_int_types_agree():
    pos, tri = random_scene(1, 100)
    ranges = torch.tensor([[0, 40], [40, 60]], dtype=torch.int32)
    rast, rast_db = dr.rasterize(None, pos[0], tri, (24, 24), ranges=ranges)
    for b, (first, count) in enumerate(ranges.tolist()):
        sub = tri[first : first + count]
        sub_rast, sub_db = dr.rasterize(None, pos, sub.int(), (24, 24))
        shown = sub_rast[..., 3] > 0
        sub_rast[..., 3][shown] += first  # ids are global in range mode
        torch.testing.assert_close(rast[b : b + 1], sub_rast)
        torch.testing.assert_close(rast_db[b : b + 1], sub_db)


def test_bad_inputs_raise_clear_errors():
    pos = torch.zeros(1, 3, 4)
    with pytest.raises(ValueError, match="tri"):
        dr.rasterize(None, pos, torch.tensor([[0, 1, 3]]), (4, 4))
    with pytest.raises(ValueError, match="ranges"):
        dr.rasterize(None, pos[0], torch.tensor([[0, 1, 2]]), (4, 4))
    with pytest.raises(ValueError, match="int32 or int64"):
        dr.rasterize(None, pos, torch.tensor([[0.0, 1.0, 2.0]]), (4, 4))


@pytest.mark.parametrize("layers", [1, 3])
@pytest.mark.parametrize("clip", [(0, 69, 0, 39), (5, 50, 3, 30)])
def test_view_parallel_and_tile_parallel_paths_agree(clip, layers):
    pos, tri = random_scene(3, 300)
    pos = pos.numpy()
    tri = tri.int().numpy()
    begin = np.zeros(3, np.int64)
    end = np.full(3, tri.shape[0], np.int64)
    min_depth = np.full((3, 40, 70), -np.inf, np.float32)
    screen, code = visibility.project_vertices(pos, 70, 40)
    clip = np.array(clip, np.int64)
    results = []
    for by_tiles in (False, True):
        tri_id = np.zeros((3, 40, 70, layers), np.int32)
        depth = np.full((3, 40, 70, layers), np.inf, np.float32)
        if by_tiles:
            bbox, bin_start, bin_tris = visibility._bin_triangles(pos, screen, code, tri, begin, end, 70, 40, clip)
            visibility._rasterize_tiles(pos, tri, bbox, bin_start, bin_tris, 70, 40, min_depth, tri_id, depth)
        else:
            visibility._rasterize_views(pos, screen, code, tri, begin, end, 70, 40, clip, min_depth, tri_id, depth)
        results.append((tri_id, depth))
    assert (results[0][0] == results[1][0]).all() and (results[0][1] == results[1][1]).all()
    assert (results[0][0][..., -1] > 0).mean() > 0.1


def test_a_window_draws_only_its_pixels_as_the_twin_does():
    pos, tri = random_scene(2, 200)
    window = Window(7, 11, 20, 33, 40, 70)
    ids, depth = visible_triangles(pos.numpy(), tri.int().numpy(), np.array([[0, 200], [0, 200]]), 40, 70,
                                   window=window)
    twin_ids, twin_depth = visibility_python(pos, tri, (40, 70), window=window)
    full_ids, full_depth = visible_triangles(pos.numpy(), tri.int().numpy(), np.array([[0, 200], [0, 200]]), 40, 70)
    assert (ids == twin_ids.numpy()).mean() > 0.99
    assert (window.crop(ids) == window.crop(full_ids)).all() and (window.crop(depth) == window.crop(full_depth)).all()
    assert ids.sum() == window.crop(ids).sum() and np.isinf(depth).sum() == depth.size - (window.crop(ids) > 0).sum()


@njit
def _both_boxes(pos, screen, code, tri, width, height):
    """``[B, T, 2, 4]``: each triangle's box by ``_triangle_bbox`` and by ``_projected_bbox``."""
    out = np.zeros((pos.shape[0], tri.shape[0], 2, 4), np.int64)
    for b in range(pos.shape[0]):
        for t in range(tri.shape[0]):
            out[b, t, 0] = visibility._triangle_bbox(pos, b, tri[t, 0], tri[t, 1], tri[t, 2], width, height)
            out[b, t, 1] = visibility._projected_bbox(pos, screen, code, b, tri[t, 0], tri[t, 1], tri[t, 2], width, height)
    return out


def test_boxes_from_projected_vertices_equal_the_per_triangle_ones():
    pos, tri = random_scene(3, 400)
    pos = pos.numpy().copy()
    pos[:, ::7, 3] *= -1.0  # some vertices behind the eye: triangles crossing the near plane
    pos[:, 1::5, 2] = 2.0 * np.abs(pos[:, 1::5, 3])  # beyond the far plane
    tri = tri.int().numpy()
    screen, code = visibility.project_vertices(pos, 70, 40)
    boxes = _both_boxes(pos, screen, code, tri, 70, 40)
    assert (boxes[:, :, 0] == boxes[:, :, 1]).all()
    culled = boxes[:, :, 0, 0] > boxes[:, :, 0, 1]
    assert 0.05 < culled.mean() < 0.95  # both the culled and the drawn cases were compared
    assert not ((code & visibility._FRONT) > 0).all()  # and the clipping path


def test_empty_and_invalid_geometry_never_crash():
    pos = torch.tensor([[[0.0, 0.0, 0.0, -1.0], [1.0, 0.0, 0.0, -1.0], [0.0, 1.0, 0.0, -1.0], [float("nan"), 0.0, 0.0, 1.0]]])
    for tri in (torch.zeros(0, 3, dtype=torch.int32), torch.tensor([[0, 1, 2], [0, 1, 3], [3, 3, 3]])):
        rast, rast_db = dr.rasterize(None, pos, tri, (8, 8))
        assert (rast == 0).all() and (rast_db == 0).all()
        color = dr.antialias(torch.ones(1, 8, 8, 3), rast, pos, tri)
        assert torch.equal(color, torch.ones(1, 8, 8, 3))


@pytest.mark.parametrize("views", [1, 3])
def test_layers_in_one_pass_equal_peeling_pass_by_pass_and_the_twin(views):
    """The k-buffer's layer k is, bit for bit, the k-th pass of peeling with the compiled
    kernel (each pass strictly behind the last, ties to the lower index: triangles 0-4 repeat
    vertices and some triangles share depths), and agrees with the plain-torch twin."""
    torch.manual_seed(7)
    pos, tri = random_scene(views, 300)
    pos[:, 120:123] = torch.tensor([[-0.5, -0.5, 0.1, 1.0], [0.5, -0.5, 0.1, 1.0], [0.0, 0.5, 0.1, 1.0]])
    pos[:, 123:126] = pos[:, 120:123]  # triangles 40 and 41 coincide: equal depths, 40 wins
    arrays = pos.numpy(), tri.int().numpy(), np.array([[0, 300]] * views)
    ids, depth = visible_layers(*arrays, 40, 70, 4)
    floor = None
    for k in range(4):
        pass_ids, pass_depth = visible_triangles(*arrays, 40, 70, floor)
        assert (ids[k] == pass_ids).all() and (depth[k] == pass_depth).all()
        floor = pass_depth
    assert (ids[3] > 0).mean() > 0.05 and (ids == 41).any() and not (ids == 42).any()
    twin_ids, twin_depth = visible_layers_python(pos, tri, (40, 70), 4)
    assert (torch.from_numpy(ids) == twin_ids).float().mean() >= 0.995
