"""Welding coincident vertices.

File formats duplicate a position wherever another attribute (a UV seam, a normal crease)
changes; OBJ readers that index positions separately may still carry coincident copies. A
decimator that sees those copies as separate vertices opens cracks along every seam, so
positions are welded first.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

DEFAULT_RELATIVE_TOLERANCE = 1e-5


def weld_tolerance(v_pos: np.ndarray, relative: float = DEFAULT_RELATIVE_TOLERANCE) -> float:
    """Welding distance: ``relative`` times the diagonal of the bounding box of ``v_pos [V, 3]``."""
    if len(v_pos) == 0:
        return 0.0
    return float(relative * np.linalg.norm(v_pos.max(axis=0) - v_pos.min(axis=0)))


def weld_vertices(v_pos: np.ndarray, t_pos_idx: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Merge vertices closer than ``tolerance`` (transitively) and drop unreferenced ones.

    Args:
        v_pos: ``[V, 3]`` float positions.
        t_pos_idx: ``[T, 3]`` integer indices into ``v_pos``.
        tolerance: merge distance in the units of ``v_pos``.

    Returns:
        ``(w_pos [W, 3] float64, w_idx [T, 3] int64, vertex_map [V] int64)``: each group of
        merged vertices becomes one vertex placed at its lowest-indexed member, ``w_idx`` is
        ``vertex_map[t_pos_idx]``, and ``vertex_map`` is -1 for vertices whose group no triangle uses.
        Triangles are kept even where welding makes them degenerate.
    """
    v_pos = np.asarray(v_pos, dtype=np.float64)
    t_pos_idx = np.asarray(t_pos_idx, dtype=np.int64)
    n = len(v_pos)
    pairs = np.zeros((0, 2), np.int64)
    if tolerance > 0:   # an unbalanced tree builds faster and finds the pairs as fast
        tree = cKDTree(v_pos, balanced_tree=False, compact_nodes=False)
        pairs = tree.query_pairs(r=tolerance, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    n_groups, group = connected_components(graph, directed=False)

    used = np.zeros(n_groups, dtype=bool)
    used[group[t_pos_idx.reshape(-1)]] = True
    used_groups = np.flatnonzero(used)   # (a mask: np.unique's sort was slow on large inputs)
    group_to_new = np.full(n_groups, -1, dtype=np.int64)
    group_to_new[used_groups] = np.arange(len(used_groups))

    representative = np.full(len(group_to_new), n, dtype=np.int64)
    np.minimum.at(representative, group, np.arange(n))
    vertex_map = group_to_new[group]
    return v_pos[representative[used_groups]], vertex_map[t_pos_idx], vertex_map
