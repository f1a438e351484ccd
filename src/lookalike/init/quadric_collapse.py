"""Edge collapse by quadric error in strict order of cost (Garland and Heckbert 1997), each
vertex placed where its error is least, as a compiled kernel with its Python twin.

Why our own. The libraries' collapses stall on fine marching-cubes meshes of a field (tens of
thousands of triangles above a count of a thousand): fast-simplification refuses any collapse that
turns a face by more than 78 degrees or leaves an angle under 2.6 degrees, which the staircase
along a marching-cubes crease always does, and meshoptimizer keeps vertices where they were, so
that its chords cut inside curved surfaces and its corners stay chamfered. This collapse refuses
only what breaks the surface: a face that turns over (``FLIP_COS``), a collapse that changes the
topology (the link condition), and an open border pinched to an interior edge.

The error of a point ``p`` at a vertex is ``p^T Q p`` (homogeneous ``p``), ``Q`` the sum over its
faces of ``area * [n; d] [n; d]^T`` (``n`` the unit normal, ``d = -n . a``), plus, along each open
border edge, the plane through the edge at right angles to its face, weighted by
``BORDER_WEIGHT * length^2`` so that open borders keep their place (``vertex_quadrics``). An edge's
cost is the least error of ``Q_u + Q_v``: at the point solving ``A p = -b`` where ``A`` is well
conditioned and that point lies near the edge, else at the best of its ends and midpoint; plus
``TIE_LENGTH`` times its length to the fourth. The cheapest edge is collapsed first (equal costs
by the edge's ends, so that the order does not depend on the order of pushes), its cost
recomputed lazily: an entry whose ends have changed since it was pushed is skipped.
"""

from __future__ import annotations

import heapq
import math

import numpy as np
from numba import njit

from ..kernel_cache import CACHE

BORDER_WEIGHT = 100.0
"""Weight of an open border edge's perpendicular plane per squared edge length (a face's weight
is its area): a border vertex moves along the border, hardly across it."""
FLIP_COS = 0.0
"""A collapse is refused where a remaining face's unit normal would turn by 90 degrees or more
(cosine at or below this) or the face would lose its area."""
TIE_LENGTH = 1e-8
"""An edge's cost adds this times its length to the fourth (the quadric error's unit): of
collapses that cost nothing (a flat region), the shortest go first, so that flat regions shrink
evenly instead of fanning out from one vertex."""
SINGULAR = 1e-9
"""``det(A)`` below this times ``(trace(A) / 3)^3`` counts as singular (a flat or crease-only
neighbourhood): the cost is then taken at the ends or the midpoint."""
NEAR_EDGE = 2.0
"""The solved point is used only within this many edge lengths of the edge's midpoint."""


def vertex_quadrics(v_pos: np.ndarray, t_pos_idx: np.ndarray) -> np.ndarray:
    """``[V, 10]`` float64 quadrics ``(aa, ab, ac, ad, bb, bc, bd, cc, cd, dd)`` of the planes
    ``(a, b, c, d)`` of the faces at each vertex of ``v_pos [V, 3]`` / ``t_pos_idx [T, 3]``,
    weighted by area, plus the border planes (module docstring)."""
    corners = v_pos[t_pos_idx]
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    double_area = np.linalg.norm(cross, axis=1)
    normal = cross / np.maximum(double_area, 1e-300)[:, None]
    quadrics = np.zeros((len(v_pos), 10))
    _add_planes(quadrics, t_pos_idx, normal, corners[:, 0], 0.5 * double_area)
    edges = np.concatenate([t_pos_idx[:, [0, 1]], t_pos_idx[:, [1, 2]], t_pos_idx[:, [2, 0]]])
    _, inverse, counts = np.unique(edge_keys(edges, len(v_pos)), return_inverse=True, return_counts=True)
    border = counts[inverse] == 1
    if border.any():
        face = np.tile(np.arange(len(t_pos_idx)), 3)[border]
        ends = edges[border]
        along = v_pos[ends[:, 1]] - v_pos[ends[:, 0]]
        side = np.cross(along, normal[face])
        side /= np.maximum(np.linalg.norm(side, axis=1), 1e-300)[:, None]
        _add_planes(quadrics, ends, side, v_pos[ends[:, 0]], BORDER_WEIGHT * (along * along).sum(1))
    return quadrics


