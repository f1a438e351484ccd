"""The paper's material model (Sec. 5.2): Lambertian diffuse plus an isotropic GGX specular
lobe, parameterised by ``kd`` (base colour, linear RGB) and ``ks = (gamma, r, m)``.

For unit normal ``n``, unit direction to the viewer ``v`` and to the light ``l``,
``h = normalize(v + l)`` and the cosines ``nl = n.l``, ``nv = n.v``, ``nh = n.h``, ``vh = v.h``:

- diffuse colour ``c_d = kd (1 - m)``; diffuse term ``f_d = c_d / pi``;
- specular colour ``F0 = (0.04 (1 - m) + kd m) (1 - gamma)``;
- Schlick Fresnel ``F = F0 + (F90 - F0) (1 - vh)^5`` with ``F90 = 1 - gamma``, so that
  ``gamma`` scales the whole specular lobe by ``1 - gamma`` (grazing reflection included);
- GGX distribution with ``alpha = r^2``: ``D = alpha^2 / (pi (nh^2 (alpha^2 - 1) + 1)^2)``;
- Smith height-correlated masking-shadowing, folded with ``1 / (4 nl nv)`` into
  ``Vis = 0.5 / (nl sqrt(nv^2 (1 - alpha^2) + alpha^2) + nv sqrt(nl^2 (1 - alpha^2) + alpha^2))``;
- ``f_s = F D Vis``.

``shade`` returns ``(f_d + f_s) nl``, the reflected radiance per unit irradiance.
Numerical guards: roughness is clamped to at least ``MIN_ROUGHNESS`` (a perfect mirror would
make ``D`` a Dirac spike that a point light cannot render); the cosines ``nv`` and ``nl`` are
clamped to at least ``COSINE_EPSILON`` inside ``Vis`` so grazing views stay finite, and the
result is zero (not negative, not NaN) wherever the light is below the surface (``nl <= 0``).
A viewer below the shading surface (``nv <= 0``) is treated as grazing rather than black;
the G-buffer bends such normals towards the viewer before they get here.
"""

from __future__ import annotations

import math

import torch

MIN_ROUGHNESS = 0.08
"""Smallest roughness ``r`` used for shading (``alpha = r^2 >= 0.0064``)."""

COSINE_EPSILON = 1e-4
"""Lower clamp of ``n.v`` and ``n.l`` in the specular visibility term."""

DIELECTRIC_F0 = 0.04
"""Normal-incidence reflectance of non-metals."""


def _dot(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    return (a * b).sum(dim=-1, keepdim=True)


def ggx_distribution(alpha2: torch.Tensor, nh: torch.Tensor) -> torch.Tensor:
    """GGX normal distribution ``D = alpha^2 / (pi (nh^2 (alpha^2 - 1) + 1)^2)`` (``[..., 1]``)."""
    nh = nh.clamp(0.0, 1.0)
    denom = nh * nh * (alpha2 - 1.0) + 1.0
    return alpha2 / (math.pi * denom * denom)


def smith_visibility(alpha2: torch.Tensor, nl: torch.Tensor, nv: torch.Tensor) -> torch.Tensor:
    """Height-correlated Smith masking-shadowing divided by ``4 nl nv`` (``[..., 1]``); the
    cosines are clamped to ``[COSINE_EPSILON, 1]``."""
    nl = nl.clamp(COSINE_EPSILON, 1.0)
    nv = nv.clamp(COSINE_EPSILON, 1.0)
    lambda_v = nl * torch.sqrt(nv * nv * (1.0 - alpha2) + alpha2)
    lambda_l = nv * torch.sqrt(nl * nl * (1.0 - alpha2) + alpha2)
    return 0.5 / (lambda_v + lambda_l)


def schlick_fresnel(f0: torch.Tensor, f90: torch.Tensor, vh: torch.Tensor) -> torch.Tensor:
    """Schlick's Fresnel ``F0 + (F90 - F0) (1 - vh)^5`` with ``vh`` clamped to [0, 1]."""
    return f0 + (f90 - f0) * (1.0 - vh.clamp(0.0, 1.0)) ** 5


def specular_colour(kd: torch.Tensor, ks: torch.Tensor) -> torch.Tensor:
    """``F0 = (0.04 (1 - m) + kd m) (1 - gamma)``: ``kd [..., 3]``, ``ks [..., 3]`` -> ``[..., 3]``."""
    gamma, metal = ks[..., 0:1], ks[..., 2:3]
    return (DIELECTRIC_F0 * (1.0 - metal) + kd * metal) * (1.0 - gamma)


def diffuse_colour(kd: torch.Tensor, ks: torch.Tensor) -> torch.Tensor:
    """``c_d = kd (1 - m)``: ``kd [..., 3]``, ``ks [..., 3]`` -> ``[..., 3]``."""
    return kd * (1.0 - ks[..., 2:3])


def shade(kd: torch.Tensor, ks: torch.Tensor, n: torch.Tensor, v: torch.Tensor, l: torch.Tensor) -> torch.Tensor:
    """Reflected radiance per unit irradiance, ``(f_d + f_s) max(nl, 0)``.

    Args:
        kd: ``[..., 3]`` linear base colour.
        ks: ``[..., 3]`` (gamma, roughness, metalness).
        n: ``[..., 3]`` unit shading normal.
        v: ``[..., 3]`` unit direction from the surface to the viewer.
        l: ``[..., 3]`` unit direction from the surface to the light.
    Returns:
        ``[..., 3]`` float, finite, non-negative.
    """
    roughness = ks[..., 1:2].clamp(MIN_ROUGHNESS, 1.0)
    alpha2 = roughness ** 4
    h = v + l
    h = h * torch.rsqrt(_dot(h, h).clamp(min=1e-12))
    nl, nv, nh, vh = _dot(n, l), _dot(n, v), _dot(n, h), _dot(v, h)
    fresnel = schlick_fresnel(specular_colour(kd, ks), 1.0 - ks[..., 0:1], vh)
    f_s = fresnel * ggx_distribution(alpha2, nh) * smith_visibility(alpha2, nl, nv)
    f_d = diffuse_colour(kd, ks) / math.pi
    return (f_d + f_s) * nl.clamp(min=0.0)
