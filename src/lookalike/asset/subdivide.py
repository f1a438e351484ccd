"""Edge-midpoint subdivision (paper, Sec. 5.1): every triangle ``(a, b, c)`` becomes four,

    (a, m_ab, m_ca), (m_ab, b, m_bc), (m_ca, m_bc, c), (m_ab, m_bc, m_ca),

with ``m_xy`` a new vertex at the midpoint of edge ``xy``. Topology is built once (it depends
on no parameter that needs gradients); attribute values are recomputed differentiably on every
call. Each index buffer of a ``Mesh`` (positions, every UV set, normal slots) is subdivided on
its own, so UV seams stay seams, hard edges stay hard and positions stay welded.
"""

from __future__ import annotations

from dataclasses import replace

import torch

from .edges import edge_index
from .mesh import Mesh
from .normals import safe_normalize


class EdgeMidpointTopology:
    """The subdivided topology of one index buffer.

    Attributes:
        num_vertices: ``V`` of the coarse buffer.
        edges: ``[E, 2]`` int64 unique undirected edges of the coarse triangles; fine vertex
            ``V + e`` is the midpoint of edge ``e``.
        t_idx: ``[4T, 3]`` int64 fine triangles; fine triangles ``4t .. 4t+3`` come from
            coarse triangle ``t`` (corner triangles at ``a``, ``b``, ``c``, then the middle one).
    """

    def __init__(self, t_idx: torch.Tensor, num_vertices: int):
        self.edges, side_edge = edge_index(t_idx)
        self.num_vertices = num_vertices
        mid = num_vertices + side_edge  # [T, 3]: m_ab, m_bc, m_ca
        a, b, c = t_idx.unbind(dim=1)
        m_ab, m_bc, m_ca = mid.unbind(dim=1)
        self.t_idx = torch.stack([
            torch.stack([a, m_ab, m_ca], dim=1),
            torch.stack([m_ab, b, m_bc], dim=1),
            torch.stack([m_ca, m_bc, c], dim=1),
            torch.stack([m_ab, m_bc, m_ca], dim=1),
        ], dim=1).reshape(-1, 3)

    def __call__(self, v_attr: torch.Tensor) -> torch.Tensor:
        """Fine vertex attributes ``[V + E, C]``: the coarse ``v_attr [V, C]`` followed by the
        edge midpoints ``(v_attr[e0] + v_attr[e1]) / 2``. Differentiable."""
        midpoints = 0.5 * (v_attr[self.edges[:, 0]] + v_attr[self.edges[:, 1]])
        return torch.cat([v_attr, midpoints], dim=0)

    def restrict(self, fine: torch.Tensor) -> torch.Tensor:
        """Coarse values ``[V]`` from fine ones ``[V + E]``: each coarse vertex's mean over the
        fine vertices it spreads to, weighted as it spreads, ``(f_v + sum_{e at v} f_e / 2) /
        (1 + deg(v) / 2)`` (the adjoint of ``__call__``, rows normalised): a tent filter of the
        fine level's values over the vertex's star. Differentiable."""
        coarse, weights = fine[:self.num_vertices], torch.ones(self.num_vertices, dtype=fine.dtype, device=fine.device)
        halves = 0.5 * fine[self.num_vertices:]
        for end in (0, 1):
            coarse = coarse.index_add(0, self.edges[:, end], halves)
            weights = weights.index_add(0, self.edges[:, end], torch.full_like(halves, 0.5))
        return coarse / weights


class MeshSubdivision:
    """One level of edge-midpoint subdivision for meshes with ``coarse``'s topology.

    ``MeshSubdivision(coarse)(mesh)`` subdivides any mesh with the same index buffers (e.g.
    the same mesh with optimised positions), recomputing positions, UVs, authored normals
    (renormalised; the split smooth normals of a mesh without them follow the fine positions),
    vertex colours and skinning influences. A midpoint vertex takes the
    influences of both edge ends with halved weights (``2K`` slots; original vertices are
    padded with zero weights).
    """

    def __init__(self, coarse: Mesh):
        self.positions = EdgeMidpointTopology(coarse.t_pos_idx, coarse.num_vertices)
        self.uvs = [EdgeMidpointTopology(t_tex_idx, v_tex.shape[0]) for v_tex, t_tex_idx in coarse.uv]
        self.normals = (None if coarse.t_nrm_idx is None
                        else EdgeMidpointTopology(coarse.t_nrm_idx, coarse.num_normals))

    def __call__(self, mesh: Mesh) -> Mesh:
        """The subdivided mesh: ``4T`` triangles, ``t_mat_idx`` repeated per child."""
        pos = self.positions
        if mesh.num_vertices != pos.num_vertices or len(mesh.uv) != len(self.uvs):
            raise ValueError("MeshSubdivision applied to a mesh with a different topology")
        fine = replace(
            mesh,
            v_pos=pos(mesh.v_pos),
            t_pos_idx=pos.t_idx,
            uv=[(topo(v_tex), topo.t_idx) for topo, (v_tex, _) in zip(self.uvs, mesh.uv)],
            t_mat_idx=mesh.t_mat_idx.repeat_interleave(4),
            v_color=None if mesh.v_color is None else pos(mesh.v_color),
        )
        if self.normals is not None:
            fine.t_nrm_idx = self.normals.t_idx
            fine.v_nrm = None if mesh.v_nrm is None else safe_normalize(self.normals(mesh.v_nrm))
        if mesh.v_joints is not None:
            fine.v_joints, fine.v_weights = self._influences(mesh.v_joints, mesh.v_weights)
        return fine

    def _influences(self, v_joints: torch.Tensor, v_weights: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``([V + E, 2K] joints, [V + E, 2K] weights)`` from coarse ``[V, K]`` influences."""
        e0, e1 = self.positions.edges.unbind(dim=1)
        joints = torch.cat([torch.cat([v_joints, torch.zeros_like(v_joints)], dim=1),
                            torch.cat([v_joints[e0], v_joints[e1]], dim=1)], dim=0)
        weights = torch.cat([torch.cat([v_weights, torch.zeros_like(v_weights)], dim=1),
                             0.5 * torch.cat([v_weights[e0], v_weights[e1]], dim=1)], dim=0)
        return joints, weights


def subdivide(mesh: Mesh, levels: int = 1) -> Mesh:
    """``mesh`` subdivided ``levels`` times (``4^levels`` times the triangles). For repeated
    use on changing positions, keep ``MeshSubdivision`` objects instead."""
    for _ in range(levels):
        mesh = MeshSubdivision(mesh)(mesh)
    return mesh
