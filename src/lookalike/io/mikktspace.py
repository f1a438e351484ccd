"""MikkTSpace per-corner tangents (Mikkelsen 2008; the reference ``mikktspace.c`` that Blender, the
glTF specification and most bakers use), vectorised with NumPy and SciPy.

The reference algorithm, as implemented here:

1. Corners with bitwise-equal position, normal and UV are one vertex.
2. Triangles with two equal corner positions are degenerate: they take no part, and each of
   their corners later copies the tangent of another corner of the same vertex.
3. Per triangle, with ``d1 = p1 - p0``, ``d2 = p2 - p0``, ``t21 = uv1 - uv0``, ``t31 = uv2 - uv0``:
   signed UV area ``A = t21.x t31.y - t21.y t31.x``, orientation-preserving iff ``A > 0``,
   ``vOs = t31.y d1 - t21.y d2`` (``A * dP/du``) and ``vOt = -t31.x d1 + t21.x d2``; the
   triangle's direction is ``sign(A) vOs / |vOs|``. A triangle with ``A``, ``|vOs|/|A|`` or
   ``|vOt|/|A|`` zero is "group with any": it contributes nothing and takes the orientation of
   the neighbour that reaches it first (here: of its first edge neighbour with a good triangle).
4. Around each vertex, corners of triangles connected through shared edges (edges matched by
   vertex identity with opposite winding) and of equal orientation form a group.
5. A group's tangent is ``normalize(sum_c angle_c * normalize(proj_n(dir_c)))`` where ``proj_n``
   removes the component along the vertex normal and ``angle_c`` is the corner angle between the
   two corner edges projected into the tangent plane; its sign is +1 for an
   orientation-preserving group, -1 otherwise. A group without a good triangle (and a degenerate
   corner without a live twin) gets the reference's initial value ``(1, 0, 0)``.

Deviation from the reference, which matters only on unusual meshes: the reference splits a group
further where two triangles' tangent directions are exactly opposite (its default 180 degree
threshold), and resolves "group with any" orientation in triangle order.

UV convention: ``mikktspace_tangents`` takes UVs in lookalike's (glTF) convention, v down the
image, and returns glTF TANGENT values, i.e. with the reference's sign computed on ``(u, 1 - v)``
(equivalently: the reference's sign on glTF UVs, negated). Then ``b = w * cross(n, t)`` points up
the image, matching ``lookalike.asset.tangents``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse
import scipy.sparse.csgraph

from .arrays import unique_rows

_FLT_MIN = 1.17549435e-38  # the reference's "NotZero" threshold
_UNSET_TANGENT = np.array([1.0, 0.0, 0.0])  # the reference's tangent where nothing defines one


def _unit(x: np.ndarray) -> np.ndarray:
    """``x / |x|`` along the last axis; rows with ``|x| <= FLT_MIN`` stay unchanged (as the reference)."""
    length = np.linalg.norm(x, axis=-1, keepdims=True)
    return np.where(length > _FLT_MIN, x / np.where(length > _FLT_MIN, length, 1.0), x)


def _welded_vertices(positions, normals, uvs) -> np.ndarray:
    """``[T, 3]`` vertex id per corner: equal ids for bitwise-equal (position, normal, uv)."""
    keys = np.concatenate([positions, normals, uvs], axis=-1).astype(np.float32).reshape(-1, 8)
    _, inverse = unique_rows(keys + np.float32(0.0))  # + 0.0 turns -0.0 into 0.0, as float == does
    return inverse.reshape(-1, 3)


def _edge_neighbours(vertex: np.ndarray, alive: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Pairs of triangles sharing an edge with opposite winding: ``(t, e, t2, e2)`` arrays where
    edge ``e`` of ``t`` (corner ``e`` to ``e + 1``) is edge ``e2`` of ``t2`` reversed."""
    tri = np.flatnonzero(alive)
    a = vertex[tri]
    b = np.roll(a, -1, axis=1)
    n_vertices = int(vertex.max()) + 1 if vertex.size else 1
    forward = (a.astype(np.int64) * n_vertices + b).reshape(-1)
    backward = (b.astype(np.int64) * n_vertices + a).reshape(-1)
    order = np.argsort(forward, kind="stable")
    position = np.searchsorted(forward[order], backward)
    position = np.minimum(position, len(order) - 1)
    match = forward[order][position] == backward
    source = np.flatnonzero(match)
    target = order[position[match]]
    return tri[source // 3], source % 3, tri[target // 3], target % 3


def _triangle_directions(p: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Step 3 of the module docstring for ``p [T, 3, 3]`` positions and ``t [T, 3, 2]`` UVs
    (float64): unit directions ``[T, 3]`` (zero for bad triangles), orientation-preserving flags
    ``[T]`` and good flags ``[T]``."""
    d1, d2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    t21, t31 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    area = t21[:, 0] * t31[:, 1] - t21[:, 1] * t31[:, 0]
    v_os = t31[:, 1:2] * d1 - t21[:, 1:2] * d2
    v_ot = -t31[:, 0:1] * d1 + t21[:, 0:1] * d2
    orient = area > 0
    len_os, len_ot = np.linalg.norm(v_os, axis=-1), np.linalg.norm(v_ot, axis=-1)
    abs_area = np.where(np.abs(area) > _FLT_MIN, np.abs(area), 1.0)
    good = (np.abs(area) > _FLT_MIN) & (len_os / abs_area > _FLT_MIN) & (len_ot / abs_area > _FLT_MIN)
    unit_os = np.where(orient, 1.0, -1.0)[:, None] * v_os / np.where(len_os > 0, len_os, 1.0)[:, None]
    return np.where((good & (len_os > _FLT_MIN))[:, None], unit_os, 0.0), orient, good


def _corner_groups(vertex: np.ndarray, alive: np.ndarray, orient: np.ndarray, good: np.ndarray):
    """Step 4: group id ``[3T]`` of every corner (corner ``(t, k)`` is ``3 t + k``) and the final
    per-triangle orientation ``[T]`` (bad triangles adopt a good neighbour's)."""
    tri_a, edge_a, tri_b, edge_b = _edge_neighbours(vertex, alive)
    adopt = ~good[tri_a] & good[tri_b]
    orient = orient.copy()
    bad, first = np.unique(tri_a[adopt], return_index=True)
    orient[bad] = orient[tri_b[adopt][first]]
    # Across a shared edge a -> b, corner a of one triangle links corner a of the other (and b, b)
    # when their orientations agree.
    same = orient[tri_a] == orient[tri_b]
    ta, ea, tb, eb = tri_a[same], edge_a[same], tri_b[same], edge_b[same]
    links_from = np.concatenate([3 * ta + ea, 3 * ta + (ea + 1) % 3])
    links_to = np.concatenate([3 * tb + (eb + 1) % 3, 3 * tb + eb])
    n_corners = vertex.size
    graph = scipy.sparse.coo_matrix((np.ones(len(links_from)), (links_from, links_to)), shape=(n_corners, n_corners))
    _, group = scipy.sparse.csgraph.connected_components(graph, directed=False)
    return group, orient


def _corner_angles(p: np.ndarray, n: np.ndarray) -> np.ndarray:
    """``[3T]`` angle at every corner between its two edges projected into the plane of the
    corner normal (``p, n [T, 3, 3]``)."""
    corner_n = n.reshape(-1, 3)
    corner_p = p.reshape(-1, 3)
    v1 = _project(p[:, [2, 0, 1]].reshape(-1, 3) - corner_p, corner_n)
    v2 = _project(p[:, [1, 2, 0]].reshape(-1, 3) - corner_p, corner_n)
    return np.arccos(np.clip((v1 * v2).sum(-1), -1.0, 1.0))


def _project(v: np.ndarray, n: np.ndarray) -> np.ndarray:
    """``v`` without its component along unit ``n``, normalised (zero stays zero)."""
    return _unit(v - n * (n * v).sum(-1, keepdims=True))


def mikktspace_tangents(positions: np.ndarray, normals: np.ndarray, uvs: np.ndarray) -> np.ndarray:
    """MikkTSpace tangents of every triangle corner (see the module docstring).

    Args:
        positions: ``[T, 3, 3]`` corner positions.
        normals: ``[T, 3, 3]`` corner normals (unit).
        uvs: ``[T, 3, 2]`` corner UVs, glTF convention (v down the image).
    Returns:
        ``[T, 3, 4]`` float32: unit tangent xyz (``(1, 0, 0)`` where no triangle with usable UVs
        defines one, as the reference) and the glTF handedness ``w = +-1``.
    """
    positions = np.asarray(positions, np.float32)
    normals = np.asarray(normals, np.float32)
    uvs = np.asarray(uvs, np.float32)
    n_tris = positions.shape[0]
    vertex = _welded_vertices(positions, normals, uvs)
    p, n = positions.astype(np.float64), normals.astype(np.float64)
    alive = ~((p[:, 0] == p[:, 1]).all(-1) | (p[:, 0] == p[:, 2]).all(-1) | (p[:, 1] == p[:, 2]).all(-1))
    direction, orient, good = _triangle_directions(p, uvs.astype(np.float64))
    group, orient = _corner_groups(vertex, alive, orient, good)

    # Step 5: angle-weighted, projected triangle directions summed per group.
    contributes = np.repeat(good & alive, 3)[:, None]
    projected = _project(np.repeat(direction, 3, axis=0), n.reshape(-1, 3))
    weighted = np.where(contributes, _corner_angles(p, n)[:, None] * projected, 0.0)
    summed = np.stack([np.bincount(group, weighted[:, k], minlength=group.max() + 1) for k in range(3)], -1)
    # A group without contributing triangles keeps the reference's initial tangent (1, 0, 0).
    empty = np.linalg.norm(summed, axis=-1) <= _FLT_MIN
    tangent = np.where(empty[:, None], _UNSET_TANGENT, _unit(summed))[group]
    # The reference's sign is computed on glTF UVs here; glTF's w is its negation.
    sign = np.where(np.repeat(orient, 3), -1.0, 1.0)

    # Step 2: corners of degenerate triangles copy a live corner of the same vertex.
    corner_vertex = vertex.reshape(-1)
    live = np.repeat(alive, 3)
    if (~live).any():
        donor = np.full(int(corner_vertex.max()) + 1, -1)
        donor[corner_vertex[live]] = np.flatnonzero(live)
        take = donor[corner_vertex[~live]]
        dead = np.flatnonzero(~live)
        has = take >= 0
        tangent[dead[has]] = tangent[take[has]]
        sign[dead[has]] = sign[take[has]]
        tangent[dead[~has]] = _UNSET_TANGENT
    return np.concatenate([tangent, sign[:, None]], axis=-1).reshape(n_tris, 3, 4).astype(np.float32)
