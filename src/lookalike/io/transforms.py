"""Node transforms as glTF stores them: translation ``[3]``, rotation quaternion ``[4]`` (x, y, z, w),
scale ``[3]``, and 4x4 column-vector matrices ``M = T @ R @ S``. NumPy float64."""

from __future__ import annotations

import numpy as np


def quaternion_to_matrix(q: np.ndarray) -> np.ndarray:
    """``[3, 3]`` rotation matrix of a quaternion ``(x, y, z, w)`` (normalised first)."""
    x, y, z, w = np.asarray(q, dtype=np.float64) / max(np.linalg.norm(q), 1e-30)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def matrix_to_quaternion(r: np.ndarray) -> np.ndarray:
    """Quaternion ``(x, y, z, w)`` with ``w >= 0`` of a ``[3, 3]`` rotation matrix (Shepperd's
    method: branch on the largest of ``w, x, y, z`` for accuracy)."""
    r = np.asarray(r, dtype=np.float64)
    trace = np.trace(r)
    diag = np.diag(r)
    k = int(np.argmax(diag))
    if trace >= diag[k]:
        w = 0.5 * np.sqrt(1.0 + trace)
        q = np.array([(r[2, 1] - r[1, 2]) / (4 * w), (r[0, 2] - r[2, 0]) / (4 * w), (r[1, 0] - r[0, 1]) / (4 * w), w])
    else:
        i, j, l = k, (k + 1) % 3, (k + 2) % 3
        s = 0.5 * np.sqrt(max(1.0 + r[i, i] - r[j, j] - r[l, l], 0.0))
        q = np.zeros(4)
        q[i] = s
        q[j] = (r[j, i] + r[i, j]) / (4 * s)
        q[l] = (r[l, i] + r[i, l]) / (4 * s)
        q[3] = (r[l, j] - r[j, l]) / (4 * s)
    return q if q[3] >= 0 else -q


def trs_to_matrix(translation, rotation, scale) -> np.ndarray:
    """``[4, 4]`` matrix ``T @ R @ S``."""
    m = np.eye(4)
    m[:3, :3] = quaternion_to_matrix(rotation) * np.asarray(scale, dtype=np.float64)[None, :]
    m[:3, 3] = translation
    return m


def matrix_to_trs(m: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Decompose an affine ``[4, 4]`` matrix without shear into ``(translation, rotation xyzw, scale)``;
    a negative determinant goes into the sign of the x scale."""
    m = np.asarray(m, dtype=np.float64)
    linear = m[:3, :3]
    scale = np.linalg.norm(linear, axis=0)
    if np.linalg.det(linear) < 0:
        scale[0] = -scale[0]
    rotation = linear / np.where(scale == 0, 1.0, scale)[None, :]
    return m[:3, 3].copy(), matrix_to_quaternion(rotation), scale
