"""Displaced tessellation (paper Sec. 5.1): a base mesh subdivided ``level`` times at edge
midpoints (``lookalike.asset.subdivide``), each fine vertex moved along its normal,

    v' = v + scale * (h(v) - offset) * n(v),

with ``h`` the height map sampled bilinearly at the vertex's UVs and ``n`` as the displacement's
``shading`` convention says (``displacement_directions``): ``"engine"``, the base's vertex
normals interpolated over each base triangle, ``n = normalize(sum_i b_i n_i)``, which are also
the shading normals, so that the normal map reads in one frame at every level (a tessellator's
domain shader); ``"recomputed"``, the angle-weighted normal of the undisplaced fine mesh
(``lookalike.asset.normals.angle_weighted_normals``, Blender's), shading then following the
displaced geometry. Either is the same at a point whatever the level. Every level reads the
map itself: a vertex of a coarse level is a vertex of every finer one, at the same point and
with the same normal, so the levels are nested (mips would mix neighbouring charts of the atlas,
4 texels apart, from mip 2 on, and blur the finest level's heights). Where the displacement
names a ``detail_level`` D, a coarser level k adds to what it reads the rise of the level-D
surface above its own chords, filtered over each vertex's star (``chord_rise``),

    h_k' = h_k + R_{D->k} (h_D - S_{k->D} h_k),

``S`` the subdivision of the level-k heights to level D and ``R`` its adjoint's tent filter
(``EdgeMidpointTopology.restrict``) level by level back to k: a coarse level then straddles the
relief that its flat triangles cannot follow, where read at its vertices alone it cuts under
every bump (a linear relief rises above no chord, and is read as before).
A vertex on a UV seam has one UV per side: it takes the mean of its samples, so that the
surface never cracks; ``stitched_displacement`` then changes the map as little as possible so
that every side reads that mean, for readers that sample one side per vertex. The topology of
every level is built once per base mesh and reused.
"""

from __future__ import annotations

import dataclasses
import weakref

import numpy as np
import scipy.sparse
import scipy.sparse.linalg
import torch
import torch.nn.functional as F

from .asset import Asset
from .material import Displacement
from .mesh import Mesh
from .normals import angle_weighted_normals, safe_normalize
from .subdivide import MeshSubdivision


class Tessellation:
    """The subdivisions of one base mesh's topology, levels ``1 .. levels``, and for each level
    the distinct (position, UV) pairs of its corners.

    Attributes:
        steps: ``MeshSubdivision`` from level ``k`` to ``k + 1``, for ``k < levels``.
        pairs: per level, ``(position [P], uv [P])`` int64 indices of the distinct pairs.
        counts: per level, ``[V_k]`` float32 how many pairs each position has (its UV sides).
    """

    def __init__(self, mesh: Mesh, levels: int):
        self.steps: list[MeshSubdivision] = []
        self.pairs: list[tuple[torch.Tensor, torch.Tensor]] = []
        self.counts: list[torch.Tensor] = []
        fine = Mesh(v_pos=mesh.v_pos.detach(), t_pos_idx=mesh.t_pos_idx, uv=[(mesh.v_tex.detach(), mesh.t_tex_idx)],
                    t_nrm_idx=mesh.t_nrm_idx)
        self._add_pairs(fine)
        for _ in range(levels):
            self.steps.append(MeshSubdivision(fine))
            fine = self.steps[-1](fine)
            self._add_pairs(fine)

    @property
    def levels(self) -> int:
        return len(self.steps)

    def _add_pairs(self, mesh: Mesh) -> None:
        pairs = torch.unique(torch.stack([mesh.t_pos_idx.reshape(-1), mesh.t_tex_idx.reshape(-1)], dim=1), dim=0)
        self.pairs.append((pairs[:, 0], pairs[:, 1]))
        self.counts.append(torch.bincount(pairs[:, 0], minlength=mesh.num_vertices).float())

    def subdivided(self, mesh: Mesh, level: int) -> Mesh:
        """``mesh`` (this topology, any positions and UVs) subdivided ``level`` times, with UV
        set 0 only; differentiable."""
        fine = dataclasses.replace(mesh, uv=mesh.uv[:1])
        for step in self.steps[:level]:
            fine = step(fine)
        return fine

    def fine_uvs(self, v_tex: torch.Tensor, level: int) -> torch.Tensor:
        """UV set 0's values ``[VT_level, 2]`` at ``level`` from the base's ``v_tex``: the
        subdivision of the UVs alone, for what needs no positions."""
        for step in self.steps[:level]:
            v_tex = step.uvs[0](v_tex)
        return v_tex


_TESSELLATIONS: dict[int, tuple[weakref.ref, weakref.ref, Tessellation]] = {}
"""Built tessellations by ``id`` of their position index buffer, dropped when it is freed."""


