"""Triangle adjacency across edges, for silhouette detection in antialiasing."""

from __future__ import annotations

from typing import NamedTuple

import torch


class EdgeTopology(NamedTuple):
    """Who lies across each triangle edge (nvdiffrast's "topology hash").

    Edge ``k`` of triangle ``t`` is the one opposite its vertex ``k``, joining vertices
    ``tri[t, (k+1)%3]`` and ``tri[t, (k+2)%3]``.  Both fields are ``[T, 3]`` int64 with -1
    on boundary edges:

    - ``opposite``: the neighbouring triangle's vertex that is not on the edge;
    - ``neighbour``: the neighbouring triangle's index.
    """

    opposite: torch.Tensor
    neighbour: torch.Tensor


def antialias_construct_topology_hash(tri: torch.Tensor) -> EdgeTopology:
    """The :class:`EdgeTopology` of ``tri [T, 3]`` int32/int64.

    Edges are matched by their (unordered) vertex pair; an edge shared by more than two
    triangles pairs each triangle with one neighbour in sorted order.
    """
    tri = tri.long()
    n_tris = tri.shape[0]
    a = tri[:, [1, 2, 0]].reshape(-1)  # edge k of triangle t is row 3t + k
    b = tri[:, [2, 0, 1]].reshape(-1)
    n_verts = int(tri.max()) + 1 if n_tris else 1
    key = torch.minimum(a, b) * n_verts + torch.maximum(a, b)
    order = torch.argsort(key, stable=True)
    sorted_key = key[order]
    same_as_next = torch.zeros_like(sorted_key, dtype=torch.bool)
    same_as_next[:-1] = sorted_key[1:] == sorted_key[:-1]
    same_as_prev = torch.zeros_like(same_as_next)
    same_as_prev[1:] = same_as_next[:-1]
    position = torch.arange(order.numel(), device=tri.device)
    partner_pos = torch.where(same_as_next, position + 1, torch.where(same_as_prev, position - 1, -1))
    partner = torch.full_like(order, -1)
    has_partner = partner_pos >= 0
    partner[order[has_partner]] = order[partner_pos[has_partner]]
    # the partner edge row 3n + k' belongs to triangle n, and its opposite vertex is tri[n, k']
    valid = partner >= 0
    opposite = torch.full((n_tris * 3,), -1, dtype=torch.int64, device=tri.device)
    opposite[valid] = tri.reshape(-1)[partner[valid]]
    neighbour = torch.where(valid, partner // 3, -1)
    return EdgeTopology(opposite.reshape(n_tris, 3), neighbour.reshape(n_tris, 3))
