"""How far a low-poly mesh strays from its input: a sampled two-sided surface distance.

Points are drawn uniformly over the area of each mesh (``conform.area_samples``, seeded) and
each is given its distance to the other mesh's closest point (``closest_point.SurfaceQuery``,
exact up to ``BEYOND``). Distances are in units of the input's bounding radius ``r`` (the largest distance of a
vertex from its bounding box's centre, as ``Mesh.bounding_sphere``). Each direction gives:

- ``mean``: the mean distance, the usual one-sided mean surface error;
- ``p99``: its 99th percentile;
- ``far_area``: the share of the area farther than ``FAR`` = 3 % of ``r`` (each sample stands
  for an equal share of the area): shards of the low mesh off the input (``low_to_input``), or
  parts of the input the low mesh lost (``input_to_low``).

Points certainly farther than ``BEYOND`` are given an upper bound on their distance rather than
the exact one, which would search most of the other mesh for each (a lost part's points).
``combined`` takes the larger of each over the two directions. A one-sided measure misses half
of what goes wrong: a dropped part is no distance from the low mesh to the input, and a shard is
no distance from the input to the low mesh.

``triangle_distances`` is the guard's measure: per low-poly triangle, the largest distance of
seven points (corners, edge midpoints, centroid) from the input.

Cost: building the query over the input (its k-d tree over at least one sample per triangle)
dominates: ``O(T log T)`` for an input of ``T`` triangles, once per input (``SurfaceGauge``
holds it for every candidate measured against it); each measurement is then ``O(N log T)``
for ``N = SAMPLES`` points each way, plus a query over the low mesh (``O(n log n)`` for ``n``
triangles). ``docs/benchmarks.md`` and ``lookalike bench decimate`` give the seconds.
``surface_distance_python`` is the brute-force twin (every point against every triangle),
the tests' oracle.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from .closest_point import SurfaceQuery, closest_barycentric
from .conform import area_samples

FAR = 0.03
"""A point farther than this share of the input's bounding radius from the other surface is far."""
BEYOND = 2 * FAR
"""Points certainly farther than this share of the radius are not searched for their exact
closest point (``SurfaceQuery.closest``'s ``beyond``): their distance is the best their first
candidates give, an upper bound within a triangle's size of the exact one. Far area is exact;
the mean and the 99th percentile are exact up to this distance."""
SAMPLES = 20_000
"""Points drawn on each surface: a far area of 0.5 % is then 100 points, +-10 %."""
_LOW_STREAM, _INPUT_STREAM = 1, 0       # random streams of the two meshes' samples under one seed


@dataclass(frozen=True)
class OneWay:
    """Distances of points sampled on one surface from the other, in bounding radii.

    Attributes:
        mean: mean distance. p99: 99th percentile. far_area: share of the area farther than
            ``FAR``.
    """

    mean: float
    p99: float
    far_area: float

    @staticmethod
    def of(distance: np.ndarray, radius: float) -> "OneWay":
        """The figures of ``distance [N]`` (absolute units) for an input of bounding radius ``radius``."""
        d = np.asarray(distance, np.float64) / max(radius, 1e-300)
        if len(d) == 0:
            return OneWay(0.0, 0.0, 0.0)
        return OneWay(float(d.mean()), float(np.percentile(d, 99)), float((d > FAR).mean()))


@dataclass(frozen=True)
class SurfaceDistance:
    """The two-sided distance between a low-poly mesh and its input (module docstring).

    Attributes:
        low_to_input: points on the low mesh against the input (shards, folds).
        input_to_low: points on the input against the low mesh (lost parts, shrunk rims).
    """

    low_to_input: OneWay
    input_to_low: OneWay

    @property
    def combined(self) -> OneWay:
        """The larger of each figure over the two directions."""
        a, b = self.low_to_input, self.input_to_low
        return OneWay(max(a.mean, b.mean), max(a.p99, b.p99), max(a.far_area, b.far_area))

    def as_dict(self) -> dict:
        """``{"mean", "p99", "far_area"}`` (combined), each direction's under its name, and
        ``"far"`` (``FAR``), as ``metrics.json`` holds them."""
        return {**asdict(self.combined), "low_to_input": asdict(self.low_to_input),
                "input_to_low": asdict(self.input_to_low), "far": FAR}


