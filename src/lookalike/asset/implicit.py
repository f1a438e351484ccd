"""Implicit surfaces: a signed distance field and its material, in the asset's units (paper
Sec. 5.5), and their triangle mesh by marching cubes.

A field's *value* at a point is its signed distance to the surface, negative inside; sphere
tracing steps by it, so it must never exceed the true distance (a 1-Lipschitz field, as the
usual SDF primitives and their unions are). Its *material* gives the linear base colour and,
optionally, roughness and metalness of points on the surface.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from .mesh import Mesh

Field = Callable[[torch.Tensor], torch.Tensor]
"""``[N, 3]`` float32 points -> ``[N]`` float32 signed distances (negative inside)."""

MaterialField = Callable[[torch.Tensor], dict]
"""``[N, 3]`` float32 points -> ``{"base_color": [N, 3], "roughness": [N], "metallic": [N]}``
(linear colour; roughness and metallic optional)."""

DEFAULT_BASE_COLOR = (0.75, 0.72, 0.68)
DEFAULT_ROUGHNESS = 0.45
"""The material of a field that gives none (or of the channels it leaves out): an untextured
mesh's (``Material``'s defaults)."""

NORMAL_STEP = 1e-4
"""The gradient's difference step, relative to the radius of the bounds."""

TETRAHEDRON = torch.tensor([[1.0, -1.0, -1.0], [-1.0, -1.0, 1.0], [-1.0, 1.0, -1.0], [1.0, 1.0, 1.0]])

CREASE_SPREAD_DEGREES = 30.0
"""A marching-cubes triangle whose corners' normals lie further apart than this crosses a crease
of the field (``crease_normals``)."""

CHUNK_POINTS = 1 << 18
"""Points a field is asked for at once (bounds the memory of its intermediate tensors)."""


