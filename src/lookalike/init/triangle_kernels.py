"""Per-triangle measures over large inputs as compiled parallel passes, with their NumPy twins.

These take one pass over the triangles on every core, because NumPy's single-threaded passes
over ``[T, 3, 3]`` temporaries were a large share of decimating inputs of millions of
triangles. Tests compare each with its ``*_python`` twin.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..kernel_cache import CACHE


@njit(cache=CACHE, parallel=True)
def _areas(v_pos, t_pos_idx, out):
    for t in prange(t_pos_idx.shape[0]):
        a, b, c = t_pos_idx[t, 0], t_pos_idx[t, 1], t_pos_idx[t, 2]
        ux, uy, uz = v_pos[b, 0] - v_pos[a, 0], v_pos[b, 1] - v_pos[a, 1], v_pos[b, 2] - v_pos[a, 2]
        wx, wy, wz = v_pos[c, 0] - v_pos[a, 0], v_pos[c, 1] - v_pos[a, 1], v_pos[c, 2] - v_pos[a, 2]
        nx, ny, nz = uy * wz - uz * wy, uz * wx - ux * wz, ux * wy - uy * wx
        out[t] = 0.5 * math.sqrt(nx * nx + ny * ny + nz * nz)


def triangle_areas(v_pos: np.ndarray, t_pos_idx: np.ndarray) -> np.ndarray:
    """``[T]`` float64 areas ``|(b - a) x (c - a)| / 2`` of the triangles ``t_pos_idx [T, 3]``
    int64 over ``v_pos [V, 3]`` float64."""
    out = np.empty(len(t_pos_idx), np.float64)
    _areas(np.ascontiguousarray(v_pos, np.float64), np.ascontiguousarray(t_pos_idx, np.int64), out)
    return out


def triangle_areas_python(v_pos: np.ndarray, t_pos_idx: np.ndarray) -> np.ndarray:
    """NumPy twin of :func:`triangle_areas`."""
    corners = v_pos[t_pos_idx]
    return 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)


@njit(cache=CACHE, parallel=True)
def _centroids_and_extents(corners, centroid, extent):
    for t in prange(corners.shape[0]):
        for k in range(3):
            centroid[t, k] = (corners[t, 0, k] + corners[t, 1, k] + corners[t, 2, k]) / 3.0
        far = 0.0
        for j in range(3):
            dx = corners[t, j, 0] - centroid[t, 0]
            dy = corners[t, j, 1] - centroid[t, 1]
            dz = corners[t, j, 2] - centroid[t, 2]
            far = max(far, math.sqrt(dx * dx + dy * dy + dz * dz))
        extent[t] = far


def centroids_and_extents(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(centroid [T, 3], extent [T])`` float64 of triangles ``corners [T, 3, 3]`` float64: the
    corners' mean and the largest corner distance from it."""
    corners = np.ascontiguousarray(corners, np.float64)
    centroid, extent = np.empty((len(corners), 3)), np.empty(len(corners))
    _centroids_and_extents(corners, centroid, extent)
    return centroid, extent


def centroids_and_extents_python(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """NumPy twin of :func:`centroids_and_extents`."""
    centroid = corners.mean(axis=1)
    return centroid, np.linalg.norm(corners - centroid[:, None], axis=-1).max(axis=1)
