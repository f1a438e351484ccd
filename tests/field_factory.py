"""Small implicit surfaces for the tests, the same field written in Python and in GLSL."""

from __future__ import annotations

import math
from pathlib import Path

import torch

from lookalike.asset.implicit import ImplicitSurface

PYTHON_FIELD = '''
import torch

bounds = ((-0.8, -0.8, -0.8), (0.8, 0.8, 0.8))


def sdf(p):
    sphere = p.norm(dim=-1) - 0.5
    q = (p - torch.tensor([0.3, 0.3, 0.0])).abs() - 0.25
    box = q.clamp(min=0).norm(dim=-1) + q.max(dim=-1).values.clamp(max=0)
    return torch.minimum(sphere, box)


def material(p):
    stripes = 0.5 + 0.5 * torch.sin(12.0 * p[:, 1])
    base_color = torch.stack([0.2 + 0.6 * stripes, 0.3 + 0.0 * stripes, 0.8 - 0.6 * stripes], dim=-1)
    return {"base_color": base_color, "roughness": 0.3 + 0.4 * stripes, "metallic": 0.0 * stripes}
'''

GLSL_FIELD = '''// the same field as the Python one
// bounds: -0.8 -0.8 -0.8 0.8 0.8 0.8
float map(vec3 p) {
    float sphere = length(p) - 0.5;
    vec3 q = abs(p - vec3(0.3, 0.3, 0.0)) - 0.25;
    float box = length(max(q, 0.0)) + min(max(q.x, max(q.y, q.z)), 0.0);
    return min(sphere, box);
}
vec3 albedo(vec3 p) {
    float stripes = 0.5 + 0.5 * sin(12.0 * p.y);
    return vec3(0.2 + 0.6 * stripes, 0.3, 0.8 - 0.6 * stripes);
}
float roughness(vec3 p) { return 0.3 + 0.4 * (0.5 + 0.5 * sin(12.0 * p.y)); }
'''


def write_fields(folder: Path) -> tuple[Path, Path]:
    """``field.py`` and ``field.glsl`` in ``folder``: one sphere and box union, striped."""
    python, glsl = folder / "field.py", folder / "field.glsl"
    python.write_text(PYTHON_FIELD)
    glsl.write_text(GLSL_FIELD)
    return python, glsl


def sphere_field(radius: float = 0.5, half_extent: float = 0.8) -> ImplicitSurface:
    """A sphere of ``radius`` at the origin in a cube of ``half_extent``, no material."""
    return ImplicitSurface(sdf=lambda p: p.norm(dim=-1) - radius, material=None,
                           lo=torch.full((3,), -half_extent), hi=torch.full((3,), half_extent), text=f"sphere {radius}")


def box_field(half: tuple[float, float, float] = (0.4, 0.25, 0.3)) -> ImplicitSurface:
    """An axis-aligned box of half-sizes ``half`` at the origin (exact distance)."""
    b = torch.tensor(half)

    def sdf(p):
        q = p.abs() - b
        return q.clamp(min=0).norm(dim=-1) + q.max(dim=-1).values.clamp(max=0)
    extent = 2 * max(half)
    return ImplicitSurface(sdf=sdf, material=None, lo=torch.full((3,), -extent), hi=torch.full((3,), extent),
                           text=f"box {half}")


def sphere_volume(radius: float) -> float:
    return 4.0 / 3.0 * math.pi * radius ** 3
