"""Material parameters at the covered pixels of a G-buffer: every material's textures are
sampled at the pixels whose triangle uses it (each with its own UV set, transform and wrap)."""

from __future__ import annotations

from dataclasses import dataclass

import torch

from ..asset.material import Material, Texture
from ..errors import AssetError
from .gbuffer import GBuffer
from .texturing import TextureSampler


@dataclass
class Surface:
    """Shading inputs of N pixels.

    Attributes:
        kd: ``[N, 4]`` linear base colour and alpha (times vertex colour where present).
        ks: ``[N, 3]`` (gamma, roughness, metalness).
        normal_map: ``[N, 3]`` tangent-space normals (``(0, 0, 1)`` where the material has
            no normal map), or ``None`` when no material has one.
        normal_uv_set: ``[N]`` int64 UV set (tangent frame) of each pixel's normal map, -1 for none.
        emissive: ``[N, 3]`` linear emission, or ``None`` when no material emits.
        alpha: ``[N, 1]`` coverage from the alpha mode: OPAQUE 1, MASK ``kd.a >= cutoff``
            (forward) with the gradient of ``kd.a`` (straight-through), or while its
            ``coverage_ramp`` ``w`` is positive ``clamp((kd.a - cutoff) / w + 1/2, 0, 1)``,
            BLEND ``kd.a``.
        double_sided: ``[N]`` bool.
    """

    kd: torch.Tensor
    ks: torch.Tensor
    normal_map: torch.Tensor | None
    normal_uv_set: torch.Tensor
    emissive: torch.Tensor | None
    alpha: torch.Tensor
    double_sided: torch.Tensor


def _uv_lookup(gb: GBuffer, rows: torch.Tensor, material: Material, source):
    """``uv_set -> (uv [n, 2], uv_da [n, 4])`` at the G-buffer ``rows`` of ``material``."""
    def lookup(uv_set: int):
        if uv_set >= len(gb.uv):
            raise AssetError(source or "asset", f"material {material.name!r} samples UV set {uv_set}, "
                                                f"which the mesh does not have")
        uv, uv_da = gb.uv[uv_set]
        return uv[rows], uv_da[rows]
    return lookup


def _sample_present(sampler: TextureSampler, textures: list[Texture | None], uv_of, count: int):
    """``sampler.sample`` of the textures that are not ``None``; ``None`` stays ``None``."""
    present = [t for t in textures if t is not None]
    values = iter(sampler.sample(present, uv_of, count))
    return [None if t is None else next(values) for t in textures]


def _alpha(material: Material, opacity: torch.Tensor) -> torch.Tensor:
    if material.alpha_mode == "OPAQUE":
        return torch.ones_like(opacity)
    if material.alpha_mode == "MASK" and material.coverage_ramp > 0:
        return ((opacity - material.alpha_cutoff) / material.coverage_ramp + 0.5).clamp(0.0, 1.0)
    if material.alpha_mode == "MASK":
        hard = (opacity >= material.alpha_cutoff).to(opacity)
        return hard + opacity - opacity.detach()
    return opacity


def sample_surface(materials: list[Material], t_mat_idx: torch.Tensor, gb: GBuffer, sampler: TextureSampler,
                   source=None) -> Surface:
    """Material parameters of the pixels of ``gb``; ``t_mat_idx [T]`` gives each triangle's
    material; ``sampler`` keeps the mip pyramids of the render. ``source`` names the asset in
    errors."""
    count = gb.pixel.shape[0]
    dtype, device = gb.position.dtype, gb.position.device
    material_of_pixel = t_mat_idx.to(device)[gb.triangle]
    kd = torch.zeros(count, 4, dtype=dtype, device=device)
    ks = torch.zeros(count, 3, dtype=dtype, device=device)
    alpha = torch.zeros(count, 1, dtype=dtype, device=device)
    any_map = any(m.normal is not None for m in materials)
    any_emission = any(m.emissive is not None for m in materials)
    normal_map = gb.position.new_tensor([0.0, 0.0, 1.0]).expand(count, 3) if any_map else None
    emissive = torch.zeros(count, 3, dtype=dtype, device=device) if any_emission else None
    normal_uv_set = torch.full((count,), -1, dtype=torch.int64, device=device)
    double_sided = torch.zeros(count, dtype=torch.bool, device=device)
    for index, material in enumerate(materials):
        rows = torch.nonzero(material_of_pixel == index).reshape(-1)
        if rows.numel() == 0:
            continue
        textures = [material.kd, material.ks, material.normal, material.emissive]
        base, specular, normal, emission = _sample_present(sampler, textures, _uv_lookup(gb, rows, material, source),
                                                           rows.shape[0])
        if gb.color is not None:
            base = base * gb.color[rows]
        kd = kd.index_put((rows,), base)
        ks = ks.index_put((rows,), specular)
        alpha = alpha.index_put((rows,), _alpha(material, base[:, 3:4]))
        if normal is not None:
            normal_map = normal_map.index_put((rows,), normal)
            normal_uv_set[rows] = material.normal.uv_set
        if emission is not None:
            emissive = emissive.index_put((rows,), emission)
        double_sided[rows] = material.double_sided
    return Surface(kd=kd, ks=ks, normal_map=normal_map, normal_uv_set=normal_uv_set, emissive=emissive,
                   alpha=alpha, double_sided=double_sided)


def sample_occlusion(materials: list[Material], t_mat_idx: torch.Tensor, gb: GBuffer, sampler: TextureSampler,
                     source=None) -> torch.Tensor | None:
    """``[N, 1]`` ambient occlusion of the pixels of ``gb`` (1 where a material has none), or
    ``None`` when no material has an occlusion map. Not part of ``sample_surface``: the
    renderer's point lights do not use it; bakes that carry it over do."""
    if all(m.occlusion is None for m in materials):
        return None
    material_of_pixel = t_mat_idx.to(gb.position.device)[gb.triangle]
    occlusion = gb.position.new_ones(gb.pixel.shape[0], 1)
    for index, material in enumerate(materials):
        rows = torch.nonzero(material_of_pixel == index).reshape(-1)
        if material.occlusion is None or rows.numel() == 0:
            continue
        value = sampler.sample([material.occlusion], _uv_lookup(gb, rows, material, source), rows.shape[0])[0]
        occlusion = occlusion.index_put((rows,), value[:, :1])
    return occlusion
