"""The deferred G-buffer: per covered pixel, the surface attributes the shader needs.

Pixels are kept as a flat list of the covered ones (``rast`` triangle id > 0) in the
rasterizer's memory order (row 0 = clip-space y = -1), so texturing and shading cost scales
with coverage, not with the image size.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import torch

import lookalike.render as dr

from ..asset.mesh import Mesh
from ..asset.normals import face_normals, safe_normalize
from ..asset.tangents import vertex_tangents
from .camera import Camera


@dataclass
class MeshBuffers:
    """Per-render vertex data derived from a mesh (the differentiable mesh operations).

    Attributes (V vertices, VN normal slots, T triangles, B views):
        mesh: the source mesh.
        tri: ``[T, 3]`` int64 position triangles (the rasterizer takes int32 too, but converts
            it on every call, which costs a noticeable share of a large reference's view).
        clip: ``[B, V, 4]`` clip-space positions (``None`` in ``without_camera``'s buffers).
        v_nrm: ``[VN, 3]`` shading normals (``Mesh.normals``: authored, or split smooth normals
            of the current positions).
        t_nrm_idx: ``[T, 3]`` int64 normal slot of each corner.
        face_nrm: ``[T, 3]`` unit geometric (face) normals.
        uv: per UV set ``(v_tex [VT, 2], t_tex_idx [T, 3] int64)``.
        tangents: ``{uv set: (v_tng [N, 4], t_tng_idx [T, 3] int64)}`` for the UV sets that
            normal maps use.
    """

    mesh: Mesh
    tri: torch.Tensor
    clip: torch.Tensor | None
    v_nrm: torch.Tensor
    t_nrm_idx: torch.Tensor
    face_nrm: torch.Tensor
    uv: list[tuple[torch.Tensor, torch.Tensor]]
    tangents: dict[int, tuple[torch.Tensor, torch.Tensor]]

    @staticmethod
    def build(mesh: Mesh, camera: Camera, tangent_uv_sets: set[int]) -> MeshBuffers:
        """Shading normals, face normals, clip positions, and tangent frames
        (``lookalike.asset.tangents.vertex_tangents``) for ``tangent_uv_sets``."""
        return MeshBuffers.without_camera(mesh, tangent_uv_sets).with_camera(camera)

    @staticmethod
    def without_camera(mesh: Mesh, tangent_uv_sets: set[int]) -> MeshBuffers:
        """``build`` less the clip positions (``clip`` is ``None``): what a mesh that never moves
        needs computing only once (``with_camera`` adds the rest)."""
        v_nrm, t_nrm_idx = mesh.normals()
        tangents = {}
        for k in sorted(tangent_uv_sets):
            v_tex, t_tex_idx = mesh.uv[k]
            v_tng, t_tng_idx = vertex_tangents(mesh.v_pos, mesh.t_pos_idx, v_tex, t_tex_idx, v_nrm, t_nrm_idx)
            tangents[k] = (v_tng, t_tng_idx.long())
        return MeshBuffers(
            mesh=mesh,
            tri=mesh.t_pos_idx.long(),
            clip=None,
            v_nrm=v_nrm,
            t_nrm_idx=t_nrm_idx.long(),
            face_nrm=safe_normalize(face_normals(mesh.v_pos, mesh.t_pos_idx)),
            uv=[(v_tex, t_tex_idx.long()) for v_tex, t_tex_idx in mesh.uv],
            tangents=tangents,
        )

    def with_camera(self, camera: Camera) -> MeshBuffers:
        """These buffers with the clip positions ``[B, V, 4]`` of ``camera``."""
        return dataclasses.replace(self, clip=camera.clip(self.mesh.v_pos))


@dataclass
class GBuffer:
    """Attributes of the N covered pixels of one rasterized layer (or of several, concatenated).

    Attributes:
        pixel: ``[N]`` int64 flat indices into ``[B, H, W]``.
        view: ``[N]`` int64 view (batch) index.
        triangle: ``[N]`` int64 triangle index.
        position: ``[N, 3]`` world positions.
        normal: ``[N, 3]`` interpolated shading normals (not normalised).
        geometric_normal: ``[N, 3]`` unit face normals.
        uv: per UV set ``(uv [N, 2], uv_da [N, 4])``.
        tangent: ``{uv set: [N, 4]}`` interpolated tangents (``w`` = handedness).
        color: ``[N, 4]`` interpolated vertex colours, or ``None``.
    """

    pixel: torch.Tensor
    view: torch.Tensor
    triangle: torch.Tensor
    position: torch.Tensor
    normal: torch.Tensor
    geometric_normal: torch.Tensor
    uv: list[tuple[torch.Tensor, torch.Tensor]]
    tangent: dict[int, torch.Tensor]
    color: torch.Tensor | None

    @staticmethod
    def build(buffers: MeshBuffers, rast: torch.Tensor, rast_db: torch.Tensor,
              needed: torch.Tensor | None = None) -> GBuffer:
        """Interpolate every attribute of ``buffers`` over ``rast [B, H, W, 4]`` (with
        ``rast_db [B, H, W, 4]`` for UV derivatives) and keep the covered pixels (those of
        them where ``needed [B, H, W]`` bool is set, when given)."""
        _, height, width = rast.shape[:3]
        triangle_flat = rast[..., 3].reshape(-1).long() - 1
        keep = triangle_flat >= 0 if needed is None else (triangle_flat >= 0) & needed.reshape(-1)
        pixel = torch.nonzero(keep).reshape(-1)

        def at_pixels(attr, tri, **derivatives):
            return dr.interpolate_at(attr, rast, tri, pixel, **derivatives)

        mesh = buffers.mesh
        vertex_attrs = [mesh.v_pos] + ([mesh.v_color] if mesh.v_color is not None else [])
        interpolated = at_pixels(torch.cat(vertex_attrs, dim=-1), buffers.tri)[0]
        normal = at_pixels(buffers.v_nrm, buffers.t_nrm_idx)[0]
        uv = [at_pixels(v_tex, t_tex_idx, rast_db=rast_db, diff_attrs="all") for v_tex, t_tex_idx in buffers.uv]
        tangent = {k: at_pixels(v_tng, t_tng_idx)[0] for k, (v_tng, t_tng_idx) in buffers.tangents.items()}
        triangle = triangle_flat[pixel]
        return GBuffer(
            pixel=pixel,
            view=torch.div(pixel, height * width, rounding_mode="floor"),
            triangle=triangle,
            position=interpolated[:, 0:3],
            normal=normal,
            geometric_normal=buffers.face_nrm[triangle],
            uv=uv,
            tangent=tangent,
            color=interpolated[:, 3:7] if mesh.v_color is not None else None,
        )

    @staticmethod
    def concatenate(parts: list[GBuffer]) -> GBuffer:
        """The points of ``parts`` in one G-buffer, in order (each part's ``pixel`` indices keep
        pointing into that part's own image), so that they are textured and shaded together."""
        if len(parts) == 1:
            return parts[0]

        def cat(values):
            return torch.cat(list(values))

        first = parts[0]
        return GBuffer(
            pixel=cat(p.pixel for p in parts),
            view=cat(p.view for p in parts),
            triangle=cat(p.triangle for p in parts),
            position=cat(p.position for p in parts),
            normal=cat(p.normal for p in parts),
            geometric_normal=cat(p.geometric_normal for p in parts),
            uv=[(cat(p.uv[k][0] for p in parts), cat(p.uv[k][1] for p in parts)) for k in range(len(first.uv))],
            tangent={k: cat(p.tangent[k] for p in parts) for k in first.tangent},
            color=None if first.color is None else cat(p.color for p in parts),
        )
