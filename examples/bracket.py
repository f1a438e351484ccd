"""A machined aluminium bracket as a signed distance field, for ``lookalike simplify
examples/bracket.py``: hard CSG edges, chamfers, a slot and bores (two counterbored holes in the
base, one through a boss in the upright), painted blue where it was cast and bare metal where it
was machined, so that its colour and metalness change sharply at the edges of every cut.

Conventions (lookalike's implicit surfaces): ``sdf(p)`` takes ``[N, 3]`` float32 torch points
and returns ``[N]`` signed distances in the asset's units, negative inside, never larger than the
true distance to the surface (so that sphere tracing can step by it); ``bounds`` is a box that
holds the whole surface; ``material(p)`` gives linear base colour ``[N, 3]`` and optionally
``roughness`` and ``metallic`` ``[N]`` at points on the surface. +y is up.

Unions (``min``), intersections and cuts (``max``) of exact distances never exceed the true
distance, so the field needs no scaling.
"""

import math

import torch

bounds = ((-0.5, -0.05, -0.36), (0.5, 0.72, 0.36))

MACHINED_WITHIN = 0.008
"""A surface point this close to a cut's surface is machined metal, not paint."""


def box(p, centre, half):
    """An axis-aligned box (exact distance)."""
    q = (p - torch.tensor(centre)).abs() - torch.tensor(half)
    return q.clamp(min=0).norm(dim=-1) + q.max(dim=-1).values.clamp(max=0)


def cylinder(u, v, w, radius, w0, w1):
    """A capped cylinder of ``radius`` around the axis (``u``, ``v``) = 0, from ``w0`` to ``w1`` along it."""
    d = torch.stack([torch.sqrt(u ** 2 + v ** 2) - radius, torch.maximum(w0 - w, w - w1)], dim=-1)
    return d.clamp(min=0).norm(dim=-1) + d.max(dim=-1).values.clamp(max=0)


def parts(p):
    """The solid before it is machined, and each cut, as distances ``[N]``: ``(solid, cuts)``."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    base = box(p, (0.0, 0.06, 0.0), (0.45, 0.06, 0.3))
    base = torch.maximum(base, (x.abs() + z.abs() - 0.69) / math.sqrt(2.0))      # chamfered corners
    upright = box(p, (-0.38, 0.33, 0.0), (0.07, 0.33, 0.3))
    boss = cylinder(y - 0.42, z, x, 0.16, -0.45, -0.22)
    ribs = [torch.maximum(box(p, (-0.16, 0.3, s), (0.16, 0.2, 0.025)), (x + 0.6 * y - 0.02) / math.hypot(1.0, 0.6))
            for s in (-0.22, 0.22)]
    solid = torch.minimum(torch.minimum(base, upright), torch.minimum(boss, torch.minimum(*ribs)))
    holes = [cylinder(x - 0.27, z - s, y, 0.05, -0.1, 0.3) for s in (-0.17, 0.17)]
    counterbores = [cylinder(x - 0.27, z - s, y, 0.085, 0.085, 0.3) for s in (-0.17, 0.17)]
    slot = box(p, (0.2, 0.06, 0.0), (0.09, 0.2, 0.0)) - 0.04                       # a stadium through the base
    bore = cylinder(y - 0.42, z, x, 0.085, -0.6, -0.1)
    return solid, holes + counterbores + [slot, bore]


def sdf(p):
    solid, cuts = parts(p)
    for cut in cuts:
        solid = torch.maximum(solid, -cut)
    return solid


def material(p):
    """Bare metal on the cuts' faces and on the upright's milled top, blue paint elsewhere."""
    _, cuts = parts(p)
    faces = torch.stack([c.abs() for c in cuts] + [(p[:, 1] - 0.66).abs()], dim=-1)
    machined = faces.min(dim=-1).values < MACHINED_WITHIN
    paint = torch.tensor([0.04, 0.16, 0.52]).expand(p.shape[0], 3)
    metal = torch.tensor([0.91, 0.92, 0.92]).expand(p.shape[0], 3)
    return {"base_color": torch.where(machined[:, None], metal, paint),
            "roughness": torch.where(machined, 0.22, 0.45),
            "metallic": torch.where(machined, 1.0, 0.0)}
