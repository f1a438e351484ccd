"""Bump shadowing: how Cycles darkens normal-mapped points towards the shadow terminator.

A normal map can turn the shading normal ``n`` towards a light that the smooth surface beneath
it (the interpolated vertex normal ``s``) faces away from. Cycles (Blender 4.2 and later; its
``bump_shadowing_term``, after Conty Estevez et al. 2019, "A Microfacet-Based Shadowing Function
to Solve the Bump Terminator Problem") gives such a point no light, and softens the light near
the terminator as a GGX masking term whose roughness grows with the map's tilt. With
``a = s.l``, ``b = s.n``, ``c = n.l`` (``l`` the unit direction to the light):

    0                                              where a b c < 0
    G1(alpha2, |a|) = 2 / (1 + sqrt(1 + alpha2 (1 - a^2) / a^2))     otherwise,
    alpha2 = clamp((1 / b^2 - 1) / 8, 0, 1)

(1 where the map does not tilt, ``|b| = 1``). Real-time engines light by ``n`` alone. Where a
coarse mesh's normal map holds what its facets lack, this term is most of what parts the two
renderers on the same file (``docs/benchmarks.md``). ``points.light_points`` applies it in the
views that shade as Cycles does (``PointLight.horizon``) where the light asks for it
(``PointLight.bump_shadowing``, from ``render.horizon_bump_shadowing``).
"""

from __future__ import annotations

import torch

GGX_TILT_SCALE = 0.125
"""``alpha2`` per ``tan^2`` of the map's tilt from the smooth normal (Cycles' constant)."""


def bump_shadowing(smooth: torch.Tensor, normal: torch.Tensor, direction: torch.Tensor) -> torch.Tensor:
    """``[N, 1]`` factor on the light a normal-mapped point reflects (module docstring).

    Args:
        smooth: ``[N, 3]`` unit interpolated vertex normals, facing the viewer.
        normal: ``[N, 3]`` unit normal-mapped shading normals.
        direction: ``[N, 3]`` unit directions to the light.
    Differentiable in all three (the sign test has no gradient).
    """
    a = (smooth * direction).sum(dim=-1, keepdim=True)
    b = (smooth * normal).sum(dim=-1, keepdim=True)
    c = (normal * direction).sum(dim=-1, keepdim=True)
    cos_i = a.abs().clamp(1e-6, 1.0)
    cos_d = b.abs().clamp(1e-6, 1.0)
    alpha2 = (GGX_TILT_SCALE * (cos_d.pow(-2) - 1.0)).clamp(0.0, 1.0)
    masking = 2.0 / (1.0 + torch.sqrt(1.0 + alpha2 * (1.0 - cos_i * cos_i) / (cos_i * cos_i)))
    return torch.where(a * b * c < 0, 0.0, masking)
