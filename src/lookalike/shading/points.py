"""Shading the points of a G-buffer: their light-independent inputs (``SurfacePoints``: the
normal-mapped shading normal facing the viewer, the material, the coverage that back faces
and the alpha mode leave) and their radiance under a point light."""

from __future__ import annotations

from dataclasses import dataclass

import torch

from ..asset.normals import safe_normalize
from .camera import Camera
from .gbuffer import GBuffer
from .light import PointLight
from .normal_map import shading_normal
from .point_lighting import lit_radiance
from .surface import Surface


def _dot(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    return (a * b).sum(dim=-1, keepdim=True)


@dataclass
class SurfacePoints:
    """What shading needs of N G-buffer points that does not depend on the light (so a
    G-buffer can be lit again under other lights).

    Attributes:
        view: ``[N]`` int64 view (batch) index.
        position: ``[N, 3]`` world positions.
        normal: ``[N, 3]`` unit shading normal: normal-mapped, flipped on back faces, bent
            towards the viewer (``normal_map``).
        geometric_normal: ``[N, 3]`` unit face normal, flipped on back faces (the horizon test's).
        view_dir: ``[N, 3]`` unit direction to the camera.
        kd: ``[N, 3]`` linear base colour; ks: ``[N, 3]`` (gamma, roughness, metalness).
        emissive: ``[N, 3]`` linear emission, or ``None``.
        alpha: ``[N, 1]`` coverage (0 on culled back faces).
    """

    view: torch.Tensor
    position: torch.Tensor
    normal: torch.Tensor
    geometric_normal: torch.Tensor
    view_dir: torch.Tensor
    kd: torch.Tensor
    ks: torch.Tensor
    emissive: torch.Tensor | None
    alpha: torch.Tensor


def surface_points(gb: GBuffer, surface: Surface, camera: Camera) -> SurfacePoints:
    """The light-independent shading inputs of the G-buffer's pixels (see ``SurfacePoints``)."""
    view_dir, front = facing_viewer(gb, camera)
    facing = torch.where(front, 1.0, -1.0).to(view_dir)
    normal = shading_normal(gb.normal, *_normal_map_inputs(gb, surface), gb.geometric_normal, view_dir, facing[:, 0])
    return SurfacePoints(view=gb.view, position=gb.position, normal=normal, geometric_normal=gb.geometric_normal * facing,
                         view_dir=view_dir, kd=surface.kd[:, :3], ks=surface.ks, emissive=surface.emissive,
                         alpha=visible_alpha(surface, front))


def facing_viewer(gb: GBuffer, camera: Camera) -> tuple[torch.Tensor, torch.Tensor]:
    """``(view_dir [N, 3], front [N, 1] bool)``: the unit direction from each pixel's point to
    its camera, and whether the point's face is turned towards it."""
    view_dir = safe_normalize(camera.position.to(gb.position)[gb.view] - gb.position)
    return view_dir, _dot(gb.geometric_normal, view_dir) >= 0


def visible_alpha(surface: Surface, front: torch.Tensor) -> torch.Tensor:
    """``[N, 1]`` coverage: the material's alpha, 0 on the back faces of single-sided materials."""
    return surface.alpha * (front | surface.double_sided[:, None]).to(surface.alpha)


def _normal_map_inputs(gb: GBuffer, surface: Surface) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """``(tangent [N, 4], tangent_space [N, 3], mapped [N] bool)`` for ``shading_normal``: each
    pixel's tangent frame of the UV set its normal map uses, and its normal-map value."""
    mapped = torch.zeros(gb.position.shape[0], dtype=torch.bool, device=gb.position.device)
    if surface.normal_map is None or not gb.tangent:
        return gb.position.new_zeros(mapped.shape[0], 4), gb.position.new_zeros(mapped.shape[0], 3), mapped
    tangent = None
    for uv_set, frame in gb.tangent.items():
        rows = surface.normal_uv_set == uv_set
        tangent = frame if tangent is None else torch.where(rows[:, None], frame, tangent)
        mapped = mapped | rows
    return tangent, surface.normal_map, mapped


def light_points(points: SurfacePoints, light: PointLight, transmittance: torch.Tensor | None = None) -> torch.Tensor:
    """Straight-alpha colour ``[N, 4]`` (linear radiance, coverage) of ``points`` under
    ``light``: ``lit_radiance`` (``bsdf.shade(kd, ks, n, v, l) * irradiance``, compiled), times
    ``transmittance [N, 1]`` where given (the share of the light that reaches each point past
    shadowing parts, ``lookalike.shading.shadow_maps``; exact, the radiance being linear in the
    light's irradiance), + emissive, no light where the view's horizon test finds the light
    below the geometric surface."""
    radiance = lit_radiance(points.kd, points.ks, points.normal, points.view_dir, points.position,
                            points.geometric_normal, points.view, light)
    if transmittance is not None:
        radiance = radiance * transmittance
    if points.emissive is not None:
        radiance = radiance + points.emissive
    return torch.cat([radiance, points.alpha], dim=-1)
