"""The planes of an implicit surface that a mesh's faces lie on, and the hold that keeps them there.

A face of a decimated field lies on a plane of the field where the field's gradient is one
direction all over it. A fit that tilts such a face by a degree or two costs nothing where the
light is high, since the normal map turns the shading back; but a renderer that tests the
geometric horizon (Cycles) draws it black where the light grazes it. Holding the face's corners
on its plane keeps it as flat as the field is. A corner on two planes is held on their line (a
crease, which the field has sharp and marching cubes rounds), on three or more on their point.

Each held vertex ``i`` moves by ``x' = M_i x + c_i``, ``M_i = I - A_i^+ A_i`` and ``c_i = A_i^+
b_i``, where the rows of ``A_i`` and ``b_i`` are the unit normals ``n`` and offsets ``d`` of its
planes ``n . x = d``: the nearest point of their intersection (``A^+`` the pseudo-inverse).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse
import scipy.sparse.csgraph
import torch

from .implicit import NORMAL_STEP, ImplicitSurface, field_gradient
from .normals import smooth_sides, split_at_both

FLAT_DEGREES = 0.5
"""A face lies on a plane of the field where the field's gradients at its centroid, at its
corners drawn in by ``INSET`` towards the centroid, and at four points ``FOOTPRINT`` from the
centroid in its plane lie within this of their mean."""

FOOTPRINT = 0.01
"""... in bounds radii: the least span over which a face must be flat, so that a sliver on a
curved surface is not taken for a plane."""

INSET = 0.2
"""Corners are sampled this share of the way towards the centroid, off the crease they may sit on."""

TILT_DEGREES = 10.0
"""... and where its own normal lies within this of the field's there (a face that straddles
a crease does not)."""

THIN = 0.02
"""... and where the point this many bounds radii below its centroid lies at least half that deep
inside the solid: a plate thinner than 1.5 of them (a fin a few pixels across) is left free, for
the fit to widen what the views see of it."""

SAME_PLANE_DEGREES = 1.0
"""Two faces' planes at a vertex are one plane where their normals lie within this."""

PARALLEL_DEGREES = 10.0
"""A vertex whose distinct planes lie nearer to parallel (or antiparallel: both sides of a thin
plate) than this is not held: their intersection is ill-defined. Directions in which three or
more planes pin it less firmly than ``sin(PARALLEL_DEGREES)`` are left free."""

REACH = 0.25
"""A vertex that its planes would move further than this share of its mean edge is not held
(planes that meet far from it: not the crease or corner it rounds)."""


@dataclass
class PlaneHold:
    """Vertices held on the planes of the faces around them.

    Attributes:
        index: ``[K]`` the held vertices.
        matrix: ``[K, 3, 3]`` ``M_i``; ``offset``: ``[K, 3]`` ``c_i`` (positions in the mesh's frame).
        faces: how many faces lie on a plane.
    """

    index: torch.Tensor
    matrix: torch.Tensor
    offset: torch.Tensor
    faces: int

    def apply(self, v_pos: torch.Tensor) -> torch.Tensor:
        """``v_pos [V, 3]`` with each held vertex moved to ``M_i x_i + c_i`` (a new tensor)."""
        held = v_pos.clone()
        held[self.index] = (self.matrix @ v_pos[self.index, :, None])[..., 0] + self.offset
        return held

    def in_frame(self, centre: torch.Tensor, radius: float | torch.Tensor) -> PlaneHold:
        """The same hold for positions ``u = (x - centre) / radius``: ``u' = M u + (M centre +
        c - centre) / radius``."""
        centre = torch.as_tensor(centre, dtype=self.offset.dtype, device=self.offset.device)
        offset = ((self.matrix @ centre) + self.offset - centre) / radius
        return PlaneHold(self.index, self.matrix, offset, self.faces)

    def to(self, device: torch.device | str) -> PlaneHold:
        return PlaneHold(self.index.to(device), self.matrix.to(device), self.offset.to(device), self.faces)


