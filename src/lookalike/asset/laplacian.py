"""The uniform Laplacian regulariser of the paper (Sec. 5.3, after Sorkine 2005).

The uniformly weighted differential of vertex ``i`` is

    delta_i = v_i - (1 / |N_i|) * sum_{j in N_i} v_j,

with ``N_i`` the one-ring of ``i`` (vertices sharing an edge with it, each counted once).
The loss is ``L = (1 / V) * sum_i |delta_i - delta'_i|^2`` with ``delta'`` the differentials
of the initial mesh (relative regulariser) or zero (absolute regulariser).
Vertices on no edge have ``delta_i = 0``.
"""

from __future__ import annotations

import torch

from .edges import edge_index


def unique_edges(t_idx: torch.Tensor) -> torch.Tensor:
    """Undirected edges of a triangle list, each once, as ``[E, 2]`` int64 with
    ``edge[:, 0] < edge[:, 1]``, sorted lexicographically (degenerate sides dropped).

    Args:
        t_idx: ``[T, 3]`` int64 triangle indices.
    """
    edges = edge_index(t_idx)[0]
    return edges[edges[:, 0] != edges[:, 1]]


class UniformLaplacian:
    """The uniform Laplacian operator ``delta = L @ v`` of a fixed topology, as a sparse
    ``[V, V]`` matrix with ``L_ii = 1`` and ``L_ij = -1/|N_i|`` for ``j`` in ``N_i``
    (rows of vertices on no edge are zero). Built once; applied to any positions.

    Args:
        t_pos_idx: ``[T, 3]`` int64 triangles.
        num_vertices: ``V``.
    """

    def __init__(self, t_pos_idx: torch.Tensor, num_vertices: int):
        edges = unique_edges(t_pos_idx)
        rows = torch.cat([edges[:, 0], edges[:, 1]])
        cols = torch.cat([edges[:, 1], edges[:, 0]])
        degree = torch.zeros(num_vertices, dtype=torch.float64, device=t_pos_idx.device)
        degree.index_add_(0, rows, torch.ones_like(rows, dtype=torch.float64))
        connected = torch.nonzero(degree > 0).reshape(-1)
        indices = torch.stack([torch.cat([connected, rows]), torch.cat([connected, cols])])
        values = torch.cat([torch.ones_like(connected, dtype=torch.float64), -1.0 / degree[rows]])
        self.num_vertices = num_vertices
        self.matrix = torch.sparse_coo_tensor(indices, values, (num_vertices, num_vertices),
                                              check_invariants=True).coalesce()
        self._cast: dict[tuple[torch.dtype, torch.device], torch.Tensor] = {}

    def _matrix_like(self, v_pos: torch.Tensor) -> torch.Tensor:
        key = (v_pos.dtype, v_pos.device)
        if key not in self._cast:
            self._cast[key] = self.matrix.to(dtype=v_pos.dtype, device=v_pos.device)
        return self._cast[key]

    def differentials(self, v_pos: torch.Tensor) -> torch.Tensor:
        """``[V, 3]`` differentials ``delta_i`` of positions ``v_pos [V, 3]`` (same dtype)."""
        return torch.sparse.mm(self._matrix_like(v_pos), v_pos)

    def loss(self, v_pos: torch.Tensor, reference_delta: torch.Tensor | None = None) -> torch.Tensor:
        """Scalar ``mean_i |delta_i - reference_delta_i|^2``; absolute (reference zero) when
        ``reference_delta`` (``[V, 3]``) is ``None``."""
        delta = self.differentials(v_pos)
        if reference_delta is not None:
            delta = delta - reference_delta
        return (delta * delta).sum(dim=-1).mean()
