"""The disjoint parts of a mesh: the leaves of a bush, the links of a chain.

Two triangles belong to one part when a chain of triangles joins them, each sharing a corner
position with the next. Positions are compared exactly (``v_pos`` rows that are equal count as
one corner), so a part whose vertices are split at UV or normal seams stays one part.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse
from scipy.sparse.csgraph import connected_components


def triangle_parts(v_pos: np.ndarray, t_pos_idx: np.ndarray) -> np.ndarray:
    """``[T]`` int64 part label of each triangle, ``0 .. parts - 1``, numbered in the order of
    each part's first triangle.

    Args:
        v_pos: ``[V, 3]`` positions; t_pos_idx: ``[T, 3]`` int triangles.
    Cost: one sort of the positions and one sparse connected-components pass, O(V log V + T).
    """
    t_pos_idx = np.asarray(t_pos_idx, dtype=np.int64)
    if len(t_pos_idx) == 0:
        return np.zeros(0, dtype=np.int64)
    _, corner = np.unique(np.asarray(v_pos), axis=0, return_inverse=True)
    corner = corner.reshape(-1)[t_pos_idx]                               # [T, 3] welded corners
    count = int(corner.max()) + 1
    edges = np.concatenate([corner[:, [0, 1]], corner[:, [1, 2]]])
    graph = scipy.sparse.coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(count, count))
    label = connected_components(graph, directed=False)[1][corner[:, 0]]
    _, first, renumbered = np.unique(label, return_index=True, return_inverse=True)
    order = np.argsort(np.argsort(first))                                # rank of each part's first triangle
    return order[renumbered.reshape(-1)].astype(np.int64)


def triangle_parts_python(v_pos: np.ndarray, t_pos_idx: np.ndarray) -> np.ndarray:
    """``triangle_parts`` by a union-find over triangles, one corner at a time (the oracle)."""
    t_pos_idx = np.asarray(t_pos_idx, dtype=np.int64)
    parent = list(range(len(t_pos_idx)))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    owner: dict[tuple, int] = {}
    for t, tri in enumerate(t_pos_idx):
        for v in tri:
            key = tuple(np.asarray(v_pos)[v].tolist())
            if key in owner:
                parent[root(t)] = root(owner[key])
            else:
                owner[key] = t
    labels, out = {}, np.zeros(len(t_pos_idx), dtype=np.int64)
    for t in range(len(t_pos_idx)):
        out[t] = labels.setdefault(root(t), len(labels))
    return out


AGGREGATE_PARTS = 20
"""An input is aggregate geometry when it takes at least this many parts to hold half its
triangles (foliage, hair, chains; a scan with a few loose crumbs takes one)."""

AGGREGATE_ALPHA_SHARE = 0.25
"""...or when alpha-tested or blended materials cover at least this share of its area, over at
least ``AGGREGATE_PARTS`` parts (leaves drawn as alpha cut-outs)."""


def aggregate_traits(asset) -> str | None:
    """What makes ``asset`` look like aggregate geometry, in a few words (e.g. ``"4,012
    disjoint parts, 61 % of the area alpha-tested"``), or ``None`` where it does not (see
    ``AGGREGATE_PARTS`` and ``AGGREGATE_ALPHA_SHARE``)."""
    mesh = asset.mesh
    v_pos, tri = mesh.v_pos.detach().numpy(), mesh.t_pos_idx.numpy()
    parts = triangle_parts(v_pos, tri)
    if len(parts) == 0:
        return None
    sizes = np.sort(np.bincount(parts))[::-1]
    to_half = int(np.searchsorted(np.cumsum(sizes), 0.5 * len(parts))) + 1
    corners = v_pos[tri].astype(np.float64)
    area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    alpha = np.array([m.uses_alpha for m in asset.materials], bool)[mesh.t_mat_idx.numpy()]
    alpha_share = float(area[alpha].sum() / max(area.sum(), 1e-30))
    many = len(sizes) >= AGGREGATE_PARTS
    if not (to_half >= AGGREGATE_PARTS or (many and alpha_share >= AGGREGATE_ALPHA_SHARE)):
        return None
    traits = f"{len(sizes):,} disjoint parts"
    return traits + (f", {100 * alpha_share:.0f} % of the area alpha-tested" if alpha_share > 0 else "")
