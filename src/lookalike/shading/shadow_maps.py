"""Deep opacity shadow maps: how much of each view's point light reaches a shading point
through the asset, so that its parts shadow each other (leaves on leaves, on a trunk) as an
offline renderer's point light shows them, and so that alpha trained on cards changes the
shadows they cast.

Building (``deep_shadow_map``): for each light ``L_b`` (``PointLight.position [L, 3]``), a
perspective camera at ``L_b`` looks at the centre ``c`` of the asset's bounding sphere (radius
``r``) with the field of view that just holds the sphere (half-angle ``asin(r / |L_b - c|)``, at
most ``MAX_HALF_ANGLE``), and the asset is depth-peeled from it (``dr.DepthPeeler``) into K
layers of S x S pixels. Layer k keeps per pixel the distance ``d_k = |x_k - L_b|`` of its
fragment ``x_k`` from the light and the fragment's alpha ``a_k`` as its material gives it
(OPAQUE 1; MASK the test, with the material lookup's straight-through gradient; BLEND ``kd.a``),
both with gradients; a pixel with no fragment in a layer has ``a_k = 0``. Both faces of every
material cast shadows, as in a path tracer, whose shadow rays meet either face.

Lookup (``DeepShadowMap.transmittance``): a point ``p`` of view b at distance
``rho = |p - L_b|`` from its light, at continuous light pixel ``(u, v)``, lets through

    T(p) = sum_t w_t prod_k (1 - a_k[t] s((rho - d_k[t] - bias) / softness)),

``t`` over the 4 light pixels around ``(u, v)`` with bilinear weights ``w_t``, ``s`` the
smoothstep ``3x^2 - 2x^3`` on ``[0, 1]`` (0 below, 1 above): each light pixel's transmittance
along its ray at ``p``'s distance, interpolated bilinearly. Interpolating the pixels'
transmittances rather than their depths and alphas keeps a silhouette from being blended with
the empty pixels beside it or with a surface far behind it (percentage-closer filtering).
With ``f = rho * pixel_width`` the width of a light pixel at ``p``'s distance
(``pixel_width = 2 tan(half-angle) / S``) and ``theta`` the angle between ``p``'s geometric
normal and the direction to the light, ``bias = f (BIAS + SLOPE_BIAS min(tan theta,
MAX_SLOPE))`` and ``softness = SOFTNESS f``: the fragments of ``p``'s own surface at the pixels
around ``p`` lie within ``sqrt(2) f tan theta`` of ``rho``, so a surface does not shadow itself
(no acne), and since the smoothstep is exactly 0 there, a surface no other part shadows is as
bright as without shadows. Points outside the light's frustum (behind the light, or off its
picture) have ``T = 1``. ``T`` is differentiable in the layers' alphas (so in the texels) and
depths, and in ``p``; the maps' coverage is not antialiased, so a shadow's outline follows the
occluder's positions without a gradient in them.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import torch

import lookalike.render as dr

from .camera import Camera, look_at, perspective
from .gbuffer import GBuffer, MeshBuffers
from .light import PointLight
from .surface import sample_surface
from .texturing import TextureSampler
from .view_sampling import UP

BIAS = 1.0
SLOPE_BIAS = 1.5
SOFTNESS = 1.0
"""The depth comparison's offset ``f (BIAS + SLOPE_BIAS tan theta)`` and ramp width
``SOFTNESS f``, in light pixel widths ``f`` (module docstring); ``SLOPE_BIAS`` exceeds
``sqrt(2)``, the farthest a bilinear tap lies from the point along its surface."""

MAX_SLOPE = 10.0
"""``tan theta`` is taken at most this (84 degrees): at grazing light the offset would grow
without bound, and such points get little light anyway."""

MAX_HALF_ANGLE = math.radians(80.0)
"""The widest half field of view of a light camera, for a light within (or nearly on) the
bounding sphere; what lies outside its picture is unshadowed."""

NEAR_SHARE = 1e-3
"""A light camera's near plane is at least this share of its distance to the centre."""


@dataclass(frozen=True)
class ShadowMapping:
    """How a render's deep opacity shadow maps are drawn: ``layers`` (K) depth-peeled layers of
    ``resolution`` x ``resolution`` (S) pixels per light."""

    layers: int = 4
    resolution: int = 256