def tessellation(mesh: Mesh, levels: int) -> Tessellation:
    """The ``Tessellation`` of ``mesh``'s topology to at least ``levels``, built once per index
    buffer (kept while ``mesh.t_pos_idx`` lives)."""
    key = id(mesh.t_pos_idx)
    kept = _TESSELLATIONS.get(key)
    if (kept is not None and kept[0]() is mesh.t_pos_idx and kept[1]() is mesh.t_tex_idx
            and kept[2].levels >= levels):
        return kept[2]
    built = Tessellation(mesh, levels)
    _TESSELLATIONS[key] = (weakref.ref(mesh.t_pos_idx, lambda _: _TESSELLATIONS.pop(key, None)),
                           weakref.ref(mesh.t_tex_idx), built)
    return built


def corner_heights(image: torch.Tensor, uv: torch.Tensor) -> torch.Tensor:
    """``[N]`` heights of ``image [S, S, 1]`` sampled bilinearly (texel centres at
    ``(i + 1/2) / S``, edges clamped) at ``uv [N, 2]``; differentiable."""
    grid = (2.0 * uv - 1.0).to(image.dtype)[None, None]  # [1, 1, N, 2], x along columns
    return F.grid_sample(image.permute(2, 0, 1)[None], grid, mode="bilinear", padding_mode="border",
                         align_corners=False).reshape(-1)


