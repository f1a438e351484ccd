"""Merging a multi-material asset into one material with one texture atlas (the latent model of
the paper has a single material).

A fresh non-overlapping UV atlas comes from ``lookalike.init.unwrap`` (xatlas). Every atlas texel
covered by a triangle (``lookalike.asset.uv_raster.rasterize_uv``) takes, per channel, the
triangle's own material sampled bilinearly at the old UV interpolated with the same barycentrics
(texture transform and wrap mode honoured). Normal maps are re-expressed from our tangent frame
of the old UVs to our tangent frame of the atlas UVs (``lookalike.asset.frames``); materials
without a normal map contribute the flat normal, those without emission black, those without
an occlusion map 1 (unoccluded). Texels are then dilated ``padding`` texels past
the chart borders so that bilinear filtering and mipmaps do not pull in the background, and any
texel still uncovered gets the channel's mean.

The merged material is double-sided if any input is, blends if any input blends, else masks if
any input masks (with the smallest cutoff). Its alpha keeps each part looking as before: 1 where
the part was opaque, 0 or 1 (the part's own cutoff applied) where it was masked, the alpha itself
where it blended.
"""

from __future__ import annotations

import numpy as np
import torch

from ..asset.asset import Asset
from ..asset.frames import our_corner_frame, reexpress_texels
from ..asset.material import Material, Texture
from ..asset.mesh import Mesh
from ..asset.uv_raster import apply_uv_transform, dilate, rasterize_uv, sample_bilinear
from .unwrap import unwrap

_FLAT_NORMAL = (0.0, 0.0, 1.0)


def _old_uv(mesh: Mesh, texture: Texture, tri: np.ndarray, bary: np.ndarray) -> np.ndarray:
    """``[K, 2]`` UVs of ``texture`` (its UV set and transform) at the given triangle barycentrics."""
    if texture.uv_set >= len(mesh.uv):
        return np.zeros((len(tri), 2))
    v_tex, t_tex_idx = mesh.uv[texture.uv_set]
    corners = v_tex.detach().double()[t_tex_idx].numpy()[tri]
    return apply_uv_transform(np.einsum("kc,kcd->kd", bary, corners), texture.transform)


def _sample(mesh: Mesh, texture: Texture, tri: np.ndarray, bary: np.ndarray) -> np.ndarray:
    data = texture.data.detach().float().numpy()
    return sample_bilinear(data, _old_uv(mesh, texture, tri, bary), texture.wrap)


def _bake_channel(mesh: Mesh, atlas_mesh: Mesh, materials: list[Material], name: str, channels: int,
                  default, size: int, raster) -> np.ndarray:
    """``[size, size, channels]`` atlas texels of channel ``name`` (NaN where uncovered)."""
    rows, cols, tri, bary = raster
    frames = {"atlas": our_corner_frame(atlas_mesh, 0)} if name == "normal" else {}
    out = np.full((size, size, channels), np.nan, np.float32)
    owner = mesh.t_mat_idx.numpy()[tri]
    for index, material in enumerate(materials):
        pick = owner == index
        if not pick.any():
            continue
        texture = getattr(material, name)
        if texture is None:
            values = np.broadcast_to(np.asarray(default, np.float32), (int(pick.sum()), channels))
        else:
            values = _sample(mesh, texture, tri[pick], bary[pick])[:, :channels]
        if name == "normal":
            old_set = texture.uv_set if texture is not None and texture.uv_set < len(mesh.uv) else None
            if old_set not in frames:
                frames[old_set] = our_corner_frame(mesh, old_set) if old_set is not None else frames["atlas"]
            values = reexpress_texels(values, frames[old_set], frames["atlas"], tri[pick], bary[pick])
            values = values.astype(np.float32)
        if name == "kd":
            values = np.concatenate([values[:, :3], _merged_alpha(material, values[:, 3:])], axis=1)
        out[rows[pick], cols[pick]] = values
    return out


def _merged_alpha(material: Material, alpha: np.ndarray) -> np.ndarray:
    """Alpha ``[K, 1]`` of ``material`` as the merged material must store it to look the same:
    1 for an opaque material, 0 or 1 (its own cutoff applied) for a masked one, as is for a
    blended one."""
    if material.alpha_mode == "OPAQUE":
        return np.ones_like(alpha)
    if material.alpha_mode == "MASK":
        return (alpha >= material.alpha_cutoff).astype(np.float32)
    return alpha


def fill_uncovered(texels: np.ndarray, padding: int) -> torch.Tensor:
    """``texels [H, W, C]`` (NaN where uncovered) with covered texels dilated ``padding`` deep and
    the rest filled with the covered mean; ``[H, W, C]`` float32 tensor."""
    covered = ~np.isnan(texels[..., 0])
    values, covered = dilate(np.nan_to_num(texels), covered, padding)
    if covered.any():
        values[~covered] = values[covered].mean(axis=0)
    return torch.from_numpy(np.ascontiguousarray(values))


def merged_modes(materials: list[Material]) -> dict:
    """``alpha_mode``, ``alpha_cutoff`` and ``double_sided`` of one material standing for all of
    ``materials`` (the rule in the module docstring), as ``Material`` keyword arguments."""
    modes = {m.alpha_mode for m in materials}
    cutoffs = [m.alpha_cutoff for m in materials if m.alpha_mode == "MASK"]
    return {
        "alpha_mode": "BLEND" if "BLEND" in modes else "MASK" if "MASK" in modes else "OPAQUE",
        "alpha_cutoff": min(cutoffs) if cutoffs else 0.5,
        "double_sided": any(m.double_sided for m in materials),
    }


def merge_materials(asset: Asset, size: int = 1024, padding: int = 4) -> Asset:
    """One material with a ``size x size`` atlas for every channel (see the module docstring).

    Args:
        asset: any asset; its mesh keeps positions, normals, skinning and triangle order.
        size: atlas side in texels.
        padding: texels between charts and dilation depth.
    Returns:
        A new ``Asset`` whose mesh has a single UV set (the atlas) and ``t_mat_idx`` all zero.
    """
    mesh = asset.mesh.detach()
    atlas_mesh = unwrap(mesh, texture_size=size, padding=padding)
    atlas_mesh.t_mat_idx = torch.zeros_like(mesh.t_mat_idx)
    uv = atlas_mesh.uv[0][0][atlas_mesh.uv[0][1]].numpy()
    raster = rasterize_uv(uv, size, size)
    materials = asset.materials

    def bake(name, channels, default):
        texels = _bake_channel(mesh, atlas_mesh, materials, name, channels, default, size, raster)
        return fill_uncovered(texels, padding)

    has_normal = any(m.normal is not None for m in materials)
    has_emissive = any(m.emissive is not None for m in materials)
    has_occlusion = any(m.occlusion is not None for m in materials)
    normal = None
    if has_normal:
        data = bake("normal", 3, _FLAT_NORMAL)
        normal = Texture(data / data.norm(dim=-1, keepdim=True).clamp_min(1e-12))
    merged = Material(
        name="atlas", kd=Texture(bake("kd", 4, (0.0, 0.0, 0.0, 1.0))), ks=Texture(bake("ks", 3, (0.0, 0.5, 0.0))),
        normal=normal, emissive=Texture(bake("emissive", 3, (0.0, 0.0, 0.0))) if has_emissive else None,
        occlusion=Texture(bake("occlusion", 1, (1.0,))) if has_occlusion else None,
        **merged_modes(materials),
    )
    return Asset(mesh=atlas_mesh, materials=[merged], skin=asset.skin, animations=asset.animations,
                 source=asset.source)
