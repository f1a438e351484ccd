"""Exact closest points on a triangle mesh, fast.

``closest_barycentric`` is the vectorised point-triangle closest point (Voronoi-region
classification, Ericson, *Real-Time Collision Detection*, Sec. 5.1.5); ``_best_candidates`` is
its compiled twin (Numba) that scans each query point's shortlist.
``SurfaceQuery`` finds, for many points at once, the closest point on a whole mesh: a k-d tree
over samples that cover every triangle shortlists candidates, the exact test picks the best,
and a bound certifies the answer (or widens the shortlist for the few points it cannot).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit, prange
from scipy.spatial import cKDTree

from ..kernel_cache import CACHE
from ..threads import thread_count
from .triangle_kernels import centroids_and_extents

_SHORTLIST = 16                    # first shortlist size (samples per query point)
_MAX_GATHER = 1 << 20              # query points x shortlist size evaluated in one batch
_MAX_SUBDIVISION = 64              # at most 64^2 cover samples per triangle


def _divide(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """``num / den`` clipped to [0, 1], 0 where ``den`` is 0 (degenerate triangles)."""
    safe = np.where(den == 0, 1.0, den)
    return np.clip(np.where(den == 0, 0.0, num / safe), 0.0, 1.0)


def closest_barycentric(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Barycentric coordinates of the point of triangle ``abc`` closest to ``p``.

    Args:
        p, a, b, c: ``[..., 3]`` float64, broadcast together.

    Returns:
        ``[..., 3]`` float64 ``(wa, wb, wc)``, non-negative, summing to 1; the closest point is
        ``wa*a + wb*b + wc*c``. Degenerate triangles (segments, points) give a closest point
        on their extent.

    The point is classified by the sign of dot products into one of seven Voronoi regions
    (3 vertices, 3 edges, the face); the first matching region in Ericson's order wins.
    """
    ab, ac = b - a, c - a
    ap, bp, cp = p - a, p - b, p - c
    d1, d2 = (ab * ap).sum(-1), (ac * ap).sum(-1)
    d3, d4 = (ab * bp).sum(-1), (ac * bp).sum(-1)
    d5, d6 = (ab * cp).sum(-1), (ac * cp).sum(-1)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2

    denom = va + vb + vc
    face_v, face_w = _divide(vb, denom), _divide(vc, denom)
    t_ab = _divide(d1, d1 - d3)
    t_ac = _divide(d2, d2 - d6)
    t_bc = _divide(d4 - d3, (d4 - d3) + (d5 - d6))
    zero, one = np.zeros_like(d1), np.ones_like(d1)

    # (condition, (wa, wb, wc)) in Ericson's order; applied in reverse so that the first wins.
    regions = [
        (np.ones_like(d1, dtype=bool), (1 - face_v - face_w, face_v, face_w)),
        ((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0), (zero, 1 - t_bc, t_bc)),
        ((vb <= 0) & (d2 >= 0) & (d6 <= 0), (1 - t_ac, zero, t_ac)),
        ((d6 >= 0) & (d5 <= d6), (zero, zero, one)),
        ((vc <= 0) & (d1 >= 0) & (d3 <= 0), (1 - t_ab, t_ab, zero)),
        ((d3 >= 0) & (d4 <= d3), (zero, one, zero)),
        ((d1 <= 0) & (d2 <= 0), (one, zero, zero)),
    ]
    wa, wb, wc = zero, zero, zero
    for condition, (ra, rb, rc) in regions:
        wa, wb, wc = np.where(condition, ra, wa), np.where(condition, rb, wb), np.where(condition, rc, wc)
    return np.stack([wa, wb, wc], axis=-1)


@njit(cache=CACHE, inline="always")
def _clip_divide(num: float, den: float) -> float:
    if den == 0.0:
        return 0.0
    return min(max(num / den, 0.0), 1.0)


@njit(cache=CACHE, inline="always")
def _dot(x0, x1, x2, y0, y1, y2):
    return x0 * y0 + x1 * y1 + x2 * y2


