"""What the renderer sees at given points of an asset's surface: material values and the
shading normal, at points named by triangle and barycentric weights (e.g. ray hits).

The points are handed to the renderer's own material lookup (``lookalike.shading.surface``) as a
G-buffer of "pixels", so UV sets, texture transforms, wrap modes, vertex colours and
per-triangle materials behave exactly as in a render. Lookups are trilinear with an isotropic
footprint: a point that stands for a patch of ``footprint`` world units across reads each
texture at the mip level of that patch, ``du/dx = dv/dy = footprint * sqrt(A_uv / A_world)`` of
its triangle (UV area over world area), so a texture finer than the patch is prefiltered instead
of aliased. The shading normal is the interpolated shading normal (``Mesh.normals``) perturbed by
the material's normal map in our tangent frame (``lookalike.shading.normal_map.perturb_normal``).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from ..asset.asset import Asset
from ..asset.normals import face_normals, safe_normalize
from ..asset.tangents import vertex_tangents
from ..shading.gbuffer import GBuffer
from ..shading.normal_map import perturb_normal
from ..shading.surface import sample_occlusion, sample_surface
from ..shading.texturing import TextureSampler


@dataclass
class SurfaceValues:
    """Material values and shading normals of N surface points (float32).

    Attributes:
        kd: ``[N, 4]`` linear base colour (times the vertex colour where present) and coverage:
            the alpha as the material's alpha mode applies it (OPAQUE 1, MASK 0 or 1, BLEND
            alpha), so one material of the most permissive mode looks the same.
        ks: ``[N, 3]`` (gamma, roughness, metalness).
        emissive: ``[N, 3]`` linear emission, or ``None`` when no material emits.
        normal: ``[N, 3]`` unit world-space shading normals.
        occlusion: ``[N, 1]`` ambient occlusion (1 where a material has none), or ``None``
            when no material has an occlusion map.
    """

    kd: torch.Tensor
    ks: torch.Tensor
    emissive: torch.Tensor | None
    normal: torch.Tensor
    occlusion: torch.Tensor | None = None


def _interpolate(values: torch.Tensor, index: torch.Tensor, bary: torch.Tensor) -> torch.Tensor:
    """``sum_k bary[:, k] * values[index[:, k]]``: ``values [V, C]``, ``index [N, 3]``, ``bary [N, 3]``
    -> ``[N, C]``."""
    return (values[index] * bary[:, :, None]).sum(dim=1)


class ReferenceSurface:
    """Samples ``asset`` (its mesh as stored, e.g. a skinned mesh in its bind pose).

    Per-mesh work (shading normals, tangent frames of the UV sets normal maps use, triangle
    areas) is done once here; ``sample`` then takes any number of points.
    """

    def __init__(self, asset: Asset):
        mesh = asset.mesh.detach()
        self.asset = asset
        self.mesh = mesh
        v_pos = mesh.v_pos.float()
        v_nrm, self.t_nrm_idx = mesh.normals()
        self.v_nrm = v_nrm.float()
        world_area = face_normals(v_pos.double(), mesh.t_pos_idx).norm(dim=-1)
        self.uv_scale = []                                        # per UV set: [T] sqrt(A_uv / A_world)
        for v_tex, t_tex_idx in mesh.uv:
            uv = v_tex.double()[t_tex_idx]
            e1, e2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
            uv_area = (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).abs()
            self.uv_scale.append(torch.sqrt(uv_area / world_area.clamp_min(1e-300)).float())
        normal_sets = {m.normal.uv_set for m in asset.materials
                       if m.normal is not None and m.normal.uv_set < len(mesh.uv)}
        self.tangents = {}
        for k in sorted(normal_sets):
            v_tex, t_tex_idx = mesh.uv[k]
            self.tangents[k] = vertex_tangents(v_pos, mesh.t_pos_idx, v_tex.float(), t_tex_idx, self.v_nrm,
                                               self.t_nrm_idx)

    def sample(self, triangle: torch.Tensor, barycentric: torch.Tensor, footprint: torch.Tensor) -> SurfaceValues:
        """Values at the points ``sum_k barycentric[:, k] * corner_k`` of ``triangle``.

        Args:
            triangle: ``[N]`` int64 triangle indices.
            barycentric: ``[N, 3]`` float corner weights.
            footprint: ``[N]`` float world-space size of the patch each point stands for.
        Returns:
            ``SurfaceValues`` of the N points.
        """
        mesh = self.mesh
        bary = barycentric.float()
        corners = mesh.t_pos_idx[triangle]
        count = triangle.shape[0]
        uv = []
        for (v_tex, t_tex_idx), scale in zip(mesh.uv, self.uv_scale):
            size = (footprint.float() * scale[triangle])[:, None]
            zero = torch.zeros_like(size)
            derivatives = torch.cat([size, zero, zero, size], dim=1)   # (du/dx, du/dy, dv/dx, dv/dy)
            uv.append((_interpolate(v_tex.float(), t_tex_idx[triangle], bary), derivatives))
        tangent = {k: _interpolate(v_tng, t_tng_idx[triangle], bary) for k, (v_tng, t_tng_idx) in self.tangents.items()}
        normal = _interpolate(self.v_nrm, self.t_nrm_idx[triangle], bary)
        gb = GBuffer(
            pixel=torch.arange(count), view=torch.zeros(count, dtype=torch.int64), triangle=triangle,
            position=_interpolate(mesh.v_pos.float(), corners, bary), normal=normal,
            geometric_normal=safe_normalize(face_normals(mesh.v_pos.float(), mesh.t_pos_idx[triangle])),
            uv=uv, tangent=tangent,
            color=None if mesh.v_color is None else _interpolate(mesh.v_color.float(), corners, bary),
        )
        sampler = TextureSampler()
        surface = sample_surface(self.asset.materials, mesh.t_mat_idx, gb, sampler, self.asset.source)
        occlusion = sample_occlusion(self.asset.materials, mesh.t_mat_idx, gb, sampler, self.asset.source)
        shading = safe_normalize(normal)
        if surface.normal_map is not None:
            for uv_set, interpolated in tangent.items():
                rows = torch.nonzero(surface.normal_uv_set == uv_set).reshape(-1)
                shading[rows] = perturb_normal(normal[rows], interpolated[rows], surface.normal_map[rows])
        kd = torch.cat([surface.kd[:, :3], surface.alpha], dim=1)
        return SurfaceValues(kd=kd, ks=surface.ks, emissive=surface.emissive, normal=shading, occlusion=occlusion)
