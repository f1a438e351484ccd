"""Decomposing glTF node matrices (4x4, column vectors, ``M = T @ R @ S``) into translation
``[3]``, rotation quaternion ``[4]`` (x, y, z, w) and scale ``[3]``; NumPy float64. The forward
direction is ``lookalike.asset.skinning.trs_matrix``."""

from __future__ import annotations

import numpy as np


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
