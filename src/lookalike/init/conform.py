"""Put a user's low-poly mesh back on the input's surface before the appearance fit
(``simplify --init-mesh``, the paper's automatic clean-up).

Bad LODs are shrunk or inflated, have parts cut off and moved, and fold where a tool moved
vertices across each other. The fit's small steps cannot undo centimetres, and its Laplacian
regulariser, relative to the start, would hold every fold in place. Two steps fix the shape,
keeping the user's topology and vertex count:

- ``reattach_detached_parts``: a part whose boundary loop matches another part's loop vertex for
  vertex (same count, same shape up to a translation: a piece cut off and moved) is moved back
  and welded to it.
- ``conform_to_surface``: the mesh is fitted to the input's surface, ICP-like. With the
  correspondences fixed, the energy

      E(P) = (1/N) sum_s |B_s P - c_s|^2  +  (1/N) sum_s |C_s P - x_s|^2
             + (mu / V) |L P - D|^2

  is quadratic in the positions ``P [V, 3]``: the first term pulls points sampled on the mesh
  (``B_s P``, barycentric rows) to their input points ``c_s``: the closest one, unless the
  input faces the other way there (a side of a thin part that the damage pushed through the
  other side); then the first input point along the sample's normal, either way, that faces
  the same way as the sample (``oriented_targets``); the second pulls the
  mesh's closest points to points ``x_s`` sampled on the input (``C_s P``), so that every part of
  the input is covered; the third (``L`` the uniform Laplacian) keeps the mesh's shape, its
  differentials ``D [V, 3]``, where the data says little. Each round solves the normal
  equations (a sparse ``[V, V]`` system) and recomputes the correspondences.

  ``D`` is first the start's own ``L P_0``. That keeps the mesh's shape, and also its folds:
  where the damage pushed vertices across their neighbours (thin parts, sharp rims), the
  fitted triangles lie on the surface but face the wrong way. So after the first rounds come
  unfolding passes: triangles that face against the input's surface at their closest point
  are found, ``D`` is set to the fitted mesh's differentials, zero at those triangles' corners
  (the term there flattens instead of keeping the fold), and a few more rounds run
  (``facing_against``; measured in ``docs/benchmarks.md``).

Snapping each vertex to its closest point, as before, is worse: decimation places vertices off
the surface on purpose (a flat triangle spans a curved patch), and snapping both undoes that
and folds sharp rims whose vertices land on the wrong side.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.sparse
import scipy.sparse.csgraph
import scipy.sparse.linalg
import torch

from ..asset import Mesh
from ..asset.laplacian import UniformLaplacian
from ..asset.normals import face_normals, safe_normalize
from .projection_bake import project_along_normals
from .closest_point import ClosestPoints, SurfaceQuery
from .raycast import RayCaster

CONFORM_ROUNDS = 20
"""Correspondence rounds of ``conform_to_surface`` before it unfolds."""
UNFOLD_PASSES = 3
"""Unfolding passes of ``conform_to_surface``: each finds the triangles facing against the
input and frees their corners' differentials."""
UNFOLD_ROUNDS = 5
"""Correspondence rounds of each unfolding pass."""
SETTLE_ROUNDS = 3
"""Correspondence rounds that put back a mesh already lying on the surface (a model fitted to
the same input, decimated): its vertices moved off by a fraction of an edge, nothing folded, so
a few rounds and no unfolding do what the full fit's 35 do at a tenth of the cost."""
CONFORM_SAMPLES = 40_000
"""Points sampled on each surface per term."""
CONFORM_SMOOTHNESS = 0.03
"""``mu``: weight of the Laplacian term against the two distance terms (chosen on a shrunk,
folded decimation of nefertiti, ``docs/benchmarks.md``)."""
CONFORM_REACH = 0.1
"""How far, as a share of the surface's bounding radius, ``oriented_targets`` looks along a
sample's normal."""
LOOP_MATCH_TOLERANCE = 0.1
"""Largest RMS difference of two boundary loops' shapes, after the best translation, as a share
of the loop's mean edge length, for ``reattach_detached_parts`` to weld them."""