def flat_faces(surface: ImplicitSurface, v_pos: torch.Tensor, t_pos_idx: torch.Tensor) -> tuple[torch.Tensor, ...]:
    """``(flat [T] bool, normal [T, 3], offset [T])``: which faces of the mesh ``v_pos [V, 3]``,
    ``t_pos_idx [T, 3]`` lie on a plane of ``surface`` (``FLAT_DEGREES``, ``TILT_DEGREES``, ``THIN``), and
    that plane, ``normal . x = offset``: the mean unit gradient at the eight samples, the offset the
    mean of ``n . p - f(p) / |grad f(p)|`` over them (the field's distance, however it is scaled)."""
    corners = v_pos.double()[t_pos_idx]                                            # [T, 3, 3]
    centroid = corners.mean(dim=1, keepdim=True)
    face = torch.linalg.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    face = face / face.norm(dim=-1, keepdim=True).clamp(min=1e-30)
    side = corners[:, 1] - corners[:, 0]
    side = side / side.norm(dim=-1, keepdim=True).clamp(min=1e-30)
    _, radius = surface.bounding_sphere()
    span = FOOTPRINT * radius * torch.stack([side, -side, torch.linalg.cross(face, side), -torch.linalg.cross(face, side)], dim=1)
    samples = torch.cat([centroid, corners + INSET * (centroid - corners), centroid + span], dim=1)   # [T, 8, 3]
    value, gradient = field_gradient(surface.distance, samples.reshape(-1, 3).float(), NORMAL_STEP * radius)
    length = gradient.double().norm(dim=-1).clamp(min=1e-20)
    unit = (gradient.double() / length[:, None]).reshape(*samples.shape)
    normal = unit.sum(dim=1)
    normal = normal / normal.norm(dim=-1, keepdim=True).clamp(min=1e-20)
    spread = (unit * normal[:, None]).sum(-1).amin(dim=1)
    probe = centroid[:, 0] - THIN * radius * normal
    depth = -surface.distance(probe.float()).double() / length.reshape(samples.shape[:2])[:, 0]
    flat = (spread >= math.cos(math.radians(FLAT_DEGREES))) & \
        ((face * normal).sum(-1) >= math.cos(math.radians(TILT_DEGREES))) & (depth >= 0.5 * THIN * radius)
    distance = (value.double() / length).reshape(samples.shape[:2])
    offset = ((samples * normal[:, None]).sum(-1) - distance).mean(dim=1)
    return flat, normal, offset


def vertex_planes(normals: list[torch.Tensor], offsets: list[float]) -> tuple[torch.Tensor, torch.Tensor] | None:
    """``(A [k, 3], b [k])``: the distinct planes among one vertex's faces' planes (each
    ``normals[j] . x = offsets[j]``), those within ``SAME_PLANE_DEGREES`` averaged; ``None`` where
    two distinct ones lie within ``PARALLEL_DEGREES`` of parallel or antiparallel."""
    same, parallel = math.cos(math.radians(SAME_PLANE_DEGREES)), math.cos(math.radians(PARALLEL_DEGREES))
    groups: list[list[int]] = []
    for j, n in enumerate(normals):
        group = next((g for g in groups if float(normals[g[0]] @ n) >= same), None)
        if group is None:
            groups.append([j])
        else:
            group.append(j)
    rows = [torch.stack([normals[j] for j in g]).mean(dim=0) for g in groups]
    rows = [r / r.norm() for r in rows]
    for a in range(len(rows)):
        for b in range(a):
            if abs(float(rows[a] @ rows[b])) >= parallel:
                return None
    return torch.stack(rows), torch.tensor([sum(offsets[j] for j in g) / len(g) for g in groups], dtype=torch.float64)


