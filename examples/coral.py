"""A branching coral on a rock as a signed distance field, for ``lookalike simplify
examples/coral.py``: an organic smooth blend (branches and rock melted into each other) with
thin parts (branch tips a few hundredths of its height across), coloured from a deep red at the
foot of each branch to a pale pink at its tips.

Conventions (lookalike's implicit surfaces): ``sdf(p)`` takes ``[N, 3]`` float32 torch points
and returns ``[N]`` signed distances in the asset's units, negative inside, never larger than the
true distance to the surface (so that sphere tracing can step by it); ``bounds`` is a box that
holds the whole surface; ``material(p)`` gives linear base colour ``[N, 3]`` and optionally
``roughness`` and ``metallic`` ``[N]`` at points on the surface. +y is up.

A tapered capsule's distance overestimates by at most a factor ``sqrt(1 + taper^2)`` and the
smooth union stays below the plain one; ``LIPSCHITZ`` covers both.
"""

import torch

bounds = ((-0.55, -0.2, -0.5), (0.55, 0.95, 0.5))

LIPSCHITZ = 1.1
"""The field is the blend's value divided by this, a bound on its gradient's length."""

BLEND = 0.035
"""Width of the smooth union where branches meet."""

BRANCHES = (
    # (start, end, radius at the start, radius at the end, branches between it and the rock)
    ((0.0, 0.0, 0.0), (0.02, 0.42, 0.01), 0.075, 0.05, 0),
    ((0.02, 0.4, 0.01), (-0.2, 0.68, 0.06), 0.045, 0.022, 1),
    ((0.02, 0.4, 0.01), (0.22, 0.72, -0.05), 0.045, 0.02, 1),
    ((0.02, 0.42, 0.01), (0.03, 0.86, 0.02), 0.04, 0.018, 1),
    ((-0.2, 0.68, 0.06), (-0.36, 0.8, 0.14), 0.022, 0.014, 2),
    ((-0.2, 0.68, 0.06), (-0.16, 0.88, -0.04), 0.022, 0.014, 2),
    ((0.22, 0.72, -0.05), (0.38, 0.84, 0.02), 0.02, 0.013, 2),
    ((0.22, 0.72, -0.05), (0.2, 0.9, -0.2), 0.02, 0.013, 2),
    ((0.0, 0.16, 0.0), (-0.3, 0.34, -0.2), 0.04, 0.016, 1),
    ((-0.3, 0.34, -0.2), (-0.42, 0.56, -0.24), 0.016, 0.012, 2),
    ((0.01, 0.22, 0.0), (0.28, 0.4, 0.24), 0.035, 0.014, 1),
)


START, END = (torch.tensor([branch[i] for branch in BRANCHES]) for i in (0, 1))
RADII = torch.tensor([branch[2:4] for branch in BRANCHES])
DEPTH = torch.tensor([float(branch[4]) for branch in BRANCHES])


def tapered_capsules(p):
    """Distances ``[N, K]`` (each an overestimate by at most its taper's slope) to the K
    branches, capsules from ``START`` to ``END`` whose radius goes linearly from ``RADII[:, 0]``
    to ``RADII[:, 1]``, and where along each the closest point lies, ``[N, K]`` in [0, 1]."""
    axis = END - START
    offset = p[:, None, :] - START
    h = ((offset * axis).sum(-1) / (axis * axis).sum(-1)).clamp(0, 1)
    return (offset - h[..., None] * axis).norm(dim=-1) - torch.lerp(RADII[:, 0], RADII[:, 1], h), h


def smooth_union(a, b, k):
    """The polynomial smooth minimum (never above ``min(a, b)``)."""
    h = (0.5 + 0.5 * (b - a) / k).clamp(0, 1)
    return torch.lerp(b, a, h) - k * h * (1 - h)


def rock(p):
    """A flattened, lumpy boulder under the coral."""
    q = p - torch.tensor([0.0, -0.02, 0.0])
    lumps = 0.015 * torch.sin(9 * q[:, 0]) * torch.sin(7 * q[:, 2] + 1.0) * torch.sin(11 * q[:, 1] + 2.0)
    return (q * torch.tensor([1.0, 2.6, 1.15])).norm(dim=-1) / 2.6 - 0.1 + lumps


def branches(p):
    """The smooth union of the branches, and how far up the coral the nearest branch's closest
    point lies (0 at the rock, 1 at a tip), ``[N]`` each."""
    d, h = tapered_capsules(p)
    field = d[:, 0]
    for k in range(1, d.shape[1]):
        field = smooth_union(field, d[:, k], BLEND)
    reach = (DEPTH + h) / 3
    return field, reach.gather(1, d.argmin(dim=1, keepdim=True))[:, 0]


def sdf(p):
    coral, _ = branches(p)
    return smooth_union(coral, rock(p), 0.06) / LIPSCHITZ


def material(p):
    coral, along = branches(p)
    on_rock = rock(p) < coral
    red = torch.tensor([0.55, 0.05, 0.04])
    pink = torch.tensor([0.95, 0.55, 0.5])
    colour = torch.lerp(red, pink, along[:, None] ** 1.5)
    stone = torch.tensor([0.32, 0.3, 0.26]) * (0.85 + 0.15 * torch.sin(23 * p[:, 0] + 17 * p[:, 2]))[:, None]
    return {"base_color": torch.where(on_rock[:, None], stone, colour),
            "roughness": torch.where(on_rock, 0.85, 0.55),
            "metallic": torch.zeros(p.shape[0])}
