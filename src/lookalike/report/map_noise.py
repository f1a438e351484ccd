"""How grainy a model's texture maps are: the high-frequency energy of each map.

For a map ``M [S, S, C]`` and the texels its triangles cover, the noise figure is the root mean
square, over the *interior* covered texels (covered with their four neighbours, so that chart
borders and the gutter's dilation do not count), of the discrete Laplacian residual

    r(i, j) = M(i, j) - (M(i-1, j) + M(i+1, j) + M(i, j-1) + M(i, j+1)) / 4,

averaged over the channels. A smooth map scores near 0; independent per-texel noise of standard
deviation s scores about ``1.12 s``. Base colour is measured on its linear RGB, specular on
(roughness, metalness), the normal map on the unit normal's x and y. A channel held as a
constant (a 1x1 texture or a factor) scores 0.
"""

from __future__ import annotations

import numpy as np

from ..asset import Asset, Texture
from ..asset.uv_raster import rasterize_uv

CHANNELS = {"base_color": ("kd", slice(0, 3)), "specular": ("ks", slice(1, 3)), "normal": ("normal", slice(0, 2))}
"""Noise figures reported, as (material attribute, channels measured)."""


def laplacian_residual_rms(values: np.ndarray, covered: np.ndarray) -> float:
    """RMS of ``values - mean of 4 neighbours`` over the texels where ``covered [S, S]`` holds
    for the texel and its four neighbours (see the module docstring); ``values [S, S, C]``.
    0.0 where no texel qualifies."""
    values = values.astype(np.float64)
    inner = covered[1:-1, 1:-1] & covered[:-2, 1:-1] & covered[2:, 1:-1] & covered[1:-1, :-2] & covered[1:-1, 2:]
    if not inner.any():
        return 0.0
    neighbours = (values[:-2, 1:-1] + values[2:, 1:-1] + values[1:-1, :-2] + values[1:-1, 2:]) / 4.0
    residual = values[1:-1, 1:-1] - neighbours
    return float(np.sqrt(np.mean(residual[inner] ** 2)))


def covered_texels(asset: Asset, material_index: int, texture: Texture) -> np.ndarray:
    """``[H, W]`` bool: the texels of ``texture`` that the triangles of material
    ``material_index`` cover (through the UV set the texture uses)."""
    height, width = texture.data.shape[:2]
    covered = np.zeros((height, width), bool)
    mesh = asset.mesh
    if texture.uv_set >= len(mesh.uv):
        return covered
    v_tex, t_tex_idx = mesh.uv[texture.uv_set]
    rows = (mesh.t_mat_idx == material_index).nonzero().reshape(-1)
    uv = v_tex.detach().cpu().numpy()[t_tex_idx[rows].cpu().numpy()]
    r, c, _, _ = rasterize_uv(uv, height, width)
    covered[r, c] = True
    return covered


def map_noise(asset: Asset) -> dict[str, float]:
    """The noise figure of each map of ``asset`` (``CHANNELS``), averaged over its materials
    weighted by their covered texels; a material without the map (or with a constant) adds 0
    with weight 0."""
    totals = {}
    for name, (attribute, channels) in CHANNELS.items():
        energy, weight = 0.0, 0
        for index, material in enumerate(asset.materials):
            texture = getattr(material, attribute)
            if texture is None or texture.data.shape[0] < 3 or texture.data.shape[1] < 3:
                continue
            covered = covered_texels(asset, index, texture)
            count = int(covered.sum())
            values = texture.data.detach().cpu().numpy()[..., channels]
            energy += laplacian_residual_rms(values, covered) ** 2 * count
            weight += count
        totals[name] = float(np.sqrt(energy / weight)) if weight else 0.0
    return totals
