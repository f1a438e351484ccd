"""Triangle meshes with one index buffer per attribute (as in OBJ).

Position topology stays welded: a UV seam duplicates texture coordinates, a hard edge duplicates
normal slots, never positions, so the Laplacian and the antialiaser see shared vertices. Unweld
only when exporting.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import torch

from .normals import split_normals


@dataclass
class Mesh:
    """A triangle mesh.

    Attributes (T triangles):
        v_pos: ``[V, 3]`` float32 positions, in the asset's own frame and units.
        t_pos_idx: ``[T, 3]`` int64 indices into ``v_pos``, counter-clockwise front faces.
        uv: list of UV sets; set ``k`` is a pair ``(v_tex [VT_k, 2] float32,
            t_tex_idx [T, 3] int64)``, glTF convention (``(0, 0)`` = top-left of the image).
        t_nrm_idx: optional ``[T, 3]`` int64 normal slot of each corner: the corners sharing a
            slot form one smoothing group, and every slot is used at one position only (so a
            hard edge is two slots at each of its ends). ``None``: one slot per position
            (``t_pos_idx``), smooth everywhere.
        v_nrm: optional ``[VN, 3]`` float32 authored unit normals of the slots (as read from a
            file), valid for the positions they were authored with; ``None``: each slot's
            normal is recomputed from the current positions (split smooth normals,
            ``lookalike.asset.normals.split_normals``). ``normals()`` gives the ones in use.
        v_color: optional ``[V, 4]`` linear RGBA vertex colours (scans), indexed by ``t_pos_idx``.
        t_mat_idx: ``[T]`` int64 material index of each triangle.
        v_joints, v_weights: optional skinning influences ``[V, K]`` int64 / float32 (K = 4
            per glTF set; several sets are concatenated), indexed like ``v_pos``.
    """

    v_pos: torch.Tensor
    t_pos_idx: torch.Tensor
    uv: list[tuple[torch.Tensor, torch.Tensor]] = field(default_factory=list)
    v_nrm: torch.Tensor | None = None
    t_nrm_idx: torch.Tensor | None = None
    v_color: torch.Tensor | None = None
    t_mat_idx: torch.Tensor | None = None
    v_joints: torch.Tensor | None = None
    v_weights: torch.Tensor | None = None

    def __post_init__(self):
        if self.v_nrm is not None and self.t_nrm_idx is None:
            raise ValueError("authored normals v_nrm need their corner index t_nrm_idx")
        if self.t_mat_idx is None:
            self.t_mat_idx = torch.zeros(self.t_pos_idx.shape[0], dtype=torch.int64)

    @property
    def num_vertices(self) -> int:
        return int(self.v_pos.shape[0])

    @property
    def num_triangles(self) -> int:
        return int(self.t_pos_idx.shape[0])

    @property
    def num_normals(self) -> int:
        """``VN``, the number of normal slots."""
        if self.v_nrm is not None:
            return int(self.v_nrm.shape[0])
        if self.t_nrm_idx is None:
            return self.num_vertices
        return int(self.t_nrm_idx.max()) + 1 if self.t_nrm_idx.numel() else 0

    def normals(self) -> tuple[torch.Tensor, torch.Tensor]:
        """The shading normals: ``(v_nrm [VN, 3], t_nrm_idx [T, 3] int64)``, the authored ones
        where the mesh has them, else split smooth normals of the current positions per slot
        (differentiable with respect to ``v_pos``); dtype and device of ``v_pos``."""
        t_nrm_idx = self.t_pos_idx if self.t_nrm_idx is None else self.t_nrm_idx
        if self.v_nrm is not None:
            return self.v_nrm.to(self.v_pos), t_nrm_idx
        return split_normals(self.v_pos, self.t_pos_idx, t_nrm_idx, self.num_normals), t_nrm_idx

    @property
    def v_tex(self) -> torch.Tensor | None:
        """``[VT, 2]`` texture coordinates of UV set 0, or ``None``."""
        return self.uv[0][0] if self.uv else None

    @property
    def t_tex_idx(self) -> torch.Tensor | None:
        """``[T, 3]`` texture-coordinate indices of UV set 0, or ``None``."""
        return self.uv[0][1] if self.uv else None

    def bounds(self) -> tuple[torch.Tensor, torch.Tensor]:
        """Axis-aligned bounds ``([3] min, [3] max)`` of the referenced vertices."""
        used = self.v_pos[self.t_pos_idx.reshape(-1)]
        return used.min(dim=0).values, used.max(dim=0).values

    def bounding_sphere(self) -> tuple[torch.Tensor, float]:
        """Centre ``[3]`` (of the bounding box) and radius enclosing every referenced vertex."""
        lo, hi = self.bounds()
        centre = 0.5 * (lo + hi)
        radius = float((self.v_pos[self.t_pos_idx.reshape(-1)] - centre).norm(dim=-1).max())
        return centre, radius

    def with_positions(self, v_pos: torch.Tensor) -> "Mesh":
        """The same topology and attributes with new positions ``[V, 3]`` (e.g. skinned): normal
        slots are kept, authored normal values dropped (they are recomputed from ``v_pos``)."""
        return replace(self, v_pos=v_pos, v_nrm=None)

    def detach(self) -> "Mesh":
        """A copy whose tensors carry no autograd history."""
        def d(x):
            return None if x is None else x.detach()
        return Mesh(
            v_pos=d(self.v_pos), t_pos_idx=self.t_pos_idx,
            uv=[(d(v), i) for v, i in self.uv],
            v_nrm=d(self.v_nrm), t_nrm_idx=self.t_nrm_idx, v_color=d(self.v_color),
            t_mat_idx=self.t_mat_idx, v_joints=self.v_joints, v_weights=d(self.v_weights),
        )