def area_samples(v_pos: np.ndarray, t_pos_idx: np.ndarray, count: int, rng: np.random.Generator):
    """``count`` points uniform over the area of a mesh: ``(triangle [N] int64, barycentric
    [N, 3])``, with ``barycentric = (1 - sqrt(u), sqrt(u) (1 - w), sqrt(u) w)``."""
    corners = v_pos[t_pos_idx]
    area = np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    triangle = rng.choice(len(t_pos_idx), count, p=area / area.sum())
    root, w = np.sqrt(rng.random(count)), rng.random(count)
    return triangle, np.stack([1.0 - root, root * (1.0 - w), root * w], axis=1)


def barycentric_rows(t_pos_idx: np.ndarray, triangle: np.ndarray, barycentric: np.ndarray,
                     num_vertices: int) -> scipy.sparse.csr_matrix:
    """``[N, V]`` sparse ``B`` with ``B @ P`` the points ``sum_k barycentric[:, k] P[t[triangle, k]]``."""
    rows = np.repeat(np.arange(len(triangle)), 3)
    return scipy.sparse.csr_matrix((barycentric.reshape(-1), (rows, t_pos_idx[triangle].reshape(-1))),
                                   shape=(len(triangle), num_vertices))


def conform_to_surface(mesh: Mesh, surface: Mesh, rounds: int = CONFORM_ROUNDS, unfold_passes: int = UNFOLD_PASSES,
                       unfold_rounds: int = UNFOLD_ROUNDS, samples: int = CONFORM_SAMPLES,
                       smoothness: float = CONFORM_SMOOTHNESS, seed: int = 0) -> Mesh:
    """``mesh`` with its vertices moved so that it lies on ``surface`` (see the module
    docstring for the energy): ``rounds`` rounds holding the start's differentials, then
    ``unfold_passes`` passes of ``unfold_rounds`` rounds, each holding the differentials of
    the mesh fitted so far except at the corners of triangles ``facing_against`` the surface.
    Topology, UVs and normal slots kept, authored normal values dropped (``Mesh.with_positions``)."""
    fit = SurfaceFit(mesh, surface, samples, smoothness, np.random.default_rng(seed))
    start = mesh.v_pos.double().numpy()
    positions = fit.rounds(start, fit.laplacian @ start, rounds)
    for _ in range(unfold_passes):
        differentials = fit.laplacian @ positions
        differentials[fit.triangles[fit.facing_against(positions)].reshape(-1)] = 0.0
        positions = fit.rounds(positions, differentials, unfold_rounds)
    return mesh.with_positions(torch.from_numpy(positions).to(mesh.v_pos.dtype))