def _add_planes(quadrics: np.ndarray, owners: np.ndarray, normal: np.ndarray, point: np.ndarray,
                weight: np.ndarray) -> None:
    """Add to ``quadrics [V, 10]``, at each vertex of ``owners [N, k]``, ``weight [N]`` times the
    quadric of the plane through ``point [N, 3]`` with unit ``normal [N, 3]``."""
    plane = np.concatenate([normal, -(normal * point).sum(1, keepdims=True)], axis=1)
    upper = np.triu_indices(4)
    outer = (plane[:, :, None] * plane[:, None, :])[:, upper[0], upper[1]] * weight[:, None]
    owner = owners.T.reshape(-1)  # the owners of column 0, then of column 1, ...
    for j in range(quadrics.shape[1]):
        quadrics[:, j] += np.bincount(owner, np.tile(outer[:, j], owners.shape[1]), len(quadrics))


def edge_keys(edges: np.ndarray, n_vertices: int) -> np.ndarray:
    """``[E]`` int64 ``lo * n_vertices + hi`` of ``edges [E, 2]`` (either order): one key per
    undirected edge, sorting as the pairs ``(lo, hi)`` do."""
    lo, hi = np.minimum(edges[:, 0], edges[:, 1]), np.maximum(edges[:, 0], edges[:, 1])
    return lo.astype(np.int64) * n_vertices + hi


