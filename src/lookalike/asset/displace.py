"""Displacement mapping (paper, Sec. 5.1): ``v_i' = v_i + tex2d(t_i) n_i`` with ``n_i`` the
interpolated (unit) normal and ``t_i`` the texture coordinate of vertex ``i``.

Positions are welded across UV seams, so a vertex can have several texture coordinates; its
displacement is the mean of the displacement-map values at the texture coordinates of all
triangle corners that use it (identical on a seam-consistent map), which keeps the mesh
watertight.
"""

from __future__ import annotations

import torch

from ..shading.texturing import sample_texture
from .material import Texture
from .normals import safe_normalize


def vertex_displacements(num_vertices: int, t_pos_idx: torch.Tensor, v_tex: torch.Tensor,
                         t_tex_idx: torch.Tensor, displacement: Texture) -> torch.Tensor:
    """``[V, 1]`` per-vertex displacement: the bilinear lookup of the 1-channel
    ``displacement`` texture (with its transform and wrap) at every UV vertex ``v_tex [VT, 2]``,
    averaged over the corners ``(t_pos_idx [T, 3], t_tex_idx [T, 3])`` of each position."""
    per_uv = sample_texture(displacement, v_tex)  # [VT, 1]
    corners = t_pos_idx.reshape(-1)
    summed = per_uv.new_zeros(num_vertices, 1).index_add(0, corners, per_uv[t_tex_idx.reshape(-1)])
    count = torch.zeros(num_vertices, 1, dtype=per_uv.dtype, device=per_uv.device)
    count = count.index_add(0, corners, torch.ones_like(summed[corners]))
    return summed / count.clamp(min=1.0)


def displace(v_pos: torch.Tensor, v_nrm: torch.Tensor, t_pos_idx: torch.Tensor, v_tex: torch.Tensor,
             t_tex_idx: torch.Tensor, displacement: Texture) -> torch.Tensor:
    """Displaced positions ``[V, 3]``: ``v_pos + d * normalize(v_nrm)`` with ``d`` from
    ``vertex_displacements``.

    Args:
        v_pos: ``[V, 3]`` positions (e.g. of a subdivided mesh).
        v_nrm: ``[V, 3]`` interpolated normals (e.g. the coarse vertex normals carried through
            subdivision), normalised here.
        t_pos_idx, t_tex_idx: ``[T, 3]`` int64 position and UV triangles.
        v_tex: ``[VT, 2]`` texture coordinates (glTF convention).
        displacement: 1-channel texture of signed distances in the units of ``v_pos``.
    Differentiable in ``v_pos``, ``v_nrm``, ``v_tex`` and ``displacement.data``.
    """
    d = vertex_displacements(v_pos.shape[0], t_pos_idx, v_tex, t_tex_idx, displacement)
    return v_pos + d * safe_normalize(v_nrm)