def mean_edge(v_pos: torch.Tensor, t_pos_idx: torch.Tensor) -> torch.Tensor:
    """``[V]`` float64: the mean length of the triangle sides at each vertex (each side counted
    once per triangle at each of its ends; 0 where no triangle uses it)."""
    corners = v_pos.double()[t_pos_idx]
    sides = (corners - corners.roll(-1, dims=1)).norm(dim=-1)                      # [T, 3]: i -> i + 1
    ends = torch.cat([t_pos_idx, t_pos_idx.roll(-1, dims=1)]).reshape(-1)
    total = torch.zeros(v_pos.shape[0], dtype=torch.float64, device=v_pos.device).index_add_(0, ends, sides.repeat(2, 1).reshape(-1))
    return total / torch.bincount(ends, minlength=v_pos.shape[0]).clamp(min=1)


def plane_hold(surface: ImplicitSurface, v_pos: torch.Tensor, t_pos_idx: torch.Tensor) -> PlaneHold:
    """The hold of every vertex of the mesh ``v_pos [V, 3]``, ``t_pos_idx [T, 3]`` that a face
    on a plane of ``surface`` uses (``flat_faces``): on the planes of its faces that are flat
    (``vertex_planes``), its other faces left free to follow."""
    flat, normal, offset = flat_faces(surface, v_pos, t_pos_idx)
    edge = mean_edge(v_pos, t_pos_idx)
    planes: dict[int, tuple[list[torch.Tensor], list[float]]] = {}
    for t in torch.nonzero(flat).squeeze(1).tolist():
        for v in t_pos_idx[t].tolist():
            normals, offsets = planes.setdefault(v, ([], []))
            normals.append(normal[t])
            offsets.append(float(offset[t]))
    index, matrices, offsets = [], [], []
    for v, (normals, plane_offsets) in sorted(planes.items()):
        rows = vertex_planes(normals, plane_offsets)
        if rows is None:
            continue
        a, b = rows
        pinv = torch.linalg.pinv(a, atol=math.sin(math.radians(PARALLEL_DEGREES)))   # [3, k]
        matrix, shift = torch.eye(3, dtype=torch.float64) - pinv @ a, pinv @ b
        x = v_pos[v].double()
        if float((matrix @ x + shift - x).norm()) > REACH * float(edge[v]):
            continue
        index.append(v)
        matrices.append(matrix)
        offsets.append(shift)
    dtype, device = v_pos.dtype, v_pos.device
    if not index:
        return PlaneHold(torch.zeros(0, dtype=torch.long, device=device), torch.zeros(0, 3, 3, dtype=dtype, device=device),
                         torch.zeros(0, 3, dtype=dtype, device=device), 0)
    return PlaneHold(torch.tensor(index, dtype=torch.long, device=device), torch.stack(matrices).to(dtype=dtype, device=device),
                     torch.stack(offsets).to(dtype=dtype, device=device), int(flat.sum()))


def plane_slots(surface: ImplicitSurface, v_pos: torch.Tensor, t_pos_idx: torch.Tensor) -> torch.Tensor:
    """``[T, 3]`` int64 normal slots that part the faces on each plane of ``surface``
    (``flat_faces``) from every other face: corners share a slot where they share a vertex and a
    plane, the plane a set of flat faces joined through edges within ``SAME_PLANE_DEGREES``
    (``asset.normals.smooth_sides``); the corners of faces on no plane share one per vertex. On a
    flat face so parted, the written normals are the plane's, so a renderer that darkens light
    below the interpolated normal's horizon (Cycles' bump shadowing) lights it as the field."""
    flat = flat_faces(surface, v_pos, t_pos_idx)[0].cpu().numpy()
    s1, s2 = smooth_sides(v_pos, t_pos_idx, SAME_PLANE_DEGREES)
    t1, t2 = s1 // 3, s2 // 3
    joined = flat[t1] & flat[t2]
    faces = t_pos_idx.shape[0]
    graph = scipy.sparse.coo_matrix((np.ones(int(joined.sum())), (t1[joined], t2[joined])), shape=(faces, faces))
    _, plane = scipy.sparse.csgraph.connected_components(graph, directed=False)
    plane = torch.from_numpy(np.where(flat, plane + 1, 0)).to(t_pos_idx.device)
    return split_at_both(t_pos_idx, plane[:, None].expand(-1, 3))