def bounding_radius(v_pos: np.ndarray, t_pos_idx: np.ndarray) -> float:
    """Largest distance of a referenced vertex of ``v_pos [V, 3]`` from the centre of their
    bounding box (``Mesh.bounding_sphere``'s radius)."""
    used = np.asarray(v_pos, np.float64)[np.unique(np.asarray(t_pos_idx).reshape(-1))]
    if len(used) == 0:
        return 0.0
    centre = 0.5 * (used.min(axis=0) + used.max(axis=0))
    return float(np.linalg.norm(used - centre, axis=1).max())


def _points(v_pos: np.ndarray, t_pos_idx: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """``count`` points ``[N, 3]`` uniform over the area of the mesh (none where it has no area)."""
    v_pos = np.asarray(v_pos, np.float64)
    if len(t_pos_idx) == 0 or count == 0:
        return np.zeros((0, 3))
    corners = v_pos[t_pos_idx]
    if not np.any(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])):
        return np.zeros((0, 3))
    triangle, barycentric = area_samples(v_pos, t_pos_idx, count, rng)
    return np.einsum("nk,nkd->nd", barycentric, corners[triangle])


def guard_points(v_pos: np.ndarray, t_pos_idx: np.ndarray) -> np.ndarray:
    """``[T, 7, 3]`` float64: each triangle's corners, edge midpoints and centroid."""
    corners = np.asarray(v_pos, np.float64)[np.asarray(t_pos_idx, np.int64)]
    midpoints = 0.5 * (corners + corners[:, [1, 2, 0]])
    return np.concatenate([corners, midpoints, corners.mean(axis=1, keepdims=True)], axis=1)


class SurfaceGauge:
    """Measures low-poly meshes against one input: its closest-point query and its samples,
    built once (module docstring).

    Args:
        v_pos: ``[V, 3]`` float input positions; t_pos_idx: ``[T, 3]`` int triangles.
        samples: points drawn on each surface.
        seed: the samples' seed; every measurement draws its low-mesh points from the same
            stream, so candidates are compared on equal terms and results repeat.
        radius: the unit of distance (default: the input's bounding radius).
        beyond: in bounding radii, where distances become upper bounds (``BEYOND``; ``inf``:
            exact everywhere).
    """

    def __init__(self, v_pos: np.ndarray, t_pos_idx: np.ndarray, samples: int = SAMPLES, seed: int = 0,
                 radius: float | None = None, beyond: float = BEYOND):
        v_pos, t_pos_idx = np.asarray(v_pos, np.float64), np.asarray(t_pos_idx, np.int64)
        self.radius = bounding_radius(v_pos, t_pos_idx) if radius is None else float(radius)
        self.samples, self.seed, self.beyond = samples, seed, beyond * self.radius
        self.query = SurfaceQuery(v_pos, t_pos_idx)
        self.input_points = _points(v_pos, t_pos_idx, samples, np.random.default_rng((seed, _INPUT_STREAM)))

    def measure(self, v_pos: np.ndarray, t_pos_idx: np.ndarray, samples: int | None = None) -> SurfaceDistance:
        """The two-sided distance of the low mesh ``v_pos [V, 3]`` / ``t_pos_idx [T, 3]``, on
        ``samples`` points each way (default all: the first of the input's, as many drawn on
        the low mesh; fewer cost less and estimate the same figures more coarsely)."""
        v_pos, t_pos_idx = np.asarray(v_pos, np.float64), np.asarray(t_pos_idx, np.int64)
        samples = self.samples if samples is None else min(samples, self.samples)
        input_points = self.input_points[:samples]
        low_points = _points(v_pos, t_pos_idx, samples, np.random.default_rng((self.seed, _LOW_STREAM)))
        there = self.query.closest(low_points, beyond=self.beyond).distance if len(low_points) else np.zeros(0)
        if len(t_pos_idx):
            back = SurfaceQuery(v_pos, t_pos_idx).closest(input_points, beyond=self.beyond).distance
        else:
            back = np.full(len(input_points), np.inf)
        return SurfaceDistance(OneWay.of(there, self.radius), OneWay.of(back, self.radius))

    def triangle_distances(self, v_pos: np.ndarray, t_pos_idx: np.ndarray, beyond: float = np.inf) -> np.ndarray:
        """``[T]`` float64: for each triangle of the low mesh, the largest distance (absolute
        units) of its corners, edge midpoints and centroid (``guard_points``) from the input;
        exact up to ``beyond`` (absolute units), at least ``beyond`` past it."""
        points = guard_points(v_pos, t_pos_idx)
        if len(points) == 0:
            return np.zeros(0)
        return self.query.closest(points.reshape(-1, 3), beyond=beyond).distance.reshape(-1, 7).max(axis=1)

    def vertex_closest(self, v_pos: np.ndarray):
        """``ClosestPoints`` of the vertices ``v_pos [V, 3]`` on the input."""
        return self.query.closest(np.asarray(v_pos, np.float64))


