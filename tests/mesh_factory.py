"""Test meshes: an icosphere (a closed, welded mesh of any size), and a bumpy one in clip space."""

from __future__ import annotations

import numpy as np
import torch

from lookalike.asset import Mesh


def _icosahedron() -> tuple[np.ndarray, np.ndarray]:
    """The 12 unit vertices ``[12, 3]`` and 20 outward-facing (counter-clockwise) faces ``[20, 3]``."""
    g = (1 + 5 ** 0.5) / 2
    v = np.array([
        [-1, g, 0], [1, g, 0], [-1, -g, 0], [1, -g, 0],
        [0, -1, g], [0, 1, g], [0, -1, -g], [0, 1, -g],
        [g, 0, -1], [g, 0, 1], [-g, 0, -1], [-g, 0, 1],
    ], dtype=np.float64)
    f = np.array([
        [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11],
        [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
        [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
        [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1],
    ], dtype=np.int64)
    return v / np.linalg.norm(v, axis=1, keepdims=True), f


def _subdivide(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split each triangle into four at its edge midpoints (pushed onto the unit sphere)."""
    edges = np.sort(np.stack([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]], axis=1).reshape(-1, 2), axis=1)
    unique_edges, edge_of = np.unique(edges, axis=0, return_inverse=True)
    mid = v[unique_edges].mean(axis=1)
    v = np.concatenate([v, mid / np.linalg.norm(mid, axis=1, keepdims=True)])
    m = len(v) - len(mid) + edge_of.reshape(-1, 3)          # midpoints of edges 01, 12, 20
    a, b, c = f.T
    f = np.concatenate([
        np.stack([a, m[:, 0], m[:, 2]], 1), np.stack([b, m[:, 1], m[:, 0]], 1),
        np.stack([c, m[:, 2], m[:, 1]], 1), m,
    ])
    return v, f


def icosphere(subdivisions: int = 3, center=(0.0, 0.0, 0.0), radius: float = 1.0) -> Mesh:
    """A sphere of ``20 * 4**subdivisions`` triangles, welded, counter-clockwise outward.

    Args:
        subdivisions: number of 1-to-4 splits of the icosahedron.
        center: ``[3]`` centre; radius: its radius.

    Returns:
        ``Mesh`` with ``v_pos [10 * 4**s + 2, 3]`` float32 and ``t_pos_idx [20 * 4**s, 3]`` int64, no UVs.
    """
    v, f = _icosahedron()
    for _ in range(subdivisions):
        v, f = _subdivide(v, f)
    v = v * radius + np.asarray(center, dtype=np.float64)
    return Mesh(v_pos=torch.as_tensor(v, dtype=torch.float32), t_pos_idx=torch.as_tensor(f, dtype=torch.int64))


def bumpy_sphere_clip(n_views: int = 2, level: int = 2, seed: int = 0):
    """A jittered icosphere (a closed mesh whose outline folds) seen through random
    perspective cameras: ``(pos [B, V, 4] float64, tri [T, 3] int64)``."""
    generator = torch.Generator().manual_seed(seed)
    sphere = icosphere(level)
    bumps = 1 + 0.15 * torch.rand(sphere.v_pos.shape[0], 1, generator=generator, dtype=torch.float64)
    verts = sphere.v_pos.double() * bumps
    pos = []
    for _ in range(n_views):
        rotation, _ = torch.linalg.qr(torch.randn(3, 3, generator=generator, dtype=torch.float64))
        eye = verts @ rotation.T + torch.tensor([0.0, 0.0, -3.5], dtype=torch.float64)
        pos.append(torch.stack([1.6 * eye[:, 0], 1.6 * eye[:, 1], -eye[:, 2] * 0.5 - 1.0, -eye[:, 2]], -1))
    return torch.stack(pos), sphere.t_pos_idx.long()