@dataclass
class DeepShadowMap:
    """The deep opacity shadow maps of L lights (module docstring).

    Attributes:
        light: ``[L, 3]`` light positions (with their gradient, where they have one).
        mvp: ``[L, 4, 4]`` world-to-clip matrices of the light cameras (no gradient).
        pixel_width: ``[L]`` width of a light pixel per unit distance, ``2 tan(half-angle) / S``.
        distance: ``[L * S * S, K]`` distance from the light of each layer's fragment (0 where
            none), pixels in the rasterizer's memory order (a pixel's layers side by side, for
            the lookup's gathers).
        alpha: ``[L * S * S, K]`` the fragments' alpha (0 where none).
        resolution: S.
    """

    light: torch.Tensor
    mvp: torch.Tensor
    pixel_width: torch.Tensor
    distance: torch.Tensor
    alpha: torch.Tensor
    resolution: int

    def transmittance(self, position: torch.Tensor, view: torch.Tensor,
                      geometric_normal: torch.Tensor) -> torch.Tensor:
        """``[N, 1]`` share ``T`` of its view's light that reaches each of N points (module
        docstring).

        Args:
            position: ``[N, 3]`` world positions; view: ``[N]`` int64 view (light) index;
            geometric_normal: ``[N, 3]`` unit face normals (their sign does not matter).
        """
        size = self.resolution
        slot = view if self.light.shape[0] > 1 else torch.zeros_like(view)
        to_light = self.light.to(position)[slot] - position
        rho = to_light.norm(dim=-1)
        homogeneous = torch.cat([position, torch.ones_like(position[:, :1])], dim=-1)
        clip = (homogeneous @ self.mvp.to(position).transpose(1, 2)).gather(0, slot[None, :, None].expand(1, -1, 4))[0]
        ahead = clip[:, 3] > 0
        w = torch.where(ahead, clip[:, 3], 1.0)
        u = ((clip[:, 0] / w + 1.0) * (size / 2) - 0.5).clamp(-1.0, size)  # off the picture: every tap outside
        v = ((clip[:, 1] / w + 1.0) * (size / 2) - 0.5).clamp(-1.0, size)
        u0, v0 = u.detach().floor(), v.detach().floor()
        bias, softness = self._tolerance(rho, to_light, geometric_normal, slot)
        # [N, 1]: fragments nearer the light than ``start`` shadow the point, fully from ``softness`` nearer
        start, softness = (rho - bias)[:, None], softness[:, None]
        total = torch.zeros_like(rho)
        for du, dv in ((0, 0), (1, 0), (0, 1), (1, 1)):
            weight = (u - u0 if du else 1.0 - (u - u0)) * (v - v0 if dv else 1.0 - (v - v0))
            column, row = (u0 + du).long(), (v0 + dv).long()
            inside = ahead & (column >= 0) & (column < size) & (row >= 0) & (row < size)
            index = (slot * size + row.clamp(0, size - 1)) * size + column.clamp(0, size - 1)
            alpha = self.alpha.index_select(0, index) * inside[:, None]
            blocked = smoothstep((start - self.distance.index_select(0, index)) / softness)
            total = total + weight * torch.prod(1.0 - alpha * blocked, dim=1)
        return total[:, None]

    def _tolerance(self, rho: torch.Tensor, to_light: torch.Tensor, geometric_normal: torch.Tensor,
                   slot: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``(bias [N], softness [N])`` of the depth comparison (module docstring), without
        gradient: a tolerance, not a quantity of the scene."""
        with torch.no_grad():
            footprint = rho * self.pixel_width.to(rho)[slot]
            cosine = ((geometric_normal * to_light).sum(dim=-1).abs() / rho.clamp(min=1e-30)).clamp(max=1.0)
            slope = ((1.0 - cosine ** 2).sqrt() / cosine.clamp(min=1.0 / MAX_SLOPE)).clamp(max=MAX_SLOPE)
            return footprint * (BIAS + SLOPE_BIAS * slope), footprint * SOFTNESS


def smoothstep(x: torch.Tensor) -> torch.Tensor:
    """``3t^2 - 2t^3`` with ``t = clamp(x, 0, 1)``: 0 below 0, 1 above 1, smooth between."""
    t = x.clamp(0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def light_cameras(light: torch.Tensor, centre: torch.Tensor, radius: float,
                  resolution: int) -> tuple[Camera, torch.Tensor]:
    """``(cameras, pixel_width [L])``: L cameras at ``light [L, 3]`` (detached) looking at
    ``centre [3]``, each with the square field of view that just holds the sphere of ``radius``
    around it (half-angle ``asin(radius / distance)``, at most ``MAX_HALF_ANGLE``) and near and
    far planes around it; ``pixel_width = 2 tan(half-angle) / resolution``."""
    eye = light.detach()
    target = centre.detach().to(eye).expand_as(eye)
    projections, widths = [], []
    for distance in (eye - target).norm(dim=-1).tolist():
        half = min(math.asin(min(radius / max(distance, 1e-30), 1.0)), MAX_HALF_ANGLE)
        near = max(distance - radius, NEAR_SHARE * distance)
        projections.append(perspective(2.0 * half, 1.0, near, distance + radius))
        widths.append(2.0 * math.tan(half) / resolution)
    camera = Camera(mv=look_at(eye, target, UP), proj=torch.stack(projections).to(eye), position=eye)
    return camera, eye.new_tensor(widths)


def deep_shadow_map(asset, buffers: MeshBuffers, light: PointLight, sampler: TextureSampler,
                    mapping: ShadowMapping) -> DeepShadowMap:
    """The deep opacity shadow maps of ``light`` (L lights) over ``asset`` (its ``mesh``,
    ``materials`` and, where it has one, ``source``), whose per-render vertex data are
    ``buffers`` (their clip positions are replaced by the light cameras'), its texels sampled by
    the render's ``sampler``; ``mapping`` sets K and S. Differentiable in the positions and
    texels (module docstring)."""
    with torch.no_grad():
        centre, radius = buffers.mesh.bounding_sphere()
    camera, pixel_width = light_cameras(light.position, centre, radius, mapping.resolution)
    seen = dataclasses.replace(buffers.with_camera(camera), tangents={})  # alpha needs no tangent frames
    size = (mapping.resolution, mapping.resolution)
    gbuffers = []
    # all K layers in one pass: its k-buffer takes as many bytes as the maps themselves
    with dr.DepthPeeler(dr.RasterizeContext(), seen.clip, seen.tri, size, layers=mapping.layers) as peeler:
        for _ in range(mapping.layers):
            rast, rast_db = peeler.rasterize_next_layer()
            if not bool((rast[..., 3] > 0).any()):
                break
            gbuffers.append(GBuffer.build(seen, rast, rast_db))
    pixels = camera.batch_size * size[0] * size[1]
    distance = seen.clip.new_zeros(pixels * mapping.layers)
    alpha = seen.clip.new_zeros(pixels * mapping.layers)
    if gbuffers:
        gb = GBuffer.concatenate(gbuffers)
        counts = torch.tensor([part.pixel.shape[0] for part in gbuffers], device=gb.pixel.device)
        flat = gb.pixel * mapping.layers + torch.repeat_interleave(torch.arange(len(gbuffers), device=gb.pixel.device),
                                                                   counts)
        to_light = light.position.to(gb.position)[gb.view] - gb.position
        distance = distance.index_put((flat,), to_light.norm(dim=-1))
        alpha = alpha.index_put((flat,), fragment_alpha(asset, gb, sampler))
    return DeepShadowMap(light=light.position, mvp=camera.mvp, pixel_width=pixel_width,
                         distance=distance.reshape(pixels, mapping.layers), alpha=alpha.reshape(pixels, mapping.layers),
                         resolution=mapping.resolution)


def fragment_alpha(asset, gb: GBuffer, sampler: TextureSampler) -> torch.Tensor:
    """``[N]`` alpha of the points of ``gb`` as ``asset``'s materials give it, on either face
    (1 without a lookup where every material is OPAQUE)."""
    if all(m.alpha_mode == "OPAQUE" for m in asset.materials):
        return gb.position.new_ones(gb.position.shape[0])
    surface = sample_surface(asset.materials, asset.mesh.t_mat_idx, gb, sampler, getattr(asset, "source", None))
    return surface.alpha[:, 0]
