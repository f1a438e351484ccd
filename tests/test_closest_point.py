"""Closest points on triangles and meshes: the Numba kernel against its numpy twin, the numpy
twin against dense sampling, and the accelerated mesh query against brute force."""

from __future__ import annotations

import numpy as np
import pytest

from lookalike.init.closest_point import SurfaceQuery, _best_candidates, closest_barycentric
from mesh_factory import icosphere


def _random_triangles(rng, n):
    """Random triangles, a fifth of them degenerate (segments and points)."""
    tri = rng.normal(size=(n, 3, 3))
    tri[: n // 10, 2] = tri[: n // 10, 0] + 0.5 * (tri[: n // 10, 1] - tri[: n // 10, 0])   # collinear
    tri[n // 10: n // 5, 1:] = tri[n // 10: n // 5, :1]                                       # a point
    return tri


def _brute_force(points, corners):
    """Exact closest distance from each point to every triangle, minimum taken over all."""
    w = closest_barycentric(points[:, None], corners[None, :, 0], corners[None, :, 1], corners[None, :, 2])
    d = np.linalg.norm((w[..., None] * corners[None]).sum(axis=2) - points[:, None], axis=-1)
    return d.min(axis=1), d


def test_numpy_closest_point_is_never_beaten_by_dense_sampling():
    rng = np.random.default_rng(1)
    tri = _random_triangles(rng, 300)
    p = rng.normal(size=(300, 3)) * 1.5
    w = closest_barycentric(p, tri[:, 0], tri[:, 1], tri[:, 2])
    assert np.all(w >= 0) and np.allclose(w.sum(axis=1), 1)
    d = np.linalg.norm((w[:, :, None] * tri).sum(axis=1) - p, axis=1)

    steps = 60
    i, j = np.meshgrid(np.arange(steps + 1), np.arange(steps + 1), indexing="ij")
    keep = i + j <= steps
    grid = np.stack([steps - i[keep] - j[keep], i[keep], j[keep]], axis=1) / steps       # [G, 3]
    samples = np.einsum("gk,nkc->ngc", grid, tri)                                        # [N, G, 3]
    dense = np.linalg.norm(samples - p[:, None], axis=-1).min(axis=1)
    spacing = np.linalg.norm(tri - tri[:, [1, 2, 0]], axis=-1).max(axis=1) / steps
    assert np.all(d <= dense + 1e-12)
    assert np.all(d >= dense - spacing)


def test_numba_kernel_matches_numpy_twin():
    rng = np.random.default_rng(2)
    tri = _random_triangles(rng, 500)
    p = rng.normal(size=(500, 3)) * 1.5
    expected = closest_barycentric(p, tri[:, 0], tri[:, 1], tri[:, 2])
    empty = np.zeros(0, dtype=np.int64)
    column, bary, distance = _best_candidates(p, np.arange(500)[:, None], tri, empty, empty)
    assert np.all(column == 0)
    np.testing.assert_allclose(bary, expected, atol=1e-12)
    np.testing.assert_allclose(distance, np.linalg.norm((expected[:, :, None] * tri).sum(axis=1) - p, axis=1), atol=1e-12)


def _bumpy_sphere_with_giant_triangle():
    """An icosphere with bumps plus one huge triangle far bigger than the others."""
    sphere = icosphere(3)
    v = sphere.v_pos.double().numpy()
    v = v * (1 + 0.1 * np.sin(5 * v[:, :1]) * np.cos(4 * v[:, 1:2]))
    f = sphere.t_pos_idx.numpy()
    giant = np.array([[-20.0, -20.0, -3.0], [20.0, -20.0, -3.0], [0.0, 20.0, -3.0]])
    return np.concatenate([v, giant]), np.concatenate([f, [[len(v), len(v) + 1, len(v) + 2]]])


def test_surface_query_is_exact_against_brute_force():
    v, f = _bumpy_sphere_with_giant_triangle()
    rng = np.random.default_rng(3)
    points = np.concatenate([
        v[rng.integers(0, len(v) - 3, 300)] + rng.normal(size=(300, 3)) * 0.02,     # near the surface
        rng.normal(size=(200, 3)) * 4,                                              # anywhere
        rng.normal(size=(50, 3)) * 0.05,                                            # deep inside
    ])
    result = SurfaceQuery(v, f).closest(points)
    best, per_triangle = _brute_force(points, v[f])
    np.testing.assert_allclose(result.distance, best, atol=1e-10)
    np.testing.assert_allclose(np.linalg.norm(result.point - points, axis=1), best, atol=1e-10)
    np.testing.assert_allclose(per_triangle[np.arange(len(points)), result.triangle], best, atol=1e-10)


def test_surface_query_respects_labels():
    v, f = _bumpy_sphere_with_giant_triangle()
    corners = v[f]
    label = (corners.mean(axis=1)[:, 0] > 0.3).astype(np.int64)        # a cap of the sphere is label 1
    label[-1] = 2
    rng = np.random.default_rng(4)
    points = rng.normal(size=(300, 3)) * 1.2
    wanted = rng.integers(0, 3, len(points))
    result = SurfaceQuery(v, f, label).closest(points, labels=wanted)
    assert np.all(label[result.triangle] == wanted)
    _, per_triangle = _brute_force(points, corners)
    per_triangle = np.where(label[None, :] == wanted[:, None], per_triangle, np.inf)
    np.testing.assert_allclose(result.distance, per_triangle.min(axis=1), atol=1e-10)


def test_surface_query_needs_triangles():
    with pytest.raises(ValueError):
        SurfaceQuery(np.zeros((3, 3)), np.zeros((0, 3), dtype=np.int64))


def test_points_certainly_beyond_a_distance_get_an_upper_bound_within_the_cover_radius():
    """``beyond``: a point every unexamined triangle lies that far from keeps its shortlist's best,
    no nearer than the exact answer and within the cover radius of it; nearer points stay exact."""
    mesh = icosphere(3)
    query = SurfaceQuery(mesh.v_pos.double().numpy(), mesh.t_pos_idx.numpy())
    rng = np.random.default_rng(4)
    directions = rng.normal(size=(400, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    near, far = directions[:200] * rng.uniform(0.9, 1.1, (200, 1)), directions[200:] * rng.uniform(3, 5, (200, 1))
    points = np.concatenate([near, far])
    exact = query.closest(points).distance
    bounded = query.closest(points, beyond=0.5).distance
    np.testing.assert_array_equal(bounded[:200], exact[:200])
    assert np.all(bounded[200:] >= exact[200:] - 1e-12) and np.all(bounded[200:] <= exact[200:] + query.cover_radius)
