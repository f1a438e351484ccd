"""A fresh, non-overlapping UV atlas from the maintained unwrapper ``xatlas``."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import torch
import xatlas

from ..asset.mesh import Mesh
from ..errors import ConfigError

_FIRST_FILL = 0.75                 # first guess of texels per unit length, times texture_size, at unit area
_SHRINK = 0.9                      # texel density factor after an atlas overflowed its texture
_ATTEMPTS = 12


def _generate(v_pos: np.ndarray, t_pos_idx: np.ndarray, texture_size: int, padding: int, texels_per_unit: float):
    atlas = xatlas.Atlas()
    atlas.add_mesh(v_pos, t_pos_idx)
    pack = xatlas.PackOptions()
    pack.resolution = texture_size
    pack.padding = padding
    pack.bilinear = True
    pack.texels_per_unit = texels_per_unit
    atlas.generate(xatlas.ChartOptions(), pack)
    return atlas


def _paddings(padding: int) -> list[int]:
    """``padding`` and its halvings down to one texel: ``4 -> [4, 2, 1]``, ``0 -> [0]``."""
    steps = [padding]
    while steps[-1] > 1:
        steps.append(steps[-1] // 2)
    return steps


def _packed(unit: np.ndarray, indices: np.ndarray, texture_size: int, padding: int) -> xatlas.Atlas:
    """The first atlas that fits one texture: densest first, then with less padding (``unwrap``)."""
    for gap in _paddings(padding):
        texels_per_unit = _FIRST_FILL * texture_size
        for _ in range(_ATTEMPTS):
            atlas = _generate(unit, indices, texture_size, gap, texels_per_unit)
            if atlas.atlas_count == 1:
                return atlas
            texels_per_unit *= _SHRINK
    raise ConfigError(f"no UV atlas of {texture_size} texels with {padding} texels of padding fits this mesh")


def unwrap(mesh: Mesh, texture_size: int = 1024, padding: int = 4) -> Mesh:
    """Replace the UV sets of ``mesh`` with one new atlas in which no two triangles overlap.

    xatlas cuts the surface into charts, flattens each, and packs them into one
    ``texture_size`` square with at least ``padding`` texels between charts. The mesh is scaled
    to unit surface area for xatlas and the texel density starts at ``0.75 * texture_size``
    per unit length, shrinking by 10% until every chart fits in one texture. Where no density
    fits (a small texture for a mesh of many small parts, whose padding alone fills it), the
    padding halves, down to one texel: a narrower gap costs less than charts of a texel or two.

    Args:
        mesh: positions welded (``t_pos_idx`` is kept as it is).
        texture_size: side of the square texture the atlas is laid out for, in texels.
        padding: minimum gap between charts, in texels of that texture.

    Returns:
        The same mesh with ``uv = [(v_tex [VT, 2] float32, t_tex_idx [T, 3] int64)]``, UVs in
        [0, 1] in glTF's convention, one UV vertex per (position, chart) corner.

    Raises:
        ConfigError: ``texture_size`` or ``padding`` out of range, or no atlas fits.
    """
    if isinstance(texture_size, bool) or not isinstance(texture_size, (int, np.integer)) or texture_size < 8:
        raise ConfigError(f"texture size must be a whole number of at least 8 texels, got {texture_size!r}")
    if isinstance(padding, bool) or not isinstance(padding, (int, np.integer)) or not 0 <= padding < texture_size // 4:
        raise ConfigError(f"UV padding must be a whole number of texels in [0, {texture_size // 4}), got {padding!r}")
    v_pos = mesh.v_pos.detach().cpu().numpy().astype(np.float64)
    t_pos_idx = mesh.t_pos_idx.cpu().numpy()
    corners = v_pos[t_pos_idx]
    area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1).sum()
    unit = (v_pos / np.sqrt(max(area, 1e-30))).astype(np.float32)
    indices = t_pos_idx.astype(np.uint32)

    atlas = _packed(unit, indices, int(texture_size), int(padding))

    _, t_tex_idx, v_tex = atlas[0]
    v_tex = v_tex * np.array([atlas.width, atlas.height], dtype=np.float32) / texture_size
    device = mesh.v_pos.device
    return replace(mesh, uv=[(
        torch.as_tensor(v_tex, dtype=torch.float32, device=device),
        torch.as_tensor(t_tex_idx.astype(np.int64), device=device),
    )])