@njit(cache=CACHE)
def _closest_barycentric_one(p, tri):
    """Scalar ``closest_barycentric`` of one point ``p [3]`` and one triangle ``tri [3, 3]``
    (rows a, b, c): returns ``(wa, wb, wc)``; the same regions in the same order."""
    ab0, ab1, ab2 = tri[1, 0] - tri[0, 0], tri[1, 1] - tri[0, 1], tri[1, 2] - tri[0, 2]
    ac0, ac1, ac2 = tri[2, 0] - tri[0, 0], tri[2, 1] - tri[0, 1], tri[2, 2] - tri[0, 2]
    ap0, ap1, ap2 = p[0] - tri[0, 0], p[1] - tri[0, 1], p[2] - tri[0, 2]
    d1, d2 = _dot(ab0, ab1, ab2, ap0, ap1, ap2), _dot(ac0, ac1, ac2, ap0, ap1, ap2)
    if d1 <= 0 and d2 <= 0:
        return 1.0, 0.0, 0.0
    bp0, bp1, bp2 = p[0] - tri[1, 0], p[1] - tri[1, 1], p[2] - tri[1, 2]
    d3, d4 = _dot(ab0, ab1, ab2, bp0, bp1, bp2), _dot(ac0, ac1, ac2, bp0, bp1, bp2)
    if d3 >= 0 and d4 <= d3:
        return 0.0, 1.0, 0.0
    vc = d1 * d4 - d3 * d2
    if vc <= 0 and d1 >= 0 and d3 <= 0:
        t = _clip_divide(d1, d1 - d3)
        return 1.0 - t, t, 0.0
    cp0, cp1, cp2 = p[0] - tri[2, 0], p[1] - tri[2, 1], p[2] - tri[2, 2]
    d5, d6 = _dot(ab0, ab1, ab2, cp0, cp1, cp2), _dot(ac0, ac1, ac2, cp0, cp1, cp2)
    if d6 >= 0 and d5 <= d6:
        return 0.0, 0.0, 1.0
    vb = d5 * d2 - d1 * d6
    if vb <= 0 and d2 >= 0 and d6 <= 0:
        t = _clip_divide(d2, d2 - d6)
        return 1.0 - t, 0.0, t
    va = d3 * d6 - d5 * d4
    if va <= 0 and d4 - d3 >= 0 and d5 - d6 >= 0:
        t = _clip_divide(d4 - d3, (d4 - d3) + (d5 - d6))
        return 0.0, 1.0 - t, t
    denom = va + vb + vc
    v, w = _clip_divide(vb, denom), _clip_divide(vc, denom)
    return 1.0 - v - w, v, w


@njit(cache=CACHE, parallel=True)
def _best_candidates(points, candidates, corners, t_label, labels):
    """For each point, the closest of its candidate triangles.

    Args:
        points: ``[P, 3]`` float64; candidates: ``[P, k]`` int64 triangle indices;
        corners: ``[T, 3, 3]`` float64; t_label: ``[T]`` int64; labels: ``[P]`` int64, or an
        empty array to accept every candidate.

    Returns:
        ``(column [P] int64, bary [P, 3] float64, distance [P] float64)``: the winning column of
        ``candidates`` (-1 and distance inf where no candidate has the point's label).
    """
    n, k = candidates.shape
    column = np.full(n, -1, dtype=np.int64)
    bary = np.zeros((n, 3))
    distance = np.full(n, np.inf)
    restrict = labels.shape[0] > 0
    for i in prange(n):
        p = points[i]
        for j in range(k):
            t = candidates[i, j]
            if restrict and t_label[t] != labels[i]:
                continue
            tri = corners[t]
            wa, wb, wc = _closest_barycentric_one(p, tri)
            q0 = wa * tri[0, 0] + wb * tri[1, 0] + wc * tri[2, 0] - p[0]
            q1 = wa * tri[0, 1] + wb * tri[1, 1] + wc * tri[2, 1] - p[1]
            q2 = wa * tri[0, 2] + wb * tri[1, 2] + wc * tri[2, 2] - p[2]
            d = np.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
            if d < distance[i]:
                distance[i] = d
                column[i] = j
                bary[i, 0], bary[i, 1], bary[i, 2] = wa, wb, wc
    return column, bary, distance


