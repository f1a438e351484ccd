"""Pictures of an implicit surface (``lookalike.asset.implicit``) by sphere tracing (Hart 1996),
shaded by the same BSDF and point lights as the rasterizer's (paper Sec. 5.5: any renderer can
be the reference).

Each sample's ray steps from where it enters the field's bounds by the field's value, ``t +=
sdf(o + t d)``, until that value falls below ``HIT_FRACTION`` of the sample's footprint at ``t``
(a hit), or ``t`` leaves the bounds (a miss); only the rays still marching are evaluated. The
fraction is small because a ray that passes within it of the surface counts as a hit: each
silhouette grows outward by that much, and a fit to such pictures learns a fatter outline than the
field's (or any fine mesh of it) has. At a hit, the normal is the field's gradient
(``lookalike.asset.implicit.field_normals``) and the material is the field's; the light is
unshadowed, as the rasterizer's is. Coverage (the share of samples that hit) is the alpha.
"""

from __future__ import annotations

import torch

from ..asset.implicit import field_normals
from .camera import Camera
from .light import PointLight
from .pipeline import box_downsample
from .point_lighting import lit_radiance

HIT_FRACTION = 0.01
"""A ray hits where the field's value is below this fraction of its sample's footprint."""

MAX_STEPS = 512
"""Steps a ray marches at most; a ray still marching then misses (a grazing ray that has not come
within ``HIT_FRACTION`` of the surface)."""


def primary_rays(camera: Camera, height: int, width: int) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Rays through the pixel centres of B cameras: ``(origins [B, H*W, 3], unit directions
    [B, H*W, 3], footprint [B, H*W])``, row 0 at the top of the picture, pixels in row-major
    order; ``footprint`` is a pixel's width per unit distance along the ray."""
    ys = 1.0 - (torch.arange(height, dtype=torch.float32) + 0.5) * (2.0 / height)
    xs = (torch.arange(width, dtype=torch.float32) + 0.5) * (2.0 / width) - 1.0
    y, x = torch.meshgrid(ys, xs, indexing="ij")
    far = torch.stack([x, y, torch.ones_like(x), torch.ones_like(x)], dim=-1).reshape(-1, 4)
    inverse = torch.linalg.inv(camera.mvp.double()).float()  # [B, 4, 4]
    points = far @ inverse.transpose(1, 2)  # [B, H*W, 4]
    directions = points[..., :3] / points[..., 3:] - camera.position[:, None, :]
    directions = directions / directions.norm(dim=-1, keepdim=True)
    origins = camera.position[:, None, :].expand_as(directions)
    # a pixel spans 2 / (H * P[1, 1]) of the view-space y at unit depth, along the axis; off it,
    # over the ray's distance, it shrinks by the cosine to the axis
    forward = -camera.mv[:, 2, :3]  # [B, 3]
    cosine = (directions * forward[:, None, :]).sum(-1)
    footprint = 2.0 / (height * camera.proj[:, 1, 1])[:, None] * cosine
    return origins, directions, footprint


def box_span(origins: torch.Tensor, directions: torch.Tensor, lo: torch.Tensor,
             hi: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Where rays ``[N, 3]`` enter and leave the box ``lo``–``hi``: ``(t_near, t_far)`` ``[N]``
    (slab test; ``t_near >= 0``; ``t_near > t_far`` for a ray that misses it)."""
    inv = 1.0 / torch.where(directions.abs() < 1e-12, torch.full_like(directions, 1e-12), directions)
    t0, t1 = (lo - origins) * inv, (hi - origins) * inv
    near = torch.minimum(t0, t1).max(dim=-1).values.clamp(min=0.0)
    far = torch.maximum(t0, t1).min(dim=-1).values
    return near, far


def sphere_trace(distance, origins: torch.Tensor, directions: torch.Tensor, footprint: torch.Tensor,
                 lo: torch.Tensor, hi: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """March N rays through ``distance`` (``[M, 3] -> [M]``) inside the box ``lo``–``hi``:
    ``(t [N], hit [N] bool)``, ``t`` the distance along each ray to its hit."""
    t, far = box_span(origins, directions, lo, hi)
    hit = torch.zeros_like(t, dtype=torch.bool)
    active = torch.nonzero(t <= far).squeeze(1)
    for _ in range(MAX_STEPS):
        if active.numel() == 0:
            break
        ta = t[active]
        value = distance(origins[active] + ta[:, None] * directions[active])
        close = value < HIT_FRACTION * footprint[active] * ta
        hit[active[close]] = True
        ta = ta + value.clamp(min=0.0)
        t[active] = ta
        going = ~close & (ta <= far[active])
        active = active[going]
    return t, hit


def render_field(surface, camera: Camera, light: PointLight, resolution: int, spp: int = 1) -> torch.Tensor:
    """B views of ``surface`` (an ``ImplicitSurface``) at ``resolution`` pixels square with
    ``spp x spp`` samples per pixel: ``[B, H, W, 4]`` linear RGB (premultiplied by coverage, as
    ``pipeline.render`` over no background) and coverage, row 0 at the top; no gradients."""
    size = resolution * spp
    batch = camera.batch_size
    with torch.no_grad():
        origins, directions, footprint = primary_rays(camera, size, size)
        origins, directions, footprint = (x.reshape(-1, *x.shape[2:]) for x in (origins, directions, footprint))
        t, hit = sphere_trace(surface.distance, origins, directions, footprint, surface.lo, surface.hi)
        rows = torch.nonzero(hit).squeeze(1)
        points = origins[rows] + t[rows, None] * directions[rows]
        normals = field_normals(surface, points)
        kd, ks = surface.channels(points)
        view = rows // (size * size)
        radiance = lit_radiance(kd, ks, normals, -directions[rows], points, normals, view, light)
        image = origins.new_zeros(batch * size * size, 4)
        image[rows, :3] = radiance.float()
        image[rows, 3] = 1.0
    return box_downsample(image.reshape(batch, size, size, 4), spp)
