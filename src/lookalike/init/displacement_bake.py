"""The displacement map's start (paper Sec. 5.1): the signed distance from the subdivided base
mesh to the input along each vertex's displacement direction, written into the atlas.

Every vertex of the base subdivided ``finest`` times (``lookalike.asset.displacement``) casts
rays along ``+n`` and ``-n`` (``n`` the direction it is displaced along: the base's interpolated
normal, or for recomputed shading the subdivided mesh's angle-weighted one), each reaching
``CAGE_FRACTION`` of the input's size, and takes the nearest surface seen from outside, as the
classic bake does
(``lookalike.init.projection_bake.project_along_normals``); a vertex whose rays both miss keeps
its place. The map's scale holds the distances up to their ``COVERED_QUANTILE`` with
``HEADROOM`` to spare on either side of the offset 1/2. Each texel of the atlas takes the
heights of the fine triangle that covers it, interpolated from its corners; uncovered texels
take their nearest covered one's, so no filter pulls in background. Bilinear lookups at the
vertices of that map read a local mean, not the vertex's height: the map is then matched
(``lookalike.asset.displacement.matched_heights``) so that each vertex reads its own.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import torch

from ..asset import Asset, Mesh, Texture
from ..asset.displacement import displacement_directions, matched_heights, tessellation
from ..asset.material import Displacement
from ..asset.normals import face_normals, safe_normalize
from ..asset.uv_raster import rasterize_uv
from .projection_bake import nearest_covered, project_along_normals
from .raycast import RayCaster

COVERED_QUANTILE = 0.995
"""Share of the vertices whose distance the map's range holds without clipping."""

HEADROOM = 1.5
"""The range's margin over those distances, for the fit to deepen the relief."""

CAGE_FRACTION = 0.05
"""The rays' reach on each side, as a share of the input's bounding-box diagonal: more than the
classic bake's (``lookalike.init.projection_bake.DEFAULT_CAGE_FRACTION``), since a coarse
base's subdivided faces lie further from the input than its own vertices."""

MIN_SCALE = 1e-3
"""The smallest scale, as a share of the bounding sphere's radius (a base already on the input)."""


def vertex_offsets(reference: Asset, fine: Mesh, normals: np.ndarray, cage: float) -> np.ndarray:
    """``[V]`` float64 signed distance from each vertex of ``fine`` to ``reference`` along its
    unit direction ``normals [V, 3]`` (0 where both rays miss)."""
    ref = reference.mesh
    face_normal = safe_normalize(face_normals(ref.v_pos.detach().double(), ref.t_pos_idx)).numpy()
    double_sided = np.array([m.double_sided for m in reference.materials], bool)
    one_sided = ~double_sided[ref.t_mat_idx.numpy()]
    caster = RayCaster(ref.v_pos.detach().double().numpy(), ref.t_pos_idx.numpy())
    _, offset = project_along_normals(caster, fine.v_pos.double().numpy(), normals, cage, face_normal, one_sided)
    return np.where(np.isfinite(offset), offset, 0.0)


def atlas_heights(fine: Mesh, heights: np.ndarray, size: int) -> torch.Tensor:
    """``[size, size, 1]`` float32: per-vertex ``heights [V]`` of ``fine`` interpolated over its
    UV triangles, uncovered texels filled from the nearest covered one."""
    corners_uv = fine.v_tex[fine.t_tex_idx].double().numpy()  # [T, 3, 2]
    rows, cols, tri, bary = rasterize_uv(corners_uv, size, size)
    values = (bary * heights[fine.t_pos_idx.numpy()[tri]]).sum(axis=1)
    image = np.zeros((size, size), np.float32)
    image[rows, cols] = values
    nearest = nearest_covered(rows, cols, size)
    return torch.from_numpy(np.ascontiguousarray(image[nearest]))[..., None]


def bake_displacement(reference: Asset, base: Mesh, finest: int, size: int, shading: str = "engine") -> Displacement:
    """The ``Displacement`` of ``base`` (with its atlas in UV set 0) towards ``reference`` at
    level ``finest`` with the ``shading`` convention (``Displacement.shading``), its map
    ``size x size`` (module docstring)."""
    topology = tessellation(base, finest)
    base = dataclasses.replace(base.detach(), v_pos=base.v_pos.detach().double())
    fine = topology.subdivided(base, finest)
    lo, hi = reference.mesh.bounds()
    cage = CAGE_FRACTION * float((hi - lo).double().norm())
    directions = displacement_directions(base, fine, topology, finest, shading)
    offsets = vertex_offsets(reference, fine, directions.numpy(), cage)
    radius = float(reference.mesh.bounding_sphere()[1])
    reach = float(np.quantile(np.abs(offsets), COVERED_QUANTILE)) if len(offsets) else 0.0
    scale = max(2.0 * HEADROOM * reach, MIN_SCALE * radius)
    heights = np.clip(0.5 + offsets / scale, 0.0, 1.0)
    position, uv = topology.pairs[finest]
    image = matched_heights(atlas_heights(fine, heights, size), fine.v_tex[uv], heights[position.numpy()])
    return Displacement(Texture(image, wrap="clamp"), scale, 0.5, level=finest, shading=shading)