def level_heights(topology: Tessellation, fine_uv: torch.Tensor, level: int,
                  image: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """``(heights [V_level], sides [P_level])`` at ``level`` from its UVs ``fine_uv``
    (``Tessellation.fine_uvs``) alone: each position's mean height over its distinct UVs, and
    each (position, UV) pair's own sample (they differ only on UV seams)."""
    position, uv = topology.pairs[level]
    sides = corner_heights(image, fine_uv[uv])
    counts = topology.counts[level]
    heights = torch.zeros(counts.shape[0], dtype=sides.dtype, device=sides.device).index_add(0, position, sides)
    return heights / counts.clamp(min=1.0), sides


def chord_rise(topology: Tessellation, v_tex: torch.Tensor, heights: torch.Tensor, level: int, detail: int,
               image: torch.Tensor) -> torch.Tensor:
    """``[V_level]`` ``R_{D->k} (h_D - S_{k->D} h_k)`` (module docstring): how far the level-``detail``
    surface rises above the chords of ``level``'s ``heights``, in map units, each vertex's
    mean over its star; differentiable."""
    rise = level_heights(topology, topology.fine_uvs(v_tex, detail), detail, image)[0]
    chords = heights[:, None]
    for step in topology.steps[level:detail]:
        chords = step.positions(chords)
    rise = rise - chords[:, 0]
    for step in reversed(topology.steps[level:detail]):
        rise = step.positions.restrict(rise)
    return rise


def position_normals(mesh: Mesh) -> torch.Tensor:
    """``[V, 3]`` one unit shading normal per position of ``mesh``: its normal slots'
    (``Mesh.normals``) where each position has one, else the normalised sum of its corners'."""
    v_nrm, t_nrm_idx = mesh.normals()
    if t_nrm_idx is mesh.t_pos_idx:
        return v_nrm
    corners = v_nrm[t_nrm_idx].reshape(-1, 3)
    return safe_normalize(torch.zeros_like(mesh.v_pos).index_add(0, mesh.t_pos_idx.reshape(-1), corners))


def displacement_directions(mesh: Mesh, fine: Mesh, topology: Tessellation, level: int, shading: str) -> torch.Tensor:
    """``[V_level, 3]`` unit directions along which the vertices of ``fine`` (``mesh``
    subdivided ``level`` times by ``topology``) move: with ``shading`` ``"engine"`` the base's
    ``position_normals`` subdivided linearly (a midpoint takes the mean of its edge's ends, so a
    fine vertex holds ``sum_i b_i n_i`` of its base triangle) and normalised; with
    ``"recomputed"`` the angle-weighted normals of ``fine``. Differentiable."""
    if shading == "recomputed":
        return angle_weighted_normals(fine.v_pos, fine.t_pos_idx)
    normals = position_normals(mesh)
    for step in topology.steps[:level]:
        normals = step.positions(normals)
    return safe_normalize(normals)


def displaced(mesh: Mesh, displacement: Displacement, level: int | None = None) -> tuple[Mesh, torch.Tensor]:
    """``(fine mesh, seam_gaps [P])``: ``mesh`` subdivided ``level`` times (default
    ``displacement.level``) and displaced (module docstring), its shading normals the
    displacement directions (``"engine"``: one slot per position) or left to be recomputed from
    the displaced positions (``"recomputed"``: normal slots kept, authored values dropped); and
    each (position, UV) pair's height minus its position's mean (zero off UV seams).
    Differentiable in positions, UVs and heights."""
    level = displacement.level if level is None else level
    detail = displacement.detail_level
    topology = tessellation(mesh, level if detail is None else max(level, detail))
    fine = topology.subdivided(mesh, level)
    normals = displacement_directions(mesh, fine, topology, level, displacement.shading)
    image = displacement.heights.data
    heights, sides = level_heights(topology, fine.v_tex, level, image)
    gaps = sides - heights[topology.pairs[level][0]]
    if detail is not None and level < detail:
        heights = heights + chord_rise(topology, mesh.v_tex, heights, level, detail, image)
    v_pos = fine.v_pos + (displacement.scale * (heights - displacement.offset))[:, None] * normals
    if displacement.shading == "recomputed":
        return dataclasses.replace(fine, v_pos=v_pos, v_nrm=None), gaps
    return dataclasses.replace(fine, v_pos=v_pos, v_nrm=normals, t_nrm_idx=fine.t_pos_idx), gaps


def seam_gaps(mesh: Mesh, displacement: Displacement) -> torch.Tensor:
    """``[P]`` each (position, UV) pair's height minus its position's mean at
    ``displacement.level`` (``displaced``'s second result) from the UVs alone: the cost of a
    seam that opens, without subdividing positions or computing normals."""
    level = displacement.level
    topology = tessellation(mesh, level)
    heights, sides = level_heights(topology, topology.fine_uvs(mesh.v_tex, level), level, displacement.heights.data)
    return sides - heights[topology.pairs[level][0]]


def tessellated(asset: Asset, level: int | None = None) -> Asset:
    """``asset`` as it is drawn: where its material has a ``Displacement``, its mesh displaced
    at ``level`` (default the displacement's own) and its material without one; else itself.
    ``ValueError`` for a displaced material on a mesh of several materials."""
    displacement = asset.materials[0].displacement if asset.materials else None
    if displacement is None:
        return asset
    if len(asset.materials) > 1:
        raise ValueError("a displacement map needs a mesh of one material")
    mesh, _ = displaced(asset.mesh, displacement, level)
    material = dataclasses.replace(asset.materials[0], displacement=None)
    return dataclasses.replace(asset, mesh=mesh, materials=[material])


MATCH_DAMPING = 1e-3
"""Ridge weight ``d`` of the texels' change in ``matched_heights``: where two vertices ask one
texel for different heights, the least-squares compromise stays small."""


def bilinear_weights(uv: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """``(texels [N, 4], weights [N, 4])``: the flat indices (row * size + column) of the four
    texels a bilinear lookup at ``uv [N, 2]`` of a ``size x size`` image reads (edges clamped),
    and their weights, as ``corner_heights`` samples."""
    x = np.clip(uv[:, 0] * size - 0.5, 0.0, size - 1.0)
    y = np.clip(uv[:, 1] * size - 0.5, 0.0, size - 1.0)
    x0, y0 = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    fx, fy = x - x0, y - y0
    x1, y1 = np.minimum(x0 + 1, size - 1), np.minimum(y0 + 1, size - 1)
    texels = np.stack([y0 * size + x0, y0 * size + x1, y1 * size + x0, y1 * size + x1], axis=1)
    weights = np.stack([(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy], axis=1)
    return texels, weights


def matched_heights(image: torch.Tensor, uv: torch.Tensor, targets: np.ndarray) -> torch.Tensor:
    """``image [S, S, 1]`` changed as little as possible so that its bilinear samples at
    ``uv [N, 2]`` are ``targets [N]``: heights that vertices read exactly, where a map
    interpolated between them reads them only near. The change is the damped least-squares one,
    ``A^T (A A^T + d^2 I)^-1 r`` (``A [N, S^2]`` the lookups' weights, ``r`` what they miss,
    ``d`` ``MATCH_DAMPING``; one sparse solve of the size of the lookups), then clipped to [0, 1]."""
    size = image.shape[0]
    values = image.detach().double().numpy().reshape(-1)
    texels, weights = bilinear_weights(uv.detach().double().numpy(), size)
    rows = np.repeat(np.arange(len(texels)), 4)
    matrix = scipy.sparse.csr_matrix((weights.reshape(-1), (rows, texels.reshape(-1))), shape=(len(texels), size * size))
    residual = targets - matrix @ values
    normal = (matrix @ matrix.T + MATCH_DAMPING ** 2 * scipy.sparse.identity(len(texels))).tocsc()
    change = matrix.T @ scipy.sparse.linalg.spsolve(normal, residual)
    return torch.from_numpy(np.clip(values + change, 0.0, 1.0).reshape(image.shape)).to(image.dtype)


def stitched_displacement(mesh: Mesh, displacement: Displacement, level: int) -> Displacement:
    """``displacement`` with its map matched (``matched_heights``) so that every UV side of
    every vertex of ``mesh`` subdivided ``level`` times reads the vertex's mean height: a reader
    that samples one side per vertex (Blender's Displace modifier, an engine's tessellator)
    builds the surface we draw, with no crack, at that level and every coarser one."""
    topology = tessellation(mesh, level)
    fine_uv, image = topology.fine_uvs(mesh.v_tex.detach(), level), displacement.heights.data.detach()
    heights, _ = level_heights(topology, fine_uv, level, image)
    position, uv = topology.pairs[level]
    matched = matched_heights(image, fine_uv[uv], heights[position].double().numpy())
    return dataclasses.replace(displacement, heights=dataclasses.replace(displacement.heights, data=matched))
