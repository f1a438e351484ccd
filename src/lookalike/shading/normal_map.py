"""Shading normals: tangent-space normal mapping, back faces of double-sided materials, and
normals bent back towards the viewer.

Tangent frame (``lookalike.asset.tangents``): per pixel the interpolated normal ``n`` and
tangent ``t`` (with handedness ``w``) give ``t' = normalize(t - (n.t) n)`` (Gram-Schmidt),
``b = sign(w) n x t'``, and a tangent-space value ``(x, y, z)`` the shading normal
``normalize(x t' + y b + z n)``.
"""

from __future__ import annotations

import torch

from ..asset.normals import safe_normalize

BEND_THRESHOLD = 0.1
"""Shading normals whose cosine with the view direction is below this are blended towards the
geometric normal (fully geometric at cosine 0 or below)."""


def _dot(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    return (a * b).sum(dim=-1, keepdim=True)


def perturb_normal(normal: torch.Tensor, tangent: torch.Tensor, tangent_space: torch.Tensor) -> torch.Tensor:
    """Normal-mapped shading normals.

    Args:
        normal: ``[N, 3]`` interpolated vertex normals (any length).
        tangent: ``[N, 4]`` interpolated tangents, ``w`` = handedness.
        tangent_space: ``[N, 3]`` normal-map values ``(x, y, z)``.
    Returns:
        ``[N, 3]`` unit normals ``normalize(x t' + y b + z n)`` (see the module docstring).
    """
    n = safe_normalize(normal)
    t = safe_normalize(tangent[:, :3] - _dot(tangent[:, :3], n) * n)
    sign = torch.where(tangent[:, 3:4] < 0, -1.0, 1.0).to(n)
    b = sign * torch.linalg.cross(n, t, dim=-1)
    x, y, z = tangent_space.unbind(dim=-1)
    return safe_normalize(x[:, None] * t + y[:, None] * b + z[:, None] * n)


def bend_towards_viewer(normal: torch.Tensor, geometric: torch.Tensor, view: torch.Tensor) -> torch.Tensor:
    """Blend shading normals that (nearly) face away from the viewer towards the front-facing
    geometric normal, so silhouettes of smooth or normal-mapped surfaces get no black speckles:
    ``normalize(lerp(geometric, normal, clamp(normal.view / BEND_THRESHOLD, 0, 1)))``.

    Args:
        normal: ``[N, 3]`` unit shading normals.
        geometric: ``[N, 3]`` unit face normals, oriented towards the viewer.
        view: ``[N, 3]`` unit directions from the surface to the viewer.
    Returns:
        ``[N, 3]`` unit normals.
    """
    weight = (_dot(normal, view) / BEND_THRESHOLD).clamp(0.0, 1.0)
    return safe_normalize(torch.lerp(geometric, normal, weight))
