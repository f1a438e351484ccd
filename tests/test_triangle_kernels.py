"""The compiled per-triangle measures against their NumPy twins."""

from __future__ import annotations

import numpy as np

from lookalike.init.triangle_kernels import (
    centroids_and_extents,
    centroids_and_extents_python,
    triangle_areas,
    triangle_areas_python,
)


def _soup(seed: int = 0):
    """Random triangles over shared vertices, some degenerate (a repeated index, collinear)."""
    rng = np.random.default_rng(seed)
    v_pos = rng.normal(size=(300, 3))
    v_pos[10] = 0.5 * (v_pos[11] + v_pos[12])  # collinear with 11 and 12
    t_pos_idx = rng.integers(0, 300, size=(2000, 3))
    t_pos_idx[:5] = [[1, 1, 2], [10, 11, 12], [3, 4, 3], [7, 8, 9], [12, 10, 11]]
    return v_pos, t_pos_idx


def test_triangle_areas_match_numpy_twin():
    v_pos, t_pos_idx = _soup()
    fast, slow = triangle_areas(v_pos, t_pos_idx), triangle_areas_python(v_pos, t_pos_idx)
    np.testing.assert_allclose(fast, slow, rtol=1e-12, atol=1e-15)
    assert fast[0] == 0 and fast[2] == 0 and fast[1] < 1e-12 and fast[3] > 0.01


def test_centroids_and_extents_match_numpy_twin():
    v_pos, t_pos_idx = _soup(1)
    corners = v_pos[t_pos_idx]
    (centroid, extent), (centroid_slow, extent_slow) = centroids_and_extents(corners), centroids_and_extents_python(corners)
    np.testing.assert_allclose(centroid, centroid_slow, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(extent, extent_slow, rtol=1e-12, atol=1e-15)
    assert extent.min() >= 0 and extent.max() > 1
