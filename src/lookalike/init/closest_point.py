"""Exact closest points on a triangle mesh, fast.

``closest_barycentric`` is the vectorised point-triangle closest point (Voronoi-region
classification, Ericson, *Real-Time Collision Detection*, Sec. 5.1.5).
``SurfaceQuery`` finds, for many points at once, the closest point on a whole mesh: a k-d tree
over samples that cover every triangle shortlists candidates, the exact test picks the best,
and a bound certifies the answer (or widens the shortlist for the few points it cannot).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

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
    centroid = corners.mean(axis=1)
    extent = np.linalg.norm(corners - centroid[:, None], axis=-1).max(axis=1)
    radius = max(float(np.percentile(extent, 90)), float(extent.max()) / _MAX_SUBDIVISION, 1e-300)
    splits = np.clip(np.ceil(extent / radius), 1, _MAX_SUBDIVISION).astype(np.int64)
    samples, owners = [], []
    for n in np.unique(splits):
        tris = np.nonzero(splits == n)[0]
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


class SurfaceQuery:
    """Closest-point queries against a fixed triangle mesh, optionally restricted by label.

    Args:
        v_pos: ``[V, 3]`` float positions.
        t_pos_idx: ``[T, 3]`` integer triangle indices.
        t_label: optional ``[T]`` int64 label per triangle (e.g. UV chart); queries may then
            ask for the closest point among triangles of one label.

    Correctness: with shortlist size k, every sample outside the shortlist lies at least
    ``d_k`` (the k-th sample distance) away, so every triangle not examined lies at least
    ``d_k - r`` away (``r`` the cover radius). A point whose best exact distance is at most
    that bound is final; the others are retried with a shortlist four times larger, up to all
    samples. The answer is therefore the exact closest point, whatever the mesh.
    """

    def __init__(self, v_pos: np.ndarray, t_pos_idx: np.ndarray, t_label: np.ndarray | None = None):
        self.corners = np.asarray(v_pos, dtype=np.float64)[np.asarray(t_pos_idx, dtype=np.int64)]
        if len(self.corners) == 0:
            raise ValueError("SurfaceQuery needs at least one triangle")
        samples, self.sample_triangle, self.cover_radius = _cover_samples(self.corners)
        self.tree = cKDTree(samples)
        self.t_label = None if t_label is None else np.asarray(t_label, dtype=np.int64)

    def closest(self, points: np.ndarray, labels: np.ndarray | None = None) -> ClosestPoints:
        """Closest points on the mesh to ``points [N, 3]``.

        Args:
            points: ``[N, 3]`` float query points.
            labels: optional ``[N]`` int64: point ``i`` only considers triangles with
                ``t_label == labels[i]`` (needs ``t_label``; every label asked for must exist).

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
        pending = np.arange(n)
        k = _SHORTLIST
        while pending.size:
            k = min(k, self.tree.n)
            exhaustive = k == self.tree.n
            chunk = max(1, _MAX_GATHER // k)
            unresolved = []
            for start in range(0, len(pending), chunk):
                rows = pending[start:start + chunk]
                best_t, best_b, best_d, bound = self._shortlist(points[rows], None if labels is None else labels[rows], k)
                better = best_d < dist[rows]
                triangle[rows[better]], bary[rows[better]], dist[rows[better]] = best_t[better], best_b[better], best_d[better]
                if not exhaustive:
                    unresolved.append(rows[dist[rows] > bound])
            pending = np.concatenate(unresolved) if unresolved else np.zeros(0, dtype=np.int64)
            k *= 4
        point = (bary[:, :, None] * self.corners[triangle]).sum(axis=1)
        return ClosestPoints(triangle, bary, point, dist)

    def _shortlist(self, points: np.ndarray, labels: np.ndarray | None, k: int):
        """Best exact candidate among the k nearest samples of each point ``[P, 3]``;
        returns ``(triangle [P], bary [P, 3], distance [P], bound [P])``."""
        sample_dist, sample = self.tree.query(points, k=k)
        sample_dist, sample = sample_dist.reshape(len(points), k), sample.reshape(len(points), k)
        candidates = self.sample_triangle[sample]                                  # [P, k]
        corners = self.corners[candidates]                                         # [P, k, 3, 3]
        w = closest_barycentric(points[:, None], corners[:, :, 0], corners[:, :, 1], corners[:, :, 2])
        closest = (w[..., None] * corners).sum(axis=2)
        d = np.linalg.norm(closest - points[:, None], axis=-1)
        if labels is not None:
            d = np.where(self.t_label[candidates] == labels[:, None], d, np.inf)
        pick = d.argmin(axis=1)
        rows = np.arange(len(points))
        bound = sample_dist[:, -1] - self.cover_radius
        return candidates[rows, pick], w[rows, pick], d[rows, pick], bound