class SurfaceFit:
    """The fit of one mesh's vertices onto a surface (``conform_to_surface``): the samples on
    both surfaces, fixed for every round, and the queries on the surface.

    Args:
        mesh: the mesh to fit, ``[V, 3]`` positions and ``[T, 3]`` triangles (its samples are
            drawn on its starting shape and keep their barycentrics).
        surface: the input's surface.
        samples: points drawn on each surface, uniform over the area.
        smoothness: ``mu``, the Laplacian term's weight.
    """

    def __init__(self, mesh: Mesh, surface: Mesh, samples: int, smoothness: float, rng: np.random.Generator):
        surface_pos, surface_tri = surface.v_pos.double().numpy(), surface.t_pos_idx.numpy()
        self.on_surface = SurfaceQuery(surface_pos, surface_tri)
        self.rays = RayCaster(surface_pos, surface_tri)
        self.surface_normal = unit_face_normals(surface_pos, surface_tri)
        self.reach = CONFORM_REACH * surface.bounding_sphere()[1]
        triangle, barycentric = area_samples(surface_pos, surface_tri, samples, rng)
        self.surface_points = np.einsum("nk,nkd->nd", barycentric, surface_pos[surface_tri[triangle]])
        self.triangles, self.count, self.samples = mesh.t_pos_idx.numpy(), mesh.num_vertices, samples
        self.sample_triangle, sample_barycentric = area_samples(mesh.v_pos.double().numpy(), self.triangles,
                                                                samples, rng)
        self.mesh_samples = barycentric_rows(self.triangles, self.sample_triangle, sample_barycentric, self.count)
        laplacian = UniformLaplacian(mesh.t_pos_idx, self.count).matrix
        indices = laplacian.indices().numpy()
        self.laplacian = scipy.sparse.csr_matrix((laplacian.values().numpy(), (indices[0], indices[1])),
                                                 shape=(self.count, self.count))
        self.shape_weight = smoothness / self.count
        # the parts of the normal equations that no round changes
        self.fixed_term = self.mesh_samples.T @ self.mesh_samples / samples \
            + self.laplacian.T @ self.laplacian * self.shape_weight

    def rounds(self, positions: np.ndarray, differentials: np.ndarray, count: int) -> np.ndarray:
        """``positions [V, 3]`` float64 after ``count`` rounds, each recomputing the
        correspondences and solving for the minimum of the energy with ``D = differentials [V, 3]``."""
        count_v = self.count
        shape_rhs = self.laplacian.T @ differentials * self.shape_weight
        anchor = 1e-6 / count_v        # holds vertices no term reaches (on no triangle)
        for _ in range(count):
            points = self.mesh_samples @ positions
            normals = unit_face_normals(positions, self.triangles)[self.sample_triangle]
            targets = oriented_targets(points, normals, self.on_surface.closest(points), self.surface_normal,
                                       self.rays, self.reach)
            nearest = SurfaceQuery(positions, self.triangles).closest(self.surface_points)
            covering = barycentric_rows(self.triangles, nearest.triangle, nearest.barycentric, count_v)
            lhs = covering.T @ covering / self.samples + self.fixed_term
            rhs = (self.mesh_samples.T @ targets + covering.T @ self.surface_points) / self.samples + shape_rhs
            lhs = (lhs + anchor * scipy.sparse.identity(count_v)).tocsc()
            positions = scipy.sparse.linalg.spsolve(lhs, rhs + anchor * positions)
        return positions

    def facing_against(self, positions: np.ndarray) -> np.ndarray:
        """``[T]`` bool: triangles whose normal points away from the surface's normal at the
        surface point closest to their centroid (negative dot product)."""
        normals = unit_face_normals(positions, self.triangles)
        nearest = self.on_surface.closest(positions[self.triangles].mean(axis=1))
        return (normals * self.surface_normal[nearest.triangle]).sum(axis=1) < 0


def unit_face_normals(v_pos: np.ndarray, t_pos_idx: np.ndarray) -> np.ndarray:
    """``[T, 3]`` float64 unit normals of counter-clockwise triangles (zero for degenerate ones)."""
    return safe_normalize(face_normals(torch.from_numpy(v_pos).double(), torch.from_numpy(t_pos_idx))).numpy()


def oriented_targets(points: np.ndarray, normals: np.ndarray, closest: ClosestPoints, surface_normal: np.ndarray,
                     rays: RayCaster, reach: float) -> np.ndarray:
    """Where ``points [N, 3]`` with unit ``normals [N, 3]`` belong on a surface: ``closest``'s
    point where the surface there faces the same way (``surface_normal [T, 3]`` of its
    triangle, positive dot product), else the nearest point along ``+-normal`` within ``reach``
    where the surface, seen from the side ``normal`` points to, shows its front
    (``lookalike.init.projection_bake.project_along_normals``, every triangle one-sided); ``closest``'s
    point where there is none."""
    targets = closest.point.copy()
    wrong = np.nonzero((surface_normal[closest.triangle] * normals).sum(axis=1) < 0)[0]
    if not len(wrong):
        return targets
    _, offset = project_along_normals(rays, points[wrong], normals[wrong], reach, surface_normal,
                                      np.ones(len(surface_normal), dtype=bool))
    found = np.isfinite(offset)
    targets[wrong[found]] = points[wrong[found]] + offset[found, None] * normals[wrong[found]]
    return targets


def boundary_loops(t_pos_idx: np.ndarray) -> list[np.ndarray]:
    """The closed boundary loops of a triangle mesh, each ``[n]`` vertex indices in the order
    of its directed boundary sides (sides ``(a, b)`` with no ``(b, a)``); vertices where several
    boundary sides start (non-manifold) end a walk, and open walks are dropped."""
    sides = np.concatenate([t_pos_idx[:, [0, 1]], t_pos_idx[:, [1, 2]], t_pos_idx[:, [2, 0]]])
    inner = set(map(tuple, sides.tolist()))
    following: dict[int, list[int]] = {}
    for a, b in sides.tolist():
        if (b, a) not in inner:
            following.setdefault(a, []).append(b)
    loops, seen = [], set()
    for start in following:
        loop, vertex = [], start
        while vertex not in seen and len(following.get(vertex, ())) == 1:
            seen.add(vertex)
            loop.append(vertex)
            vertex = following[vertex][0]
        if vertex == start and len(loop) >= 3:
            loops.append(np.array(loop, dtype=np.int64))
    return loops


