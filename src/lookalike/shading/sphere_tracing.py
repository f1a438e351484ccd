"""Pictures of an implicit surface (``lookalike.asset.implicit``) by sphere tracing (Hart 1996),
shaded by the same BSDF and point lights as the rasterizer's (paper Sec. 5.5: any renderer can
be the reference).

Each sample's ray steps from where it enters the field's bounds by the field's value, ``t +=
sdf(o + t d)``, until that value falls below ``HIT_FRACTION`` of the sample's footprint at ``t``
(a hit), or ``t`` leaves the bounds (a miss); only the rays still marching are evaluated. A
picture's rays first skip the empty space in front of them by cone marching (``cone_starts``):
one cone per tile of samples, then per smaller tile, each marched until the surface may lie
inside it, so that most of the space is crossed by one evaluation per tile, not per sample. The
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

CONE_TILES = (16, 4)
"""Sides, in samples, of the tiles whose cones ``cone_starts`` marches, coarse to fine."""

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


def tiled(x: torch.Tensor, side: int) -> torch.Tensor:
    """``x [B, S, S, ...]`` in square tiles of ``side``: ``[B, T, T, side * side, ...]``, ``T =
    ceil(S / side)``, the last row and column of tiles filled out by repeating the edge samples."""
    b, s = x.shape[:2]
    pad = -s % side
    if pad:
        x = torch.cat([x, x[:, -1:].expand(b, pad, *x.shape[2:])], dim=1)
        x = torch.cat([x, x[:, :, -1:].expand(b, s + pad, pad, *x.shape[3:])], dim=2)
    t = (s + pad) // side
    x = x.reshape(b, t, side, t, side, *x.shape[3:]).transpose(2, 3)
    return x.reshape(b, t, t, side * side, *x.shape[5:])


def untiled(x: torch.Tensor, side: int, size: int) -> torch.Tensor:
    """A value per tile ``[B, T, T]`` given to each of its samples: ``[B, size, size]``."""
    return x.repeat_interleave(side, dim=1).repeat_interleave(side, dim=2)[:, :size, :size]


def cone_march(distance, origins: torch.Tensor, directions: torch.Tensor, footprint: torch.Tensor,
               start: torch.Tensor, far: torch.Tensor, side: int) -> torch.Tensor:
    """How far each ray of a grid may skip: ``start [B, S, S]`` raised to where the cone of its
    tile of ``side`` samples stopped (``inf`` where the cone left every ray's ``far`` first).

    A tile's cone has the axis ``a`` of its rays' mean direction (all from one origin ``o``)
    and the slope ``k = max tan(angle to a) + 2 HIT_FRACTION max footprint``: it holds every
    ray of the tile, widened by the distance at which a ray would count a hit. From the
    tile's least axial start, ``s += (f - k s) / (1 + k)``, ``f = sdf(o + s a)``, until ``f <
    2 k s``: each step stays inside the ball ``f`` drawn around the last point, so no surface
    lies in the cone before ``s``, and each ray may start at distance ``s`` (its axial
    distance at ``s`` is at most ``s``). Stopping at ``2 k s``, not ``k s``, leaves the steps of
    a cone that grazes the surface at least ``k s / (1 + k)``, where they would shrink without
    end; the rays take it from there.

    Args:
        origins, directions: ``[B, S, S, 3]``, one origin per picture; footprint, start, far:
            ``[B, S, S]`` (a ray with ``start > far`` misses).
    """
    size = start.shape[1]
    d = tiled(directions, side)
    axis = torch.nn.functional.normalize(d.sum(dim=3), dim=-1)  # [B, T, T, 3]
    cosine = (d * axis[..., None, :]).sum(-1)
    sine = torch.linalg.cross(d, axis[..., None, :].expand_as(d), dim=-1).norm(dim=-1)
    slope = (sine / cosine).amax(dim=-1) + 2 * HIT_FRACTION * tiled(footprint, side).amax(dim=-1)
    open_ray = tiled(start <= far, side)
    s = torch.where(open_ray, tiled(start, side) * cosine, torch.inf).amin(dim=-1).flatten()
    end = torch.where(open_ray, tiled(far, side), -torch.inf).amax(dim=-1).flatten()
    tiles = axis.shape[:3]
    origin = origins[:, :1, :1].expand(*tiles, 3).reshape(-1, 3)
    axis, slope = axis.reshape(-1, 3), slope.flatten()
    active = torch.nonzero(s <= end).squeeze(1)
    for _ in range(MAX_STEPS):
        if active.numel() == 0:
            break
        sa, ka = s[active], slope[active]
        value = distance(origin[active] + sa[:, None] * axis[active])
        stop = value < 2 * ka * sa
        sa = torch.where(stop, sa, sa + (value - ka * sa) / (1 + ka))
        s[active] = sa
        active = active[~stop & (sa <= end[active])]
    s = torch.where(s > end, torch.inf, s)
    return torch.maximum(start, untiled(s.reshape(tiles), side, size))


def cone_starts(distance, origins: torch.Tensor, directions: torch.Tensor, footprint: torch.Tensor,
                lo: torch.Tensor, hi: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Where each ray of a grid ``[B, S, S, 3]`` (one origin per picture) enters the box
    ``lo``–``hi`` and starts marching, past the cones of ``CONE_TILES`` (``cone_march``):
    ``(start [B, S, S], far [B, S, S])``."""
    start, far = box_span(origins, directions, lo, hi)
    for side in CONE_TILES:
        start = cone_march(distance, origins, directions, footprint, start, far, side)
    return start, far


def sphere_trace(distance, origins: torch.Tensor, directions: torch.Tensor, footprint: torch.Tensor,
                 lo: torch.Tensor, hi: torch.Tensor, start: tuple[torch.Tensor, torch.Tensor] | None = None
                 ) -> tuple[torch.Tensor, torch.Tensor]:
    """March N rays through ``distance`` (``[M, 3] -> [M]``) inside the box ``lo``–``hi``:
    ``(t [N], hit [N] bool)``, ``t`` the distance along each ray to its hit; ``start``: where
    each ray starts and ends marching (``(t0 [N], far [N])``, default: where it enters and
    leaves the box)."""
    t, far = box_span(origins, directions, lo, hi) if start is None else (start[0].clone(), start[1])
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
        grid = (x.reshape(batch, size, size, *x.shape[2:]) for x in (origins, directions, footprint))
        start = (x.flatten() for x in cone_starts(surface.distance, *grid, surface.lo, surface.hi))
        origins, directions, footprint = (x.reshape(-1, *x.shape[2:]) for x in (origins, directions, footprint))
        t, hit = sphere_trace(surface.distance, origins, directions, footprint, surface.lo, surface.hi, tuple(start))
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
