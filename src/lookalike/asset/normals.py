"""Shading normals of triangle meshes: face normals, split smooth normals (differentiable with
respect to positions), smoothing groups split at creases, and welding authored normals into slots.

A mesh's corners index normal *slots* (``t_nrm_idx [T, 3]``, ``lookalike.asset.mesh``); every slot
is used at one position only, and the corners that share a slot form one smoothing group around
that position. A slot's split smooth normal is the normalised sum of the area-weighted face normals
of its corners, so a hard edge is two slots on each of its end positions.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse
import scipy.sparse.csgraph
import torch

from .edges import edge_index
from .index_tables import first_occurrence_slots

FALLBACK_NORMAL = (0.0, 0.0, 1.0)
"""Normal given to slots whose triangles all have zero area (or that no triangle uses)."""

DEFAULT_CREASE_ANGLE = 60.0
"""Dihedral angle in degrees above which an edge of a mesh whose geometry we make (decimation,
the fitted model) is hard: its two sides get their own normals, as Blender's auto smooth does.
A 90 degree edge shaded round cannot be undone by a normal map (it would have to bend the normal
by 45 degrees within one texel at the edge), while splitting at lower angles would show the facets
of coarse curved surfaces, whose dihedral angles at low-poly budgets reach 20 to 45 degrees."""


def safe_normalize(x: torch.Tensor, eps: float = 1e-20) -> torch.Tensor:
    """``x / |x|`` along the last axis, with ``|x|^2`` clamped below by ``eps`` so that a zero
    vector stays zero (finite value and gradient) instead of becoming NaN.

    Args:
        x: ``[..., C]`` float tensor.
    Returns:
        ``[..., C]``, same dtype.
    """
    return x * torch.rsqrt(torch.clamp((x * x).sum(dim=-1, keepdim=True), min=eps))


def face_normals(v_pos: torch.Tensor, t_pos_idx: torch.Tensor) -> torch.Tensor:
    """Unnormalised face normals ``(v1 - v0) x (v2 - v0)``; the length is twice the area.

    Args:
        v_pos: ``[V, 3]`` float positions.
        t_pos_idx: ``[T, 3]`` int64 counter-clockwise triangles.
    Returns:
        ``[T, 3]`` float, same dtype as ``v_pos``.
    """
    v0, v1, v2 = (v_pos[t_pos_idx[:, k]] for k in range(3))
    return torch.linalg.cross(v1 - v0, v2 - v0, dim=-1)


def _unit_or_fallback(summed: torch.Tensor) -> torch.Tensor:
    """Rows of ``summed [N, 3]`` normalised; rows of zero length become ``FALLBACK_NORMAL``."""
    length2 = (summed * summed).sum(dim=-1, keepdim=True)
    fallback = torch.tensor(FALLBACK_NORMAL, dtype=summed.dtype, device=summed.device)
    tiny = torch.finfo(summed.dtype).tiny
    return torch.where(length2 > tiny, safe_normalize(summed, eps=tiny), fallback)


def split_normals(v_pos: torch.Tensor, t_pos_idx: torch.Tensor, t_nrm_idx: torch.Tensor,
                  num_normals: int) -> torch.Tensor:
    """Unit split smooth normals: slot ``s`` gets ``normalize(sum_{corners c in s} f_c)`` with
    ``f_c = (v1 - v0) x (v2 - v0)`` the face normal of the corner's triangle (area-weighted).

    Degenerate (zero-area) triangles contribute nothing; a slot whose sum is zero gets
    ``FALLBACK_NORMAL``. Values and gradients (with respect to ``v_pos``) are finite for any input.

    Args:
        v_pos: ``[V, 3]`` float positions (float32 or float64).
        t_pos_idx: ``[T, 3]`` int64 counter-clockwise triangles.
        t_nrm_idx: ``[T, 3]`` int64 normal slot of each corner.
        num_normals: ``VN``, the number of slots (``> t_nrm_idx.max()``).
    Returns:
        ``[VN, 3]`` unit normals, dtype and device of ``v_pos``.
    """
    fn = face_normals(v_pos, t_pos_idx)
    summed = v_pos.new_zeros(num_normals, 3).index_add(0, t_nrm_idx.reshape(-1), fn.repeat_interleave(3, dim=0))
    return _unit_or_fallback(summed)


def split_normals_python(v_pos: torch.Tensor, t_pos_idx: torch.Tensor, t_nrm_idx: torch.Tensor,
                         num_normals: int) -> torch.Tensor:
    """Loop twin of ``split_normals`` (same arguments and result), to test it against."""
    summed = [torch.zeros(3, dtype=v_pos.dtype) for _ in range(num_normals)]
    for (a, b, c), slots in zip(t_pos_idx.tolist(), t_nrm_idx.tolist()):
        normal = torch.linalg.cross(v_pos[b] - v_pos[a], v_pos[c] - v_pos[a])
        for slot in slots:
            summed[slot] = summed[slot] + normal
    return _unit_or_fallback(torch.stack(summed))


def vertex_normals(v_pos: torch.Tensor, t_pos_idx: torch.Tensor) -> torch.Tensor:
    """Smooth unit vertex normals: ``split_normals`` with one slot per position (``[V, 3]``, dtype
    and device of ``v_pos``)."""
    return split_normals(v_pos, t_pos_idx, t_pos_idx, v_pos.shape[0])


def angle_weighted_normals(v_pos: torch.Tensor, t_pos_idx: torch.Tensor) -> torch.Tensor:
    """Unit vertex normals ``[V, 3]``: ``normalize(sum_t angle_t(v) * n_t)`` over the triangles
    ``t`` at each vertex, ``angle_t(v)`` the corner angle and ``n_t`` the unit face normal
    (Blender's vertex normals). A vertex keeps its normal when the triangles around it are
    subdivided at edge midpoints, so displacement moves it alike at every tessellation level.
    Differentiable in ``v_pos``."""
    corners = v_pos[t_pos_idx]  # [T, 3, 3]
    ahead, behind = corners.roll(-1, dims=1) - corners, corners.roll(1, dims=1) - corners
    angle = torch.atan2(torch.linalg.cross(ahead, behind, dim=-1).norm(dim=-1), (ahead * behind).sum(dim=-1))
    unit = safe_normalize(face_normals(v_pos, t_pos_idx))
    weighted = angle[..., None] * unit[:, None, :]  # [T, 3, 3]
    summed = torch.zeros_like(v_pos).index_add(0, t_pos_idx.reshape(-1), weighted.reshape(-1, 3))
    return _unit_or_fallback(summed)


def angle_weighted_normals_python(v_pos: torch.Tensor, t_pos_idx: torch.Tensor) -> torch.Tensor:
    """``angle_weighted_normals`` by a loop over triangles and corners (for tests)."""
    summed = [torch.zeros(3, dtype=v_pos.dtype) for _ in range(v_pos.shape[0])]
    for tri in t_pos_idx.tolist():
        normal = torch.linalg.cross(v_pos[tri[1]] - v_pos[tri[0]], v_pos[tri[2]] - v_pos[tri[0]])
        normal = normal / normal.norm()
        for k in range(3):
            a, b = v_pos[tri[(k + 1) % 3]] - v_pos[tri[k]], v_pos[tri[(k + 2) % 3]] - v_pos[tri[k]]
            angle = torch.arccos((a @ b / (a.norm() * b.norm())).clamp(-1.0, 1.0))
            summed[tri[k]] = summed[tri[k]] + angle * normal
    return _unit_or_fallback(torch.stack(summed))


def _first_occurrence_labels(labels: np.ndarray) -> np.ndarray:
    """``labels [N]`` renumbered 0, 1, ... in the order each first occurs."""
    _, first, inverse = np.unique(labels, return_index=True, return_inverse=True)
    rank = np.empty(len(first), dtype=np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    return rank[inverse.reshape(-1)]


def _next_corner(side: np.ndarray) -> np.ndarray:
    """Flat corner index ``3 t + (k + 1) % 3`` of the corner after ``side = 3 t + k``."""
    return side - side % 3 + (side % 3 + 1) % 3


def smooth_sides(v_pos: torch.Tensor, t_pos_idx: torch.Tensor,
                 crease_angle: float = DEFAULT_CREASE_ANGLE) -> tuple[np.ndarray, np.ndarray]:
    """The smooth edges of a mesh as pairs of triangle sides ``(s1 [S], s2 [S])`` int64 (side
    ``3 t + k`` runs from corner ``k`` to ``(k + 1) % 3`` of triangle ``t``; ``s1`` runs a -> b and
    ``s2`` b -> a). An edge is smooth when exactly two triangles share it, with opposite winding
    (a manifold, consistently oriented edge), both have non-zero area, and the angle between their
    face normals is at most ``crease_angle`` degrees; every other edge is hard.

    Args:
        v_pos: ``[V, 3]`` float positions (not differentiated).
        t_pos_idx: ``[T, 3]`` int64 counter-clockwise triangles.
    """
    tri = t_pos_idx.cpu()
    unit = safe_normalize(face_normals(v_pos.detach().double().cpu(), tri)).numpy()
    usable = np.abs(unit).sum(-1) > 0
    side_edge = edge_index(tri)[1].reshape(-1).numpy()
    tail = tri.reshape(-1).numpy()
    order = np.argsort(side_edge, kind="stable")
    count = np.bincount(side_edge)
    start = (np.cumsum(count) - count)[count == 2]
    s1, s2 = order[start], order[start + 1]
    t1, t2 = s1 // 3, s2 // 3
    cosine = (unit[t1] * unit[t2]).sum(-1)
    smooth = (tail[s1] != tail[s2]) & usable[t1] & usable[t2] & (cosine >= math.cos(math.radians(crease_angle)))
    return s1[smooth], s2[smooth]


def crease_normal_index(v_pos: torch.Tensor, t_pos_idx: torch.Tensor,
                        crease_angle: float = DEFAULT_CREASE_ANGLE) -> torch.Tensor:
    """Normal slots split at creases: the corners at one position share a slot when they are
    joined through smooth edges (``smooth_sides``) around it. Slots are numbered in the order
    their first corner occurs (row-major over ``[T, 3]``), so equal partitions give equal indices.

    Args:
        v_pos: ``[V, 3]`` float positions (not differentiated).
        t_pos_idx: ``[T, 3]`` int64 counter-clockwise triangles.
        crease_angle: the largest dihedral angle, in degrees, of a smooth edge.
    Returns:
        ``t_nrm_idx [T, 3]`` int64 on the device of ``t_pos_idx``.
    """
    s1, s2 = smooth_sides(v_pos, t_pos_idx, crease_angle)
    # s1 runs a -> b and s2 runs b -> a: corner s1 (at a) joins the corner after s2, and the corner
    # after s1 (at b) joins corner s2.
    links_from = np.concatenate([s1, _next_corner(s1)])
    links_to = np.concatenate([_next_corner(s2), s2])
    corners = 3 * t_pos_idx.shape[0]
    graph = scipy.sparse.coo_matrix((np.ones(len(links_from)), (links_from, links_to)), shape=(corners,) * 2)
    _, group = scipy.sparse.csgraph.connected_components(graph, directed=False)
    return torch.from_numpy(_first_occurrence_labels(group).reshape(-1, 3)).to(t_pos_idx.device)


def hard_sides(v_pos: torch.Tensor, t_pos_idx: torch.Tensor, t_nrm_idx: torch.Tensor | None = None,
               crease_angle: float = DEFAULT_CREASE_ANGLE) -> torch.Tensor:
    """``[T, 3]`` bool on the CPU: side ``k`` of triangle ``t`` (corners ``k``, ``(k + 1) % 3``)
    lies on a hard edge: not smooth (``smooth_sides``: a border, a non-manifold or flipped edge,
    or a crease sharper than ``crease_angle``, where a model written on crease normals splits
    them), or its two triangles' normal slots ``t_nrm_idx [T, 3]`` (``None``: one per position)
    differ at either end."""
    s1, s2 = smooth_sides(v_pos, t_pos_idx, crease_angle)
    slots = (t_pos_idx if t_nrm_idx is None else t_nrm_idx).cpu().reshape(-1).numpy()
    shared = (slots[s1] == slots[_next_corner(s2)]) & (slots[_next_corner(s1)] == slots[s2])
    hard = np.ones(slots.size, bool)
    hard[s1[shared]] = False
    hard[s2[shared]] = False
    return torch.from_numpy(hard.reshape(-1, 3))


def split_at_both(t_nrm_idx: torch.Tensor, other: torch.Tensor) -> torch.Tensor:
    """Normal slots split wherever either of two slot assignments splits: two corners share a
    slot where they share one in ``t_nrm_idx`` and in ``other`` (both ``[T, 3]`` int64 over the
    same triangles); numbered in the order their first corner occurs.

    Returns:
        ``[T, 3]`` int64 on the device of ``t_nrm_idx``.
    """
    pair = t_nrm_idx.cpu().reshape(-1).numpy() * (int(other.max()) + 1) + other.cpu().reshape(-1).numpy()
    return torch.from_numpy(_first_occurrence_labels(pair).reshape(-1, 3)).to(t_nrm_idx.device)


def crease_normal_index_python(v_pos: torch.Tensor, t_pos_idx: torch.Tensor,
                               crease_angle: float = DEFAULT_CREASE_ANGLE) -> torch.Tensor:
    """Loop twin of ``crease_normal_index`` (same arguments and result), to test it against."""
    tris = t_pos_idx.tolist()
    p = v_pos.detach().double()
    sides: dict[frozenset, list[tuple[int, int]]] = {}
    for t, corners in enumerate(tris):
        for k in range(3):
            sides.setdefault(frozenset((corners[k], corners[(k + 1) % 3])), []).append((t, k))
    parent = list(range(3 * len(tris)))

    def root(c: int) -> int:
        while parent[c] != c:
            c = parent[c]
        return c

    def unit_normal(t: int) -> torch.Tensor:
        a, b, c = (p[i] for i in tris[t])
        n = torch.linalg.cross(b - a, c - a)
        return n / n.norm() if n.norm() > 0 else n

    limit = math.cos(math.radians(crease_angle))
    for shared in sides.values():
        if len(shared) != 2:
            continue
        (t1, k1), (t2, k2) = shared
        n1, n2 = unit_normal(t1), unit_normal(t2)
        if tris[t1][k1] == tris[t2][k2] or n1.norm() == 0 or n2.norm() == 0 or float(n1 @ n2) < limit:
            continue
        for c1, c2 in ((3 * t1 + k1, 3 * t2 + (k2 + 1) % 3), (3 * t1 + (k1 + 1) % 3, 3 * t2 + k2)):
            parent[root(c1)] = root(c2)
    labels = np.array([root(c) for c in range(3 * len(tris))])
    return torch.from_numpy(_first_occurrence_labels(labels).reshape(-1, 3))


def weld_normals(t_pos_idx: torch.Tensor, corner_normals: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Slots of authored per-corner normals: one slot per distinct (position, normal) pair,
    normals compared bitwise (``-0.0`` equal to ``0.0``).

    Each corner's normal is compared, bit for bit, with the distinct normals met so far at its
    position (``index_tables.first_occurrence_slots``, compiled): one pass over the corners,
    because sorting the keys (``np.lexsort``, ``torch.unique(dim=0)``) dominated the loading of
    large inputs.

    Args:
        t_pos_idx: ``[T, 3]`` int64 triangles.
        corner_normals: ``[T, 3, 3]`` float32 normal of every corner.
    Returns:
        ``(v_nrm [VN, 3] float32, t_nrm_idx [T, 3] int64)`` with ``v_nrm[t_nrm_idx]`` equal to
        ``corner_normals``, slots numbered in the order their first corner occurs.
    """
    normals = corner_normals.reshape(-1, 3).float() + 0.0
    bits = normals.cpu().contiguous().view(torch.int32).numpy()
    position = np.ascontiguousarray(t_pos_idx.reshape(-1).cpu().numpy(), np.int64)
    slot_np, count = first_occurrence_slots(position, bits, int(position.max(initial=-1)) + 1)
    slot = torch.from_numpy(slot_np).to(t_pos_idx.device)
    v_nrm = normals.new_zeros(count, 3).index_copy(0, slot, normals)
    return v_nrm, slot.reshape(-1, 3)


def weld_normals_python(t_pos_idx: torch.Tensor, corner_normals: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Loop twin of ``weld_normals`` (same arguments and result), to test it against."""
    slots: dict[tuple, int] = {}
    values, index = [], []
    for position, normal in zip(t_pos_idx.reshape(-1).tolist(), (corner_normals.reshape(-1, 3).float() + 0.0).tolist()):
        key = (position, *np.float32(normal).view(np.int32).tolist())
        if key not in slots:
            slots[key] = len(values)
            values.append(normal)
        index.append(slots[key])
    return torch.tensor(values, dtype=torch.float32).reshape(-1, 3), torch.tensor(index, dtype=torch.int64).reshape(-1, 3)


def file_normals(v_pos: torch.Tensor, t_pos_idx: torch.Tensor, values: torch.Tensor,
                 index: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Slots (``weld_normals``) of a file's normals ``values [N, 3]`` at the corners ``index
    [T, 3]``, normalised; corners whose normal is zero take the smooth vertex normal
    (``vertex_normals`` of ``v_pos [V, 3]``, ``t_pos_idx [T, 3]``). Returns ``(v_nrm [VN, 3]
    float32, t_nrm_idx [T, 3] int64)``."""
    corner = safe_normalize(values.float()[index])
    smooth = vertex_normals(v_pos.float(), t_pos_idx)[t_pos_idx]
    return weld_normals(t_pos_idx, torch.where((corner == 0).all(-1, keepdim=True), smooth, corner))