def _best_match(a: np.ndarray, b: np.ndarray, positions: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """How loop ``b`` lines up with loop ``a`` (the two sides of one cut run opposite ways):
    ``(rms shape difference, b's vertices in a's order, translation from a to b)`` over every
    cyclic shift of reversed ``b``."""
    best = (np.inf, b, np.zeros(3))
    for shift in range(len(b)):
        partner = np.roll(b[::-1], shift)
        offset = (positions[partner] - positions[a]).mean(axis=0)
        rms = float(np.sqrt(((positions[partner] - positions[a] - offset) ** 2).sum(axis=1).mean()))
        if rms < best[0]:
            best = (rms, partner, offset)
    return best


def reattach_detached_parts(mesh: Mesh, tolerance: float = LOOP_MATCH_TOLERANCE) -> tuple[Mesh, int]:
    """Weld parts cut off and moved back to where they came from: a boundary loop of a part is
    matched with a loop of a larger part with as many vertices and the same shape up to a
    translation (RMS difference at most ``tolerance`` of the loop's mean edge length); the
    smaller part is moved by that translation and its loop's vertices merged into the other's
    (then dropped). Merged corners take the normal slot of their new vertex
    (``_merged_slots``).

    Returns:
        ``(mesh, parts welded)``.
    """
    tri, positions = mesh.t_pos_idx.numpy().copy(), mesh.v_pos.double().numpy().copy()
    count = mesh.num_vertices
    sides = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]]])
    graph = scipy.sparse.coo_matrix((np.ones(len(sides)), (sides[:, 0], sides[:, 1])), shape=(count, count))
    part = scipy.sparse.csgraph.connected_components(graph, directed=False)[1]
    size = np.bincount(part[tri[:, 0]], minlength=part.max() + 1)
    loops = boundary_loops(tri)
    welded = 0
    for loop in sorted(loops, key=lambda loop: size[part[loop[0]]]):
        own = part[loop[0]]
        edge = float(np.linalg.norm(positions[loop] - positions[np.roll(loop, 1)], axis=1).mean())
        candidates = [other for other in loops if len(other) == len(loop) and part[other[0]] != own
                      and size[part[other[0]]] >= size[own]]
        matches = [_best_match(loop, other, positions) for other in candidates]
        if not matches:
            continue
        rms, partner, offset = min(matches, key=lambda match: match[0])
        if rms > tolerance * edge:
            continue
        moved = part == own
        positions[moved] += offset
        remap = np.arange(count)
        remap[loop] = partner
        tri = remap[tri]
        part[moved] = part[partner[0]]
        size[part[partner[0]]] += size[own]
        welded += 1
    if not welded:
        return mesh, 0
    used, compact = np.unique(tri, return_inverse=True)
    per_vertex = {name: getattr(mesh, name)[torch.from_numpy(used)] for name in ("v_color", "v_joints", "v_weights")
                  if getattr(mesh, name) is not None}
    repaired = dataclasses.replace(mesh, v_pos=torch.from_numpy(positions[used]).to(mesh.v_pos.dtype),
                                   t_pos_idx=torch.from_numpy(compact.reshape(-1, 3)), v_nrm=None,
                                   t_nrm_idx=_merged_slots(mesh, tri), **per_vertex)
    return repaired, welded


def _merged_slots(mesh: Mesh, tri: np.ndarray) -> torch.Tensor | None:
    """``t_nrm_idx`` after welding (``tri`` the welded corners' vertices, before compaction): a
    corner whose vertex was merged takes the slot of a corner that already had that vertex, so
    the weld is shaded smooth across."""
    if mesh.t_nrm_idx is None:
        return None
    slots = mesh.t_nrm_idx.numpy().reshape(-1).copy()
    before, after = mesh.t_pos_idx.numpy().reshape(-1), tri.reshape(-1)
    kept = before == after
    slot_of = np.full(mesh.num_vertices, -1)
    slot_of[after[kept]] = slots[kept]
    merged = ~kept & (slot_of[after] >= 0)
    slots[merged] = slot_of[after[merged]]
    return torch.from_numpy(slots.reshape(-1, 3))
