"""A chess rook as a signed distance field, for ``lookalike simplify examples/rook.py``.

Conventions (lookalike's implicit surfaces): ``sdf(p)`` takes ``[N, 3]`` float32 torch points
and returns ``[N]`` signed distances in the asset's units, negative inside, never larger than the
true distance to the surface (so that sphere tracing can step by it); ``bounds`` is a box that
holds the whole surface; ``material(p)`` gives linear base colour ``[N, 3]`` and optionally
``roughness`` and ``metallic`` ``[N]`` at points on the surface. +y is up.
"""

import math

import torch

bounds = ((-0.5, -0.05, -0.5), (0.5, 1.1, 0.5))


def cylinder(p, radius, y0, y1):
    """A capped vertical cylinder from height y0 to y1."""
    d = torch.stack([torch.sqrt(p[:, 0] ** 2 + p[:, 2] ** 2) - radius,
                     torch.maximum(y0 - p[:, 1], p[:, 1] - y1)], dim=-1)
    return d.clamp(min=0).norm(dim=-1) + d.max(dim=-1).values.clamp(max=0)


def smooth_union(a, b, k):
    h = (0.5 + 0.5 * (b - a) / k).clamp(0, 1)
    return torch.lerp(b, a, h) - k * h * (1 - h)


def sdf(p):
    r = torch.sqrt(p[:, 0] ** 2 + p[:, 2] ** 2)
    base = cylinder(p, 0.40, 0.0, 0.12) - 0.02
    body_radius = 0.30 - 0.06 * (p[:, 1] - 0.12).clamp(0, 0.7) / 0.7
    body = torch.maximum(r - body_radius, torch.maximum(0.12 - p[:, 1], p[:, 1] - 0.85)) * 0.95
    top = cylinder(p, 0.34, 0.82, 1.05) - 0.01
    shape = smooth_union(smooth_union(base, body, 0.05), top, 0.04)
    # grooves: thin rings cut into the body
    groove = torch.sqrt((r - body_radius) ** 2 + (torch.remainder(p[:, 1] - 0.2, 0.12) - 0.06) ** 2) - 0.018
    groove = torch.where((p[:, 1] > 0.2) & (p[:, 1] < 0.76), groove, torch.full_like(groove, 1.0))
    shape = torch.maximum(shape, -groove)
    # the hollow top and its four crenels
    hollow = cylinder(p, 0.25, 0.95, 1.2)
    angle = torch.atan2(p[:, 2], p[:, 0])
    sector = torch.remainder(angle, math.pi / 2) - math.pi / 4
    u = r * torch.sin(sector).abs()
    crenel = torch.maximum(u - 0.07, 0.96 - p[:, 1])
    return torch.maximum(shape, -torch.minimum(hollow, crenel))


def material(p):
    y = p[:, 1]
    stone = torch.stack([0.62 + 0.08 * torch.sin(40 * y + 7 * p[:, 0]),
                         0.55 + 0.06 * torch.sin(40 * y + 7 * p[:, 0]),
                         0.42 + 0.0 * y], dim=-1)
    band = ((y > 0.12) & (y < 0.17)) | ((y > 0.79) & (y < 0.84))
    gold = torch.tensor([0.85, 0.6, 0.2]).expand_as(stone)
    base_color = torch.where(band[:, None], gold, stone)
    return {"base_color": base_color,
            "roughness": torch.where(band, 0.3, 0.6),
            "metallic": torch.where(band, 1.0, 0.0)}
