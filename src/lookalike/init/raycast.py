"""Nearest ray-triangle intersections against a fixed mesh, fast (Embree, through ``embreex``).

A ray is ``o + t d`` for ``0 <= t <= t_max``; its hit is the intersection with the smallest
``t`` over all triangles (front and back faces alike), given as the triangle, the barycentric
weights ``(1 - u - v, u, v)`` of its corners (so the point is ``w0 p0 + w1 p1 + w2 p2``) and
``t``. ``RayCaster`` traces with Embree's BVH; ``intersect_python`` is its slow, plain NumPy
twin (Moeller-Trumbore against every triangle), kept to test it against.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from ..threads import thread_count

THREAD_BLOCK = 1 << 16              # fewest rays worth a thread of their own
_REFERENCE_CHUNK = 1 << 22          # rays x triangles tested at once by the NumPy twin


@dataclass
class RayHits:
    """Nearest hits of N rays.

    Attributes:
        triangle: ``[N]`` int64 hit triangle, -1 where the ray hits nothing within ``t_max``.
        barycentric: ``[N, 3]`` float64 corner weights of the hit point (zeros on a miss).
        t: ``[N]`` float64 ray parameter of the hit (``inf`` on a miss).
    """

    triangle: np.ndarray
    barycentric: np.ndarray
    t: np.ndarray

    @property
    def hit(self) -> np.ndarray:
        """``[N]`` bool: the ray hit a triangle."""
        return self.triangle >= 0


def _hits(triangle: np.ndarray, u: np.ndarray, v: np.ndarray, t: np.ndarray) -> RayHits:
    """``RayHits`` from per-ray triangle (-1 = miss), Embree-style ``u, v`` and ``t``."""
    hit = triangle >= 0
    u, v = np.where(hit, u, 0.0), np.where(hit, v, 0.0)
    bary = np.stack([np.where(hit, 1.0 - u - v, 0.0), u, v], axis=-1)
    return RayHits(triangle.astype(np.int64), bary, np.where(hit, t, np.inf))


class RayCaster:
    """Nearest-hit queries against the triangles ``v_pos [V, 3]``, ``t_pos_idx [T, 3]``.

    Embree builds its BVH over the float32 triangle corners once (committed by a first query
    here, before any threads share the scene); ``intersect`` then traces any number of rays,
    in blocks of at least ``THREAD_BLOCK`` rays on up to ``lookalike.threads.thread_count()``
    threads (Embree
    releases the GIL while it traces). Coordinates are float32 inside Embree (relative error
    ~1e-7 of the mesh's size).
    """

    def __init__(self, v_pos: np.ndarray, t_pos_idx: np.ndarray):
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh

        corners = np.asarray(v_pos, dtype=np.float32)[np.asarray(t_pos_idx, dtype=np.int64)]
        if len(corners) == 0:
            raise ValueError("RayCaster needs at least one triangle")
        self._scene = rtcore_scene.EmbreeScene()
        self._mesh = TriangleMesh(self._scene, np.ascontiguousarray(corners))  # kept alive with the scene
        self._trace(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32), np.zeros(1, np.float32))

    def intersect(self, origins: np.ndarray, directions: np.ndarray, t_max: np.ndarray) -> RayHits:
        """Nearest hits of rays ``origins [N, 3] + t directions [N, 3]``, ``0 <= t <= t_max [N]``
        (directions need not be unit; ``t`` is in units of their length)."""
        origins = np.ascontiguousarray(origins, dtype=np.float32).reshape(-1, 3)
        directions = np.ascontiguousarray(directions, dtype=np.float32).reshape(-1, 3)
        t_max = np.ascontiguousarray(np.broadcast_to(t_max, (len(origins),)), dtype=np.float32)
        blocks = max(1, min(thread_count(), len(origins) // THREAD_BLOCK))
        parts = [np.array_split(a, blocks) for a in (origins, directions, t_max)]
        with ThreadPoolExecutor(max_workers=blocks) as pool:
            traced = list(pool.map(self._trace, *parts))
        return _hits(*(np.concatenate([part[k] for part in traced]) for k in range(4)))

    def _trace(self, origins: np.ndarray, directions: np.ndarray, t_max: np.ndarray):
        """Embree on one block of rays (float32, contiguous): ``(triangle [n] (-1 = miss), u [n],
        v [n], t [n])``."""
        out = self._scene.run(np.ascontiguousarray(origins), np.ascontiguousarray(directions),
                              dists=t_max.copy(), output=1)
        triangle = np.where(out["geomID"] >= 0, out["primID"], -1)
        return triangle, out["u"].astype(np.float64), out["v"].astype(np.float64), out["tfar"].astype(np.float64)


def intersect_python(v_pos: np.ndarray, t_pos_idx: np.ndarray, origins: np.ndarray, directions: np.ndarray,
                     t_max: np.ndarray) -> RayHits:
    """``RayCaster(v_pos, t_pos_idx).intersect(origins, directions, t_max)`` by brute force in
    float64: Moeller-Trumbore for every ray against every triangle, ``u, v >= 0``,
    ``u + v <= 1``, ``0 <= t <= t_max``; the smallest ``t`` wins (the lowest triangle index on
    equal ``t``). Slow (``O(N T)``); for tests."""
    corners = np.asarray(v_pos, dtype=np.float64)[np.asarray(t_pos_idx, dtype=np.int64)]
    origins = np.asarray(origins, dtype=np.float64).reshape(-1, 3)
    directions = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    t_max = np.broadcast_to(np.asarray(t_max, dtype=np.float64), (len(origins),))
    p0, e1, e2 = corners[:, 0], corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    triangle = np.full(len(origins), -1, np.int64)
    best_t, best_u, best_v = np.full(len(origins), np.inf), np.zeros(len(origins)), np.zeros(len(origins))
    step = max(1, _REFERENCE_CHUNK // len(corners))
    for start in range(0, len(origins), step):
        rows = slice(start, start + step)
        d, o = directions[rows, None], origins[rows, None]            # [n, 1, 3]
        pvec = np.cross(d, e2[None])                                    # [n, T, 3]
        det = (e1[None] * pvec).sum(-1)
        safe = np.where(det == 0, 1.0, det)
        s = o - p0[None]
        u = (s * pvec).sum(-1) / safe
        qvec = np.cross(s, e1[None])
        v = (d * qvec).sum(-1) / safe
        t = (e2[None] * qvec).sum(-1) / safe
        ok = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0) & (t <= t_max[rows, None])
        t = np.where(ok, t, np.inf)
        first = t.argmin(axis=1)
        n = np.arange(len(first))
        found = np.isfinite(t[n, first])
        triangle[rows] = np.where(found, first, -1)
        best_t[rows], best_u[rows], best_v[rows] = t[n, first], u[n, first], v[n, first]
    return _hits(triangle, best_u, best_v, best_t)
