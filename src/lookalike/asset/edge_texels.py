"""Texels beside a mesh's hard edges, and maps whose texels there are taken from further in.

A texel whose centre lies within ``EDGE_TEXELS`` of a hard edge in UV space
(``normals.hard_sides``: normals split there, a crease, or the mesh's border) is read by the
pixels on both sides of a step in the picture: the edge's other face, or the background beyond
an outline. A fit pulls such texels towards the other side's colour and normal (its draw shades
one random sample of each pixel, so its loss also pays for the difference between the two sides),
and the fitted maps show a bright or dark rim along every hard edge in a deterministic draw,
ours and Cycles alike. Taking each such texel from the nearest texel of its own chart further from
the edge removes the rim and keeps the faces' maps. The run offers the result beside the fitted
model and the validation views choose (``jobs.run.optimise``), because at a seam of a finely
curved chart those texels hold detail.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import torch
from scipy.ndimage import distance_transform_edt, label

from .asset import Asset
from .material import Texture
from .normals import hard_sides
from .uv_raster import rasterize_uv

EDGE_TEXELS = 1.0
"""Distance, in texels of the map, from a hard edge within which a texel centre is taken from
further in: the texels a bilinear lookup on the edge's own side still reads."""

MAP_CHANNELS = ("kd", "ks", "normal", "emissive", "occlusion")
"""The material's maps that are read at the surface (displacement moves it, and is left as it is)."""


SAMPLE_SPACING = 0.5
"""Texels between the points at which ``near_hard_sides`` walks a side."""


def near_hard_sides(corner_uv: np.ndarray, hard: np.ndarray, height: int, width: int,
                    distance: float = EDGE_TEXELS) -> np.ndarray:
    """``[H, W]`` bool: the texels of an ``height x width`` map whose centres lie within
    ``distance`` texels of a hard side (``corner_uv [T, 3, 2]`` UVs in glTF's convention,
    ``hard [T, 3]``: side ``k`` joins corners ``k`` and ``(k + 1) % 3``), in UV space, so also
    where a triangle touches a hard edge by a corner only. Each side is walked at
    ``SAMPLE_SPACING`` and the texels around each point are measured against the whole side."""
    xy = corner_uv * np.array([width, height]) - 0.5                 # texel (r, c) centred at (c, r)
    t, k = np.nonzero(hard)
    start, end = xy[t, k], xy[t, (k + 1) % 3]
    steps = np.ceil(np.linalg.norm(end - start, axis=-1) / SAMPLE_SPACING).astype(np.int64) + 1
    side = np.repeat(np.arange(len(t)), steps)
    along = (np.arange(len(side)) - np.repeat(np.cumsum(steps) - steps, steps)) / np.maximum(steps[side] - 1, 1)
    reach = int(np.ceil(distance + SAMPLE_SPACING))
    offsets = np.stack(np.meshgrid(np.arange(-reach, reach + 1), np.arange(-reach, reach + 1)), -1).reshape(-1, 2)
    near = np.zeros((height, width), bool)
    for chunk in np.array_split(np.arange(len(side)), max(1, len(side) // 100_000)):
        s = side[chunk]
        points = start[s] + along[chunk, None] * (end[s] - start[s])
        texels = np.round(points)[:, None] + offsets[None]             # [N, O, 2] texel centres (c, r)
        direction = (end[s] - start[s])[:, None]
        square = np.maximum((direction * direction).sum(-1), 1e-24)
        onto = np.clip(((texels - start[s][:, None]) * direction).sum(-1) / square, 0.0, 1.0)
        gap = np.linalg.norm(texels - (start[s][:, None] + onto[..., None] * direction), axis=-1)
        hit = texels[gap < distance].astype(np.int64)
        near[hit[:, 1] % height, hit[:, 0] % width] = True
    return near


def texel_sources(corner_uv: np.ndarray, hard: np.ndarray, height: int, width: int,
                  distance: float = EDGE_TEXELS) -> tuple[torch.Tensor, torch.Tensor] | None:
    """Where each texel of an ``height x width`` map takes its value from: itself, or, for a
    covered texel ``near_hard_sides``, the nearest covered texel further from them in the same
    chart (8-connected covered texels) where that chart has one; an uncovered texel, the nearest
    texel that keeps its own value, as a bake pads its charts. ``None`` where no covered texel
    lies so near a hard side.

    Args:
        corner_uv: ``[T, 3, 2]`` UVs (UV set 0, glTF convention) of the triangles the map covers.
        hard: ``[T, 3]`` bool, ``normals.hard_sides`` of those triangles.
    Returns:
        ``(rows [H, W], cols [H, W])`` int64: ``map[rows, cols]`` is the map with those texels taken.
    """
    rows, cols, _, _ = rasterize_uv(corner_uv, height, width)
    covered = np.zeros((height, width), bool)
    covered[rows, cols] = True
    near = covered & near_hard_sides(corner_uv, hard, height, width, distance)
    if not near.any():
        return None
    kept = covered & ~near
    charts, _ = label(covered, structure=np.ones((3, 3), bool))
    source = distance_transform_edt(~kept, return_distances=False, return_indices=True)
    kept |= covered & (charts[source[0], source[1]] != charts)   # a chart with no texel further in keeps its own
    source = distance_transform_edt(~kept, return_distances=False, return_indices=True)
    return torch.from_numpy(source[0]), torch.from_numpy(source[1])


def with_texels_from_inside(asset: Asset, distance: float = EDGE_TEXELS) -> Asset | None:
    """``asset`` with every map of an opaque material read at its surface (``MAP_CHANNELS``: UV
    set 0, untransformed, no mips of its own) resampled at its ``texel_sources`` over the
    material's triangles; ``None`` where no map changes (no UVs, no hard edge, constant maps).
    An alpha-tested or blended material is left as it is: its outline is its texture's, not
    its mesh's, and the texels at its border hold that outline."""
    mesh = asset.mesh
    if not mesh.uv:
        return None
    hard = hard_sides(mesh.v_pos, mesh.t_pos_idx, mesh.t_nrm_idx).numpy()
    v_tex, t_tex_idx = mesh.uv[0]
    corner_uv = v_tex.detach().double().cpu()[t_tex_idx.cpu()].numpy()
    materials, changed = [], False
    for index, material in enumerate(asset.materials):
        mine = np.ones(len(corner_uv), bool) if mesh.t_mat_idx is None else (mesh.t_mat_idx.cpu() == index).numpy()
        sources, maps = {}, {}
        for channel in MAP_CHANNELS if material.alpha_mode == "OPAQUE" else ():
            texture: Texture | None = getattr(material, channel)
            if (texture is None or texture.uv_set != 0 or texture.transform is not None or texture.mips is not None
                    or texture.data.shape[0] * texture.data.shape[1] == 1):
                continue
            size = (int(texture.data.shape[0]), int(texture.data.shape[1]))
            if size not in sources:
                sources[size] = texel_sources(corner_uv[mine], hard[mine], *size, distance)
            if (source := sources[size]) is not None:
                data = texture.data.detach()
                maps[channel] = dataclasses.replace(texture, data=data[source[0].to(data.device), source[1].to(data.device)])
        changed |= bool(maps)
        materials.append(dataclasses.replace(material, **maps) if maps else material)
    return dataclasses.replace(asset, materials=materials) if changed else None