def _cover_samples(corners: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Points that come within a radius ``r`` of every point of every triangle.

    Triangle ``t`` with circumradius-about-centroid ``R_t`` is cut into ``n_t^2`` similar
    sub-triangles, ``n_t = ceil(R_t / r)``; their centroids are its samples, each within
    ``R_t / n_t <= r`` of every point of its sub-triangle. ``r`` is the 90th percentile of
    ``R_t`` (at least ``max R_t / 64``), so most triangles carry one sample.

    Args:
        corners: ``[T, 3, 3]`` float64 triangle corners.

    Returns:
        ``(samples [S, 3] float64, sample_triangle [S] int64, r)``.
    """
    centroid, extent = centroids_and_extents(corners)
    radius = max(float(np.percentile(extent, 90)), float(extent.max()) / _MAX_SUBDIVISION, 1e-300)
    splits = np.clip(np.ceil(extent / radius), 1, _MAX_SUBDIVISION).astype(np.int64)
    samples, owners = [], []
    for n in np.nonzero(np.bincount(splits))[0]:   # the split counts present (1 .. _MAX_SUBDIVISION; no sort)
        tris = np.nonzero(splits == n)[0]
        if n == 1:   # most triangles: the one sample is the centroid
            samples.append(centroid[tris])
            owners.append(tris)
            continue
        i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        up = (i + j <= n - 1)
        down = (i + j <= n - 2)
        uv = np.concatenate([
            np.stack([i[up] + 1 / 3, j[up] + 1 / 3], axis=-1),
            np.stack([i[down] + 2 / 3, j[down] + 2 / 3], axis=-1),
        ]) / n                                                     # [n^2, 2] along ab, ac
        a, ab, ac = corners[tris, 0], corners[tris, 1] - corners[tris, 0], corners[tris, 2] - corners[tris, 0]
        points = a[:, None] + uv[None, :, :1] * ab[:, None] + uv[None, :, 1:] * ac[:, None]
        samples.append(points.reshape(-1, 3))
        owners.append(np.repeat(tris, len(uv)))
    return np.concatenate(samples), np.concatenate(owners), radius


@dataclass
class ClosestPoints:
    """Closest points of N query points.

    Attributes:
        triangle: ``[N]`` int64 index of the triangle holding the closest point.
        barycentric: ``[N, 3]`` float64 weights of that triangle's corners.
        point: ``[N, 3]`` float64 closest point.
        distance: ``[N]`` float64 distance from the query point.
    """

    triangle: np.ndarray
    barycentric: np.ndarray
    point: np.ndarray
    distance: np.ndarray


PARALLEL_QUERY = 100_000
"""Neighbours a k-d tree query looks up at least before it runs on every core: SciPy starts its
threads for each query, which costs more than a small query itself."""


def _query_workers(lookups: int) -> int:
    """Threads a k-d tree query of ``lookups`` neighbours runs on (``PARALLEL_QUERY``)."""
    return thread_count() if lookups >= PARALLEL_QUERY else 1


class SurfaceQuery:
    """Closest-point queries against a fixed triangle mesh, optionally restricted by label.

    Args:
        v_pos: ``[V, 3]`` float positions.
        t_pos_idx: ``[T, 3]`` integer triangle indices.
        t_label: optional ``[T]`` int64 label per triangle (e.g. UV chart); queries may then
            ask for the closest point among triangles of one label.

    Correctness: with shortlist size k, every sample outside the shortlist lies at least
    ``d_k`` (the k-th sample distance) away, so every triangle not examined lies at least
    ``d_k - r`` away (``r`` the cover radius). A point whose best exact distance ``d`` is at
    most that bound is final. The others are retried with a shortlist that holds every sample
    within ``d + r`` (counted with a ball query), or four times the last one where no candidate
    had the point's label yet, up to all samples. The answer is therefore the exact closest
    point, whatever the mesh.
    """

    def __init__(self, v_pos: np.ndarray, t_pos_idx: np.ndarray, t_label: np.ndarray | None = None):
        self.corners = np.asarray(v_pos, dtype=np.float64)[np.asarray(t_pos_idx, dtype=np.int64)]
        if len(self.corners) == 0:
            raise ValueError("SurfaceQuery needs at least one triangle")
        samples, self.sample_triangle, self.cover_radius = _cover_samples(self.corners)
        self.tree = cKDTree(samples, balanced_tree=False, compact_nodes=False)   # builds faster, queries as fast
        self.t_label = None if t_label is None else np.asarray(t_label, dtype=np.int64)

    def closest(self, points: np.ndarray, labels: np.ndarray | None = None, beyond: float = np.inf) -> ClosestPoints:
        """Closest points on the mesh to ``points [N, 3]``.

        Args:
            points: ``[N, 3]`` float query points.
            labels: optional ``[N]`` int64: point ``i`` only considers triangles with
                ``t_label == labels[i]`` (needs ``t_label``; every label asked for must exist).
            beyond: a point whose shortlist already shows every other triangle at least this far
                away is not searched further: its answer is the best of its shortlist, at least
                ``beyond`` away and no nearer than the exact one (a point far from the mesh
                would otherwise widen its shortlist to most of the mesh). Default: exact.

        Returns:
            ``ClosestPoints`` of the N points.
        """
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        if labels is not None:
            if self.t_label is None:
                raise ValueError("labels given but the SurfaceQuery has no t_label")
            labels = np.asarray(labels, dtype=np.int64)
        n = len(points)
        triangle = np.zeros(n, dtype=np.int64)
        bary = np.zeros((n, 3))
        dist = np.full(n, np.inf)
        shortlist = np.full(n, _SHORTLIST, dtype=np.int64)
        pending = np.arange(n)
        while pending.size:
            unresolved = []
            for k in np.unique(shortlist[pending]):
                k_used = min(int(k), self.tree.n)
                rows_k = pending[shortlist[pending] == k]
                chunk = max(1, _MAX_GATHER // k_used)
                for start in range(0, len(rows_k), chunk):
                    rows = rows_k[start:start + chunk]
                    best_t, best_b, best_d, bound = self._shortlist(
                        points[rows], None if labels is None else labels[rows], k_used)
                    triangle[rows], bary[rows], dist[rows] = best_t, best_b, best_d
                    if k_used < self.tree.n:
                        unresolved.append(rows[(best_d > bound) & (bound < beyond)])
            pending = np.concatenate(unresolved) if unresolved else np.zeros(0, dtype=np.int64)
            shortlist[pending] = self._next_shortlist(points[pending], dist[pending], shortlist[pending])
        point = (bary[:, :, None] * self.corners[triangle]).sum(axis=1)
        return ClosestPoints(triangle, bary, point, dist)

    def _next_shortlist(self, points: np.ndarray, best: np.ndarray, last: np.ndarray) -> np.ndarray:
        """Shortlist sizes ``[P]`` (powers of two) that hold every sample within ``best + r`` of
        each point, at least twice ``last``; four times ``last`` where ``best`` is infinite."""
        size = 4 * last
        found = np.isfinite(best)
        if found.any():
            inside = self.tree.query_ball_point(points[found], best[found] + self.cover_radius,
                                                  return_length=True, workers=_query_workers(int(found.sum())))
            needed = 2 ** np.ceil(np.log2(np.asarray(inside, dtype=np.float64) + 1)).astype(np.int64)
            size[found] = np.maximum(needed, 2 * last[found])
        return size

    def _shortlist(self, points: np.ndarray, labels: np.ndarray | None, k: int):
        """Best exact candidate among the k nearest samples of each point ``[P, 3]``;
        returns ``(triangle [P], bary [P, 3], distance [P], bound [P])``."""
        sample_dist, sample = self.tree.query(points, k=k, workers=_query_workers(len(points) * k))
        sample_dist, sample = sample_dist.reshape(len(points), k), sample.reshape(len(points), k)
        candidates = self.sample_triangle[sample]                                  # [P, k]
        no_labels = np.zeros(0, dtype=np.int64)
        column, bary, distance = _best_candidates(
            points, candidates, self.corners,
            no_labels if self.t_label is None else self.t_label, no_labels if labels is None else labels)
        triangle = candidates[np.arange(len(points)), np.maximum(column, 0)]
        return triangle, bary, distance, sample_dist[:, -1] - self.cover_radius