def mesh_edges(t_pos_idx: np.ndarray) -> np.ndarray:
    """``[E, 2]`` int64: each undirected edge of ``t_pos_idx [T, 3]`` once, smaller index first,
    in sorted order."""
    edges = np.concatenate([t_pos_idx[:, [0, 1]], t_pos_idx[:, [1, 2]], t_pos_idx[:, [2, 0]]])
    n = int(edges.max()) + 1 if len(edges) else 1
    keys = np.unique(edge_keys(edges, n))
    return np.stack([keys // n, keys % n], axis=1)


@njit(cache=CACHE)
def _placement(q, p_u, p_v):
    """``(cost, x, y, z)``: the least error of quadric ``q [10]`` (module docstring)."""
    aa, ab, ac, ad, bb, bc, bd, cc, cd, dd = q[0], q[1], q[2], q[3], q[4], q[5], q[6], q[7], q[8], q[9]
    c00, c01, c02 = bb * cc - bc * bc, ac * bc - ab * cc, ab * bc - bb * ac
    c11, c12, c22 = aa * cc - ac * ac, ab * ac - aa * bc, aa * bb - ab * ab
    det = aa * c00 + ab * c01 + ac * c02
    scale = (aa + bb + cc) / 3.0
    mx, my, mz = 0.5 * (p_u[0] + p_v[0]), 0.5 * (p_u[1] + p_v[1]), 0.5 * (p_u[2] + p_v[2])
    ex, ey, ez = p_v[0] - p_u[0], p_v[1] - p_u[1], p_v[2] - p_u[2]
    reach = NEAR_EDGE * math.sqrt(ex * ex + ey * ey + ez * ez)
    if scale > 0.0 and abs(det) > SINGULAR * scale * scale * scale:
        x = -(c00 * ad + c01 * bd + c02 * cd) / det
        y = -(c01 * ad + c11 * bd + c12 * cd) / det
        z = -(c02 * ad + c12 * bd + c22 * cd) / det
        if math.sqrt((x - mx) ** 2 + (y - my) ** 2 + (z - mz) ** 2) <= reach:
            return _error(q, x, y, z), x, y, z
    best, bx, by, bz = _error(q, mx, my, mz), mx, my, mz
    for p in (p_u, p_v):
        e = _error(q, p[0], p[1], p[2])
        if e < best:
            best, bx, by, bz = e, p[0], p[1], p[2]
    return best, bx, by, bz


@njit(cache=CACHE)
def _edge_cost(q, p_u, p_v):
    """The edge's place in the queue: its least error (``_placement``) plus ``TIE_LENGTH``
    times its length to the fourth."""
    length2 = (p_v[0] - p_u[0]) ** 2 + (p_v[1] - p_u[1]) ** 2 + (p_v[2] - p_u[2]) ** 2
    return _placement(q, p_u, p_v)[0] + TIE_LENGTH * length2 * length2


@njit(cache=CACHE)
def _error(q, x, y, z):
    """``p^T Q p`` for ``p = (x, y, z, 1)``, never below zero (rounding)."""
    e = (q[0] * x * x + 2.0 * q[1] * x * y + 2.0 * q[2] * x * z + 2.0 * q[3] * x + q[4] * y * y
         + 2.0 * q[5] * y * z + 2.0 * q[6] * y + q[7] * z * z + 2.0 * q[8] * z + q[9])
    return max(e, 0.0)


@njit(cache=CACHE)
def _before(cost_a, cost_b, lo, hi, a, b):
    """Whether entry ``a`` (of cost ``cost_a``) is popped before entry ``b``: by cost, then by
    the edge's ends (the order of equal costs does not depend on the order of pushes), then by
    age."""
    if cost_a != cost_b:
        return cost_a < cost_b
    if lo[a] != lo[b]:
        return lo[a] < lo[b]
    if hi[a] != hi[b]:
        return hi[a] < hi[b]
    return a < b


@njit(cache=CACHE)
def _sift_up(heap, keys, lo, hi, i):
    """Move ``heap[i]`` (entries, their costs ``keys`` beside them: a sift reads the costs in
    heap order, not scattered over the entries) up to its place."""
    entry, key = heap[i], keys[i]
    while i > 0:
        parent = (i - 1) // 2
        if _before(keys[parent], key, lo, hi, heap[parent], entry):
            break
        heap[i], keys[i] = heap[parent], keys[parent]
        i = parent
    heap[i], keys[i] = entry, key


@njit(cache=CACHE)
def _sift_down(heap, keys, lo, hi, size, i):
    entry, key = heap[i], keys[i]
    while True:
        child = 2 * i + 1
        if child >= size:
            break
        if child + 1 < size and _before(keys[child + 1], keys[child], lo, hi, heap[child + 1], heap[child]):
            child += 1
        if _before(key, keys[child], lo, hi, entry, heap[child]):
            break
        heap[i], keys[i] = heap[child], keys[child]
        i = child
    heap[i], keys[i] = entry, key


@njit(cache=CACHE)
def _grown(array, capacity):
    out = np.empty(capacity, array.dtype)
    out[:array.shape[0]] = array
    return out


@njit(cache=CACHE)
def _turns_over(pos, faces, face, corner, x, y, z, min_double_area):
    """Whether moving ``faces[face, corner]`` to ``(x, y, z)`` turns the face's normal by 90
    degrees or more (``FLIP_COS``) or leaves it without area (twice its area at most
    ``min_double_area``)."""
    a, b, c = faces[face, 0], faces[face, 1], faces[face, 2]
    ax, ay, az = pos[a, 0], pos[a, 1], pos[a, 2]
    bx, by, bz = pos[b, 0], pos[b, 1], pos[b, 2]
    cx, cy, cz = pos[c, 0], pos[c, 1], pos[c, 2]
    ox = (by - ay) * (cz - az) - (bz - az) * (cy - ay)
    oy = (bz - az) * (cx - ax) - (bx - ax) * (cz - az)
    oz = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    if corner == 0:
        ax, ay, az = x, y, z
    elif corner == 1:
        bx, by, bz = x, y, z
    else:
        cx, cy, cz = x, y, z
    nx = (by - ay) * (cz - az) - (bz - az) * (cy - ay)
    ny = (bz - az) * (cx - ax) - (bx - ax) * (cz - az)
    nz = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
    new_length = math.sqrt(nx * nx + ny * ny + nz * nz)
    old_length = math.sqrt(ox * ox + oy * oy + oz * oz)
    return new_length <= min_double_area or ox * nx + oy * ny + oz * nz <= FLIP_COS * old_length * new_length


@njit(cache=CACHE)
def _star(head, nxt, faces, face_alive, centre, other, mark, count, token, out):
    """The distinct neighbours of ``centre`` over its live faces written to ``out``; returns
    ``(how many, faces shared with other, whether an edge of centre has one face)``. Marks
    neighbours with ``token`` in ``mark`` and counts their faces in ``count``."""
    found = 0
    shared = 0
    c = head[centre]
    while c >= 0:
        f = c // 3
        if face_alive[f]:
            has_other = False
            for k in range(3):
                w = faces[f, k]
                if w == centre:
                    continue
                if w == other:
                    has_other = True
                if mark[w] != token:
                    mark[w] = token
                    count[w] = 0
                    out[found] = w
                    found += 1
                count[w] += 1
            if has_other:
                shared += 1
        c = nxt[c]
    border = False
    for i in range(found):
        if count[out[i]] == 1:
            border = True
    return found, shared, border


@njit(cache=CACHE)
def _collapse(pos, faces, quadrics, edges, target, min_double_area):
    """Collapse edges of ``faces [T, 3]`` (in place, with ``pos [V, 3]`` and ``quadrics [V, 10]``)
    until at most ``target`` faces live; returns ``face_alive [T]``."""
    n_vertices, n_faces = pos.shape[0], faces.shape[0]
    face_alive = np.ones(n_faces, np.bool_)
    vertex_alive = np.ones(n_vertices, np.bool_)
    stamp = np.zeros(n_vertices, np.int64)
    head = np.full(n_vertices, -1, np.int64)
    nxt = np.full(3 * n_faces, -1, np.int64)
    for c in range(3 * n_faces - 1, -1, -1):
        v = faces[c // 3, c % 3]
        nxt[c] = head[v]
        head[v] = c
    capacity = max(16, 4 * edges.shape[0])
    keys = np.empty(capacity)
    lo = np.empty(capacity, np.int64)
    hi = np.empty(capacity, np.int64)
    stamp_lo = np.empty(capacity, np.int64)
    stamp_hi = np.empty(capacity, np.int64)
    heap = np.empty(capacity, np.int64)
    entries = 0
    size = 0
    for e in range(edges.shape[0]):
        u, w = edges[e, 0], edges[e, 1]
        lo[entries], hi[entries] = u, w
        stamp_lo[entries], stamp_hi[entries] = 0, 0
        heap[size], keys[size] = entries, _edge_cost(quadrics[u] + quadrics[w], pos[u], pos[w])
        _sift_up(heap, keys, lo, hi, size)
        entries += 1
        size += 1
    mark_u = np.full(n_vertices, -1, np.int64)
    mark_v = np.full(n_vertices, -1, np.int64)
    count_u = np.zeros(n_vertices, np.int64)
    count_v = np.zeros(n_vertices, np.int64)
    ring_u = np.empty(n_vertices, np.int64)
    ring_v = np.empty(n_vertices, np.int64)
    live = n_faces
    token = 0
    while live > target and size > 0:
        e = heap[0]
        size -= 1
        heap[0], keys[0] = heap[size], keys[size]
        if size > 0:
            _sift_down(heap, keys, lo, hi, size, 0)
        u, v = lo[e], hi[e]
        if not (vertex_alive[u] and vertex_alive[v]) or stamp[u] != stamp_lo[e] or stamp[v] != stamp_hi[e]:
            continue
        token += 1
        n_u, shared, border_u = _star(head, nxt, faces, face_alive, u, v, mark_u, count_u, token, ring_u)
        n_v, _, border_v = _star(head, nxt, faces, face_alive, v, u, mark_v, count_v, token, ring_v)
        if shared == 0 or shared > 2 or (shared == 2 and border_u and border_v):
            continue
        common = 0
        for i in range(n_v):
            w = ring_v[i]
            if w != u and mark_u[w] == token:
                common += 1
        if common != shared:
            continue
        q = quadrics[u] + quadrics[v]
        _, x, y, z = _placement(q, pos[u], pos[v])
        refused = False
        for centre, other in ((u, v), (v, u)):
            c = head[centre]
            while c >= 0 and not refused:
                f = c // 3
                if face_alive[f] and faces[f, 0] != other and faces[f, 1] != other and faces[f, 2] != other:
                    refused = _turns_over(pos, faces, f, c % 3, x, y, z, min_double_area)
                c = nxt[c]
        if refused:
            continue
        pos[u, 0], pos[u, 1], pos[u, 2] = x, y, z
        quadrics[u] = q
        vertex_alive[v] = False
        stamp[u] += 1
        c = head[v]
        tail = -1
        while c >= 0:
            f = c // 3
            if face_alive[f]:
                if faces[f, 0] == u or faces[f, 1] == u or faces[f, 2] == u:
                    face_alive[f] = False
                    live -= 1
                else:
                    faces[f, c % 3] = u
            tail = c
            c = nxt[c]
        if tail >= 0:
            nxt[tail] = head[u]
            head[u] = head[v]
            head[v] = -1
        previous = -1
        c = head[u]
        while c >= 0:                                # drop dead faces' corners from u's list
            if face_alive[c // 3]:
                previous = c
            elif previous < 0:
                head[u] = nxt[c]
            else:
                nxt[previous] = nxt[c]
            c = nxt[c]
        token += 1
        n_u, _, _ = _star(head, nxt, faces, face_alive, u, -1, mark_u, count_u, token, ring_u)
        for i in range(n_u):
            w = ring_u[i]
            if entries == capacity:
                capacity *= 2
                keys, lo, hi = _grown(keys, capacity), _grown(lo, capacity), _grown(hi, capacity)
                stamp_lo, stamp_hi = _grown(stamp_lo, capacity), _grown(stamp_hi, capacity)
                heap = _grown(heap, capacity)
            a, b = min(u, w), max(u, w)
            lo[entries], hi[entries] = a, b
            stamp_lo[entries], stamp_hi[entries] = stamp[a], stamp[b]
            heap[size], keys[size] = entries, _edge_cost(quadrics[a] + quadrics[b], pos[a], pos[b])
            _sift_up(heap, keys, lo, hi, size)
            entries += 1
            size += 1
    return face_alive


def _prepared(v_pos: np.ndarray, t_pos_idx: np.ndarray):
    """Shared start of both twins: positions as float64, faces as int64, quadrics, edges, and
    the least double area a face may keep (``1e-12`` of the squared bounding-box diagonal)."""
    pos = np.array(v_pos, np.float64)
    faces = np.array(t_pos_idx, np.int64).reshape(-1, 3)
    diagonal = float(np.linalg.norm(pos.max(0) - pos.min(0))) if len(pos) else 0.0
    return pos, faces, vertex_quadrics(pos, faces), mesh_edges(faces), 2e-12 * diagonal * diagonal


def _compacted(pos: np.ndarray, faces: np.ndarray, face_alive: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    kept = faces[face_alive]
    used, inverse = np.unique(kept, return_inverse=True)
    return pos[used], inverse.reshape(-1, 3).astype(np.int64)


def quadric_collapse(v_pos: np.ndarray, t_pos_idx: np.ndarray, triangles: int) -> tuple[np.ndarray, np.ndarray]:
    """Collapse edges of ``v_pos [V, 3]`` / ``t_pos_idx [T, 3]`` (welded, no degenerate faces) in
    order of quadric error until at most ``triangles`` faces are left (one fewer where the last
    collapse was inside the surface: it removes two faces), or no edge can be collapsed.
    Returns ``(v_pos [V', 3] float64, t_pos_idx [T', 3] int64)``, unreferenced vertices dropped,
    faces in input order. :func:`quadric_collapse_python` is the twin."""
    pos, faces, quadrics, edges, min_double_area = _prepared(v_pos, t_pos_idx)
    if len(faces) <= triangles:
        return _compacted(pos, faces, np.ones(len(faces), bool))
    alive = _collapse(pos, faces, quadrics, edges, int(triangles), min_double_area)
    return _compacted(pos, faces, alive)


def quadric_collapse_python(v_pos: np.ndarray, t_pos_idx: np.ndarray, triangles: int
                            ) -> tuple[np.ndarray, np.ndarray]:
    """Twin of :func:`quadric_collapse` over Python sets and ``heapq`` (the tests' oracle)."""
    pos, faces, quadrics, edges, min_double_area = _prepared(v_pos, t_pos_idx)
    place, edge_cost, turns_over = _placement.py_func, _edge_cost.py_func, _turns_over.py_func
    alive = np.ones(len(faces), bool)
    around = [set() for _ in range(len(pos))]
    for f, face in enumerate(faces):
        for w in face:
            around[w].add(f)
    stamp, dead = [0] * len(pos), set()
    heap = [(edge_cost(quadrics[a] + quadrics[b], pos[a], pos[b]), a, b, 0, 0) for a, b in edges.tolist()]
    heapq.heapify(heap)

    def star(centre):
        """``{neighbour: faces with it}`` over the live faces at ``centre``."""
        counts = {}
        for f in around[centre]:
            for w in faces[f]:
                if w != centre:
                    counts[int(w)] = counts.get(int(w), 0) + 1
        return counts

    live = len(faces)
    while live > triangles and heap:
        _, u, v, stamp_u, stamp_v = heapq.heappop(heap)
        if u in dead or v in dead or stamp[u] != stamp_u or stamp[v] != stamp_v:
            continue
        ring_u, ring_v = star(u), star(v)
        shared = [f for f in around[u] if v in faces[f]]
        border_u, border_v = 1 in ring_u.values(), 1 in ring_v.values()
        if not 0 < len(shared) <= 2 or (len(shared) == 2 and border_u and border_v):
            continue
        if len((ring_u.keys() & ring_v.keys()) - {u, v}) != len(shared):
            continue
        q = quadrics[u] + quadrics[v]
        _, x, y, z = place(q, pos[u], pos[v])
        if any(turns_over(pos, faces, f, list(faces[f]).index(centre), x, y, z, min_double_area)
               for centre, other in ((u, v), (v, u)) for f in around[centre] if other not in faces[f]):
            continue
        pos[u] = x, y, z
        quadrics[u] = q
        stamp[u] += 1
        dead.add(v)
        for f in shared:
            alive[f] = False
            live -= 1
            for w in faces[f]:
                around[w].discard(f)
        for f in around[v]:
            faces[f][list(faces[f]).index(v)] = u
        around[u] |= around[v]
        around[v] = set()
        for w in star(u):
            a, b = min(u, w), max(u, w)
            heapq.heappush(heap, (edge_cost(quadrics[a] + quadrics[b], pos[a], pos[b]), a, b, stamp[a], stamp[b]))
    return _compacted(pos, faces, alive)