@dataclass
class ImplicitSurface:
    """A surface given by a signed distance field.

    Attributes:
        sdf: ``Field``; ``material``: ``MaterialField`` or ``None`` (``DEFAULT_BASE_COLOR``, ``DEFAULT_ROUGHNESS``).
        lo, hi: ``[3]`` float32 corners of the box that holds the surface (``bounds``).
        text: the source it was made from (its fingerprint).
        kind: ``"python"`` or ``"glsl"``: the language of ``text``, which picks its renderer.
        path: the file ``text`` was read from (named in errors), or ``None``.
    """

    sdf: Field
    material: MaterialField | None
    lo: torch.Tensor
    hi: torch.Tensor
    text: str
    kind: str = "python"
    path: Path | None = None

    def distance(self, points: torch.Tensor) -> torch.Tensor:
        """``sdf`` of ``points [N, 3]`` -> ``[N]`` float32, asked ``CHUNK_POINTS`` at a time."""
        return torch.cat([self.sdf(points[i:i + CHUNK_POINTS]).reshape(-1).float()
                          for i in range(0, points.shape[0], CHUNK_POINTS)] or [points.new_zeros(0)])

    def channels(self, points: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``(kd [N, 3] linear base colour, ks [N, 3] = (0, roughness, metalness))`` at
        ``points [N, 3]``, clamped to [0, 1]; the defaults where ``material`` gives none."""
        n = points.shape[0]
        kd = torch.tensor(DEFAULT_BASE_COLOR).expand(n, 3)
        ks = torch.tensor([0.0, DEFAULT_ROUGHNESS, 0.0]).expand(n, 3).clone()
        if self.material is None or n == 0:
            return kd.clone(), ks
        kds, roughs, metals = [], [], []
        for i in range(0, n, CHUNK_POINTS):
            values = self.material(points[i:i + CHUNK_POINTS])
            count = min(CHUNK_POINTS, n - i)
            kds.append(torch.as_tensor(values["base_color"]).float().reshape(count, 3))
            roughs.append(torch.as_tensor(values.get("roughness", DEFAULT_ROUGHNESS)).float().expand(count))
            metals.append(torch.as_tensor(values.get("metallic", 0.0)).float().expand(count))
        ks[:, 1], ks[:, 2] = torch.cat(roughs), torch.cat(metals)
        return torch.cat(kds).clamp(0.0, 1.0), ks.clamp(0.0, 1.0)

    def bounding_sphere(self) -> tuple[torch.Tensor, float]:
        """``(centre [3], radius)`` of the bounds box (the surface lies inside it)."""
        return 0.5 * (self.lo + self.hi), float(0.5 * (self.hi - self.lo).norm())

    def fingerprint(self) -> str:
        """SHA-256 (hex) of ``kind``, ``text`` and the bounds."""
        return hashlib.sha256(f"{self.kind}\n{self.text}\n{self.lo.tolist()}{self.hi.tolist()}".encode()).hexdigest()


def field_gradient(distance, points: torch.Tensor, step: float) -> tuple[torch.Tensor, torch.Tensor]:
    """``(f(p) [N], gradient [N, 3])`` of ``distance`` at ``points [N, 3]``: central
    differences on a tetrahedron (Quilez), ``sum_k e_k f(p + h e_k) / 4h`` over its corners
    ``e_k``, four evaluations; ``f(p)`` is the mean of the four values."""
    corners = TETRAHEDRON.to(points)
    values = distance((points[:, None, :] + step * corners).reshape(-1, 3)).reshape(-1, 4)
    return values.mean(dim=1), values @ corners / (4.0 * step)


def field_normals(surface: ImplicitSurface, points: torch.Tensor) -> torch.Tensor:
    """Unit gradients ``[N, 3]`` of ``surface``'s field at ``points [N, 3]`` (``field_gradient``
    with a step of ``NORMAL_STEP`` times the bounds' radius): the normals a sphere tracer shades."""
    if points.shape[0] == 0:
        return points.clone()
    _, radius = surface.bounding_sphere()
    _, gradient = field_gradient(surface.distance, points, NORMAL_STEP * radius)
    return gradient / gradient.norm(dim=-1, keepdim=True).clamp(min=1e-20)


def grid_axes(lo: torch.Tensor, hi: torch.Tensor, cells: int, block: int = 1) -> tuple[list[torch.Tensor], float]:
    """The corner coordinates along each axis (``[X]``, ``[Y]``, ``[Z]`` float64) of a grid of
    cubes of side ``h`` over the box ``lo``–``hi`` (``[3]``), about ``cells`` along its longest
    side, padded by at least one cube on every side and to a multiple of ``block`` cubes, and ``h``."""
    h = float((hi - lo).max()) / cells
    counts = [math.ceil((math.ceil(float(e) / h) + 2) / block) * block + 1 for e in (hi - lo)]
    return [float(lo[k]) - h + h * torch.arange(counts[k], dtype=torch.float64) for k in range(3)], h


def axes_points(axes: list[torch.Tensor]) -> torch.Tensor:
    """The grid points ``[X*Y*Z, 3]`` float32 of ``axes`` (``grid_axes``), in x-major order."""
    return torch.stack(torch.meshgrid(*axes, indexing="ij"), dim=-1).reshape(-1, 3).float()


def narrow_band_values(surface: ImplicitSurface, axes: list[torch.Tensor], h: float, block: int) -> np.ndarray:
    """``surface``'s values ``[X, Y, Z]`` float32 on the grid ``axes`` (``grid_axes`` in whole
    blocks), evaluated only in the blocks of ``block`` cubes that the surface may cross: the
    blocks' corners are evaluated first, and a block whose corners share a sign and have
    ``|f| > 2 sqrt(3) block h`` (twice its diagonal: a 1-Lipschitz field's value bounds the
    distance to the surface) holds no surface and is filled by interpolating them. Makes a fine
    mesh (millions of triangles) affordable: its cost follows the surface's area, not the box's
    volume."""
    shape = [len(axis) for axis in axes]
    blocks = [(n - 1) // block for n in shape]
    coarse = surface.distance(axes_points([axis[::block] for axis in axes])).reshape([b + 1 for b in blocks])
    values = torch.nn.functional.interpolate(coarse[None, None], size=shape, mode="trilinear",
                                             align_corners=True)[0, 0].numpy()
    corners = torch.stack([coarse[i:i + blocks[0], j:j + blocks[1], k:k + blocks[2]]
                           for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    near = ((corners.min(0).values < 0) & (corners.max(0).values > 0)) | \
        (corners.abs().min(0).values <= 2.0 * math.sqrt(3.0) * block * h)
    offsets = torch.stack(torch.meshgrid(*[torch.arange(block + 1)] * 3, indexing="ij"), dim=-1).reshape(-1, 3)
    active = torch.nonzero(near) * block
    per_chunk = max(1, CHUNK_POINTS // offsets.shape[0])
    for first in range(0, active.shape[0], per_chunk):
        index = (active[first:first + per_chunk, None, :] + offsets[None]).reshape(-1, 3)
        points = torch.stack([axes[k][index[:, k]] for k in range(3)], dim=1).float()
        values[index[:, 0].numpy(), index[:, 1].numpy(), index[:, 2].numpy()] = surface.distance(points).numpy()
    return values


def field_mesh(surface: ImplicitSurface, cells: int, block: int = 0) -> Mesh:
    """The zero level set of ``surface`` as a welded triangle mesh (marching cubes, scikit-image's
    ``measure.marching_cubes``, on a grid of about ``cells`` cubes along the bounds' longest
    side), front faces outwards, with ``material``'s base colour at the vertices (``v_color``) and
    the field's gradient as their authored normals (``crease_normals``: they shade as the field
    does, not as the facets' average). With ``block``, the grid is evaluated near the surface
    only (``narrow_band_values``), else everywhere.
    Raises ``ValueError`` saying what is wrong where the field has no zero crossing on the grid,
    or is negative on the grid's outer layer (one cube beyond the bounds: they cut the
    surface)."""
    from skimage import measure

    axes, h = grid_axes(surface.lo, surface.hi, cells, max(block, 1))
    shape = tuple(len(axis) for axis in axes)
    values = (narrow_band_values(surface, axes, h, block) if block
              else surface.distance(axes_points(axes)).reshape(shape).numpy())
    if not (values.min() < 0.0 < values.max()):
        raise ValueError("positive everywhere in its bounds (it must be negative inside)" if values.min() >= 0.0 else
                         "negative everywhere in its bounds (no surface: the bounds lie inside it)")
    shell = np.ones(shape, bool)
    shell[1:-1, 1:-1, 1:-1] = False
    inside = np.flatnonzero(shell.reshape(-1) & (values.reshape(-1) < 0.0))
    if inside.size:
        x, y, z = (float(axes[k][i]) for k, i in enumerate(np.unravel_index(int(inside[0]), shape)))
        raise ValueError(f"negative just outside its bounds, at ({x:.4g}, {y:.4g}, {z:.4g}): the bounds cut the "
                         "surface; enlarge them")
    verts, faces, _, _ = measure.marching_cubes(values, level=0.0, spacing=(h, h, h), allow_degenerate=False)
    v_pos = torch.from_numpy(verts.astype(np.float32)) + torch.tensor([float(axis[0]) for axis in axes])
    t_pos_idx = torch.from_numpy(faces.astype(np.int64))  # counter-clockwise seen from outside
    kd, _ = surface.channels(v_pos)
    colour = torch.cat([kd, torch.ones(kd.shape[0], 1)], dim=1)
    v_nrm, t_nrm_idx = crease_normals(surface, v_pos, t_pos_idx)
    return Mesh(v_pos=v_pos, t_pos_idx=t_pos_idx, v_color=colour, v_nrm=v_nrm, t_nrm_idx=t_nrm_idx)


def crease_normals(surface: ImplicitSurface, v_pos: torch.Tensor, t_pos_idx: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """The authored normals of ``surface``'s marching-cubes mesh (``v_pos [V, 3]``, ``t_pos_idx
    [T, 3]``): ``(v_nrm [V + 3C, 3], t_nrm_idx [T, 3])``, the field's gradient at each vertex
    (``field_normals``), except on the ``C`` triangles whose corners' normals spread more than
    ``CREASE_SPREAD_DEGREES``: each takes, at all three corners, the gradient at its centroid.
    Marching cubes rounds a crease of the field within one cube, and such a triangle has its
    corners on both faces; interpolated, their normals sweep every direction between the faces'
    and draw a glint along the crease that the field, sharp there, does not show. Its centroid lies
    off the surface, where the gradient is the nearer face's normal."""
    v_nrm = field_normals(surface, v_pos)
    corner = v_nrm[t_pos_idx]                                                       # [T, 3, 3]
    cosine = (corner * corner.roll(1, dims=1)).sum(-1).amin(dim=1)                   # [T]
    crease = torch.nonzero(cosine < math.cos(math.radians(CREASE_SPREAD_DEGREES))).squeeze(1)
    t_nrm_idx = t_pos_idx.clone()
    t_nrm_idx[crease] = v_pos.shape[0] + torch.arange(3 * crease.numel()).reshape(-1, 3)   # a slot per corner
    centroids = v_pos[t_pos_idx[crease]].mean(dim=1)
    return torch.cat([v_nrm, field_normals(surface, centroids).repeat_interleave(3, dim=0)]), t_nrm_idx