def surface_distance(input_pos: np.ndarray, input_idx: np.ndarray, low_pos: np.ndarray, low_idx: np.ndarray,
                     samples: int = SAMPLES, seed: int = 0, radius: float | None = None,
                     beyond: float = BEYOND) -> SurfaceDistance:
    """The two-sided distance of a low mesh ``low_pos [V', 3]`` / ``low_idx [T', 3]`` from its
    input ``input_pos [V, 3]`` / ``input_idx [T, 3]`` (module docstring); ``SurfaceGauge`` when
    several low meshes are measured against one input."""
    return SurfaceGauge(input_pos, input_idx, samples, seed, radius, beyond).measure(low_pos, low_idx)


def _closest_distance_python(points: np.ndarray, v_pos: np.ndarray, t_pos_idx: np.ndarray) -> np.ndarray:
    """``[N]`` distance from each of ``points [N, 3]`` to the nearest of all the triangles, by
    trying every triangle (``closest_barycentric``)."""
    corners = np.asarray(v_pos, np.float64)[np.asarray(t_pos_idx, np.int64)]
    if len(corners) == 0:
        return np.full(len(points), np.inf)
    best = np.full(len(points), np.inf)
    for start in range(0, len(points), 256):
        p = points[start:start + 256, None]
        w = closest_barycentric(p, corners[None, :, 0], corners[None, :, 1], corners[None, :, 2])
        d = np.linalg.norm((w[..., None] * corners[None]).sum(axis=2) - p, axis=-1)
        best[start:start + 256] = d.min(axis=1)
    return best


def surface_distance_python(input_pos: np.ndarray, input_idx: np.ndarray, low_pos: np.ndarray, low_idx: np.ndarray,
                            samples: int = SAMPLES, seed: int = 0, radius: float | None = None) -> SurfaceDistance:
    """Twin of :func:`surface_distance` with brute-force closest points (``O(N T)``): the same
    samples, every point against every triangle, every distance exact (``beyond`` infinite)."""
    input_pos, low_pos = np.asarray(input_pos, np.float64), np.asarray(low_pos, np.float64)
    radius = bounding_radius(input_pos, input_idx) if radius is None else float(radius)
    input_points = _points(input_pos, input_idx, samples, np.random.default_rng((seed, _INPUT_STREAM)))
    low_points = _points(low_pos, low_idx, samples, np.random.default_rng((seed, _LOW_STREAM)))
    return SurfaceDistance(OneWay.of(_closest_distance_python(low_points, input_pos, input_idx), radius),
                           OneWay.of(_closest_distance_python(input_points, low_pos, low_idx), radius))
