"""Quadric-error decimation to a triangle budget, the paper's initial guess, chosen by how far
it strays from the input.

Positions are welded first (so that UV-seam duplicates do not open cracks), unless the input is
closed as indexed and the weld would open it (``welded_input``). Then each setting of
``CANDIDATES`` brings the mesh to the count: the maintained ``fast-simplification`` library
(edge collapses by quadric error, Garland and Heckbert 1997, in rounds under a growing
threshold, each vertex placed where its error is least) with and without frozen borders (with
its threshold growing faster, ``FASTER``, where it stops above the count), and meshoptimizer's
``meshopt_simplify`` (quadric collapses onto existing vertices, open borders collapsed only
along themselves). A field's fine marching cubes get ``FIELD_CANDIDATES``: our own edge
collapse in strict order of quadric error first (``lookalike.init.quadric_collapse``, each
vertex placed where its error is least, refusing only collapses that turn a face over or change
the topology). Each result is cleaned of degenerate triangles and zero-volume fins. Among those
that land on the count (within ``_NEARLY``), the one that strays least from the input is kept:
no shard (the guard, below) first, then the least far area, then the least mean of the sampled
two-sided surface distance (``lookalike.init.surface_distance``, ``CHOICE_SAMPLES`` points each
way). Which setting wins depends on the input: the strict order goes on where
fast-simplification stalls (the staircases of fine marching cubes) and places vertices on a
field's corners; frozen borders keep open sheets whole but stall on meshes that are mostly
border; fast-simplification's faster ``agg`` settings reach the count where the slower stop
above it, and leave shards on many small open parts; meshoptimizer reaches the count on those
whole, but keeps vertices where they were and so strays a little more on smooth scans
(``lookalike bench decimate``, ``docs/benchmarks.md``). The slowest settings (``FALLBACKS``)
are tried only where none of these reaches the count. UVs, materials, vertex colours and skin
weights are then carried over from the input (``transfer``), and normals split at creases
sharper than ``lookalike.asset.normals.DEFAULT_CREASE_ANGLE`` (normal slots only: the values
follow the positions).

The guard. No triangle of the result may lie farther from the input than ``GUARD`` times the
count's feature size ``s = sqrt(4 A / (sqrt(3) n))``, the edge of an equilateral triangle of the
mean area when ``n`` triangles cover the input's area ``A``: a triangle whose corners lie on the
surface is nowhere farther from it than its circumradius (``s / sqrt(3)`` for that triangle),
and decimations without shards stay within half of ``s`` on every benchmark asset, where shards
reach ``1.3 s`` (``docs/benchmarks.md``). A triangle's distance is the largest of its corners', edge midpoints' and
centroid's (``SurfaceGauge.triangle_distances``). A setting that leaves a shard is not chosen
while another does not; where all do, the chosen result is repaired (``repair_shards``): the
corners of its shards are moved to their closest points on the input, and triangles that still
lie beyond the bound (spanning empty space) are removed.

Landing on the exact count takes several runs of a setting, each over the whole input; on a
large input (over ``COARSE_ABOVE`` triangles) one run first brings it to ``COARSE_TRIANGLES``
(``coarse_setting``), and every setting runs, and is measured, from there, so that the whole
input is decimated once; ``decimate_reported`` then measures the result against the whole input
once more.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import fast_simplification
import meshoptimizer
import numpy as np
import torch

from ..asset.edges import edge_index
from ..asset.index_tables import triple_copies
from ..asset.mesh import Mesh
from ..asset.parts import triangle_parts
from ..asset.normals import DEFAULT_CREASE_ANGLE, crease_normal_index
from ..errors import ConfigError
from .quadric_collapse import quadric_collapse
from .surface_distance import SurfaceDistance, SurfaceGauge
from .transfer import transfer_attributes
from .triangle_kernels import triangle_areas, triangle_areas_python
from .weld import weld_tolerance, weld_vertices

FAST_SIMPLIFICATION = "fast-simplification"
MESHOPTIMIZER = "meshoptimizer"
QUADRIC_COLLAPSE = "quadric collapse"


@dataclass(frozen=True)
class Setting:
    """One way to simplify: ``simplifier`` (``QUADRIC_COLLAPSE``, ``FAST_SIMPLIFICATION`` or
    ``MESHOPTIMIZER``), whether border vertices are frozen (fast-simplification's
    ``preserve_border``, meshoptimizer's ``SIMPLIFY_LOCK_BORDER``; the quadric collapse weights
    its borders instead), and fast-simplification's ``agg`` (how fast its error threshold grows:
    low values keep the shape better but may stop above the count)."""

    simplifier: str
    preserve_border: bool = False
    agg: float = 0.0

    @property
    def label(self) -> str:
        """E.g. ``"fast-simplification (borders frozen, agg 3)"``, ``"meshoptimizer"``."""
        options = (["borders frozen"] if self.preserve_border else []) + \
            ([f"agg {self.agg:g}"] if self.simplifier == FAST_SIMPLIFICATION else [])
        return self.simplifier + (f" ({', '.join(options)})" if options else "")

    def run(self, unit: np.ndarray, t_pos_idx: np.ndarray, request: int) -> tuple[int, np.ndarray, np.ndarray]:
        """Simplify ``unit [V, 3]`` (unit bounding-box diagonal) / ``t_pos_idx [T, 3]`` towards
        ``request`` triangles: ``(triangles returned, v_pos [V', 3], t_pos_idx [T', 3])``, the
        latter cleaned (``clean_triangles``)."""
        if self.simplifier == QUADRIC_COLLAPSE:
            out_pos, out_idx = quadric_collapse(unit, t_pos_idx, request)
            return len(out_idx), *clean_triangles(out_pos, out_idx)
        if self.simplifier == FAST_SIMPLIFICATION:
            out_pos, out_idx = fast_simplification.simplify(unit, t_pos_idx, target_count=request, agg=self.agg,
                                                             preserve_border=self.preserve_border)
            return len(out_idx), *clean_triangles(np.asarray(out_pos, np.float64), np.asarray(out_idx, np.int64))
        out = np.empty(t_pos_idx.size, np.uint32)
        count = meshoptimizer.simplify(out, np.ascontiguousarray(t_pos_idx.reshape(-1), np.uint32),
                                       np.ascontiguousarray(unit, np.float32), target_index_count=3 * request,
                                       target_error=_ANY_ERROR,
                                       options=meshoptimizer.SIMPLIFY_LOCK_BORDER if self.preserve_border else 0)
        return count // 3, *clean_triangles(unit, out[:count].reshape(-1, 3).astype(np.int64))


CANDIDATES = (Setting(FAST_SIMPLIFICATION, False, 3.0), Setting(FAST_SIMPLIFICATION, True, 3.0),
              Setting(MESHOPTIMIZER))
"""The settings tried on every input (a frozen border is skipped where the mesh has none: it
changes nothing there)."""
FIELD_CANDIDATES = (Setting(QUADRIC_COLLAPSE),) + CANDIDATES
"""The settings tried on an implicit surface's fine marching cubes (``jobs.simplify``): our
quadric collapse too, measured so far on fields only (``docs/benchmarks.md``)."""
FASTER = {Setting(FAST_SIMPLIFICATION, False, 3.0): Setting(FAST_SIMPLIFICATION, False, 5.0),
          Setting(FAST_SIMPLIFICATION, True, 3.0): Setting(FAST_SIMPLIFICATION, True, 5.0)}
"""A candidate's next setting, tried where it stops above the count: fast-simplification's
threshold growing faster (where ``agg`` 3 reaches the count, 5 strayed as far or further on the
benchmark assets)."""
CHOICE_SAMPLES = 5_000
"""Points sampled each way when candidates are compared (the first of the gauge's); the result
chosen is measured with all of them (``decimate_reported``)."""
FALLBACKS = (Setting(FAST_SIMPLIFICATION, True, 7.0), Setting(FAST_SIMPLIFICATION, True, 10.0),
             Setting(FAST_SIMPLIFICATION, False, 7.0), Setting(FAST_SIMPLIFICATION, False, 10.0))
"""Tried only where no candidate reaches the count: they do, where the others stall, but stray
far more (``lookalike bench decimate``)."""
SCHEDULE = tuple(Setting(FAST_SIMPLIFICATION, frozen, agg) for frozen in (True, False)
                 for agg in (3.0, 5.0, 7.0, 10.0))
"""The settings of fast-simplification in the order the first decimation tried them, taking the
first that reached the count (``lookalike bench decimate`` compares with it); the coarse pass
of a large input uses its first (``coarse_setting``)."""
GUARD = 1.0
"""No triangle of a result may lie farther from the input than this many feature sizes of its
count (module docstring)."""
_ATTEMPTS = 6                      # runs per setting with a corrected request to land on the exact count
_NEARLY = 2                        # a result this close to the count is accepted; a run this far above its request stalled
_ANY_ERROR = 1.0                   # meshoptimizer's error limit, of the unit diagonal: none, the count decides
_ZERO_AREA = 1e-12                 # triangle area below this times the squared bbox diagonal is degenerate
COARSE_ABOVE = 400_000
"""Inputs with more triangles are first decimated once to ``COARSE_TRIANGLES``."""
COARSE_TRIANGLES = 200_000
"""What a large input is first decimated to (at least 20 times any target's count)."""


def check_triangle_target(triangles, available: int) -> int:
    """Validate a target triangle count against the input's ``available`` triangles.

    Returns the count as an ``int``; raises ``ConfigError`` for a count that is not a positive
    integer or that is not below ``available``.
    """
    if isinstance(triangles, bool) or not isinstance(triangles, (int, np.integer)):
        raise ConfigError(f"target triangle count must be a whole number, got {triangles!r}")
    if triangles <= 0:
        raise ConfigError(f"target triangle count must be positive, got {triangles}")
    if triangles >= available:
        raise ConfigError(
            f"target triangle count {triangles:,} is not below the input's {available:,} triangles; "
            "nothing to simplify (ask for fewer triangles)"
        )
    return int(triangles)


def clean_triangles(v_pos: np.ndarray, t_pos_idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop degenerate triangles and fins, then unreferenced vertices.

    Removed: triangles with a repeated index or an area below ``1e-12 * diagonal^2``; every copy
    of a vertex triple that appears with both orientations (a zero-volume fin, which a collapse
    can leave behind and which makes its edges non-manifold); repeats of a triple that appears
    with one orientation only (one copy is kept). The repeats are found by a compiled hash
    table (``index_tables.triple_copies``); :func:`clean_triangles_python` is the sorting twin.

    Args:
        v_pos: ``[V, 3]`` float64, ``t_pos_idx``: ``[T, 3]`` int64.

    Returns:
        ``(v_pos [V', 3], t_pos_idx [T', 3])`` with every vertex referenced, triangle order and
        vertex order kept.
    """
    t_pos_idx = np.ascontiguousarray(t_pos_idx, dtype=np.int64)
    fin, first = triple_copies(t_pos_idx)
    kept = t_pos_idx[_large_enough(v_pos, t_pos_idx) & first & ~fin]
    used = np.zeros(len(v_pos), dtype=bool)
    used[kept.reshape(-1)] = True
    new_index = np.cumsum(used) - 1
    return v_pos[used], new_index[kept]


def clean_triangles_python(v_pos: np.ndarray, t_pos_idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Twin of :func:`clean_triangles` by sorting rows (``np.unique``), the tests' oracle."""
    keep = _large_enough(v_pos, t_pos_idx, triangle_areas_python)
    a, b, c = t_pos_idx.T
    keep &= (a != b) & (b != c) & (c != a)
    # An even permutation of a triple keeps its orientation: rotate so the smallest index leads.
    lead = t_pos_idx.argmin(axis=1)
    rotated = t_pos_idx[np.arange(len(t_pos_idx))[:, None], (lead[:, None] + np.arange(3)) % 3]
    oriented = np.unique(rotated, axis=0, return_inverse=True)[1].reshape(-1)
    triple = np.unique(np.sort(t_pos_idx, axis=1), axis=0, return_inverse=True)[1].reshape(-1)
    stride = max(len(t_pos_idx), 1)
    triple_of_orientation = np.unique(triple * stride + oriented) // stride   # one entry per (triple, orientation)
    fin = np.bincount(triple_of_orientation, minlength=len(t_pos_idx))[triple] > 1
    first_copy = np.zeros(len(t_pos_idx), dtype=bool)
    first_copy[np.unique(oriented, return_index=True)[1]] = True
    keep &= ~fin & first_copy
    kept = t_pos_idx[keep]
    used, remapped = np.unique(kept, return_inverse=True)
    return v_pos[used], remapped.reshape(-1, 3).astype(np.int64)


def _large_enough(v_pos: np.ndarray, t_pos_idx: np.ndarray, areas=triangle_areas) -> np.ndarray:
    """``[T]`` bool: triangle area (by ``areas``: the compiled pass, or its NumPy twin for the
    twin of ``clean_triangles``) above ``_ZERO_AREA`` times the squared bounding-box diagonal."""
    area = areas(v_pos, t_pos_idx)
    diagonal = np.linalg.norm(v_pos.max(axis=0) - v_pos.min(axis=0)) if len(v_pos) else 0.0
    return area > _ZERO_AREA * diagonal ** 2


def edge_uses(t_pos_idx: np.ndarray) -> np.ndarray:
    """``[E]``: how many of the triangles ``t_pos_idx [T, 3]`` use each undirected edge
    (``asset.edges.edge_index``)."""
    return np.bincount(edge_index(torch.from_numpy(np.asarray(t_pos_idx, dtype=np.int64)))[1].reshape(-1).numpy())


def closed_manifold(t_pos_idx: np.ndarray) -> bool:
    """Whether every edge of the triangles ``t_pos_idx [T, 3]`` is shared by exactly two of
    them: a closed surface, no edge non-manifold."""
    return len(t_pos_idx) > 0 and bool((edge_uses(t_pos_idx) == 2).all())


def welded_input(v_pos: np.ndarray, t_pos_idx: np.ndarray) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """The input as the decimations take it: ``(welded [T, 3], (v_pos' [V', 3], t_pos_idx'
    [T', 3]))``, its triangles' corners welded (``weld_vertices`` at ``weld_tolerance``, indices
    into ``v_pos``'s welded positions) and the welded mesh cleaned (``clean_triangles``). An
    input closed as indexed (``closed_manifold``) that this would open is taken as it is: welding
    also merges vertices that face each other across a gap thinner than its tolerance (the two
    sides of a thin part, the sheets of a field's fine marching cubes where they pass within a
    hair of one another), and cleaning the fins and non-manifold edges this makes tears holes;
    the collapses take the input's zero-length edges first and keep it closed. Where the weld
    and the clean change nothing, nothing is checked (each check sorts every edge: seconds at
    millions of triangles)."""
    t_pos_idx = np.asarray(t_pos_idx, dtype=np.int64)
    w_pos, welded, _ = weld_vertices(v_pos, t_pos_idx, weld_tolerance(v_pos))
    cleaned = clean_triangles(w_pos, welded)
    changed = len(w_pos) < len(v_pos) or len(cleaned[1]) < len(t_pos_idx)
    if changed and closed_manifold(t_pos_idx) and not closed_manifold(cleaned[1]):
        return t_pos_idx, (v_pos, t_pos_idx)
    return welded, cleaned


def unit_frame(v_pos: np.ndarray) -> tuple[np.ndarray, float]:
    """``(centre [3], scale)`` that map ``v_pos [V, 3]`` to a unit bounding-box diagonal."""
    lo, hi = v_pos.min(axis=0), v_pos.max(axis=0)
    return 0.5 * (lo + hi), max(float(np.linalg.norm(hi - lo)), 1e-30)


def has_open_border(t_pos_idx: np.ndarray) -> bool:
    """Whether an edge of the triangles ``t_pos_idx [T, 3]`` belongs to one triangle only."""
    return len(t_pos_idx) > 0 and bool((edge_uses(t_pos_idx) == 1).any())


def feature_size(area: float, triangles: int) -> float:
    """``s = sqrt(4 A / (sqrt(3) n))``: the edge of an equilateral triangle of area ``A / n``,
    the mean edge length of ``n = triangles`` triangles covering the area ``A = area``."""
    return float(np.sqrt(4.0 * area / (np.sqrt(3.0) * max(triangles, 1))))


def land(setting: Setting, unit: np.ndarray, t_pos_idx: np.ndarray, triangles: int) -> tuple[np.ndarray, np.ndarray]:
    """``setting`` run on ``unit [V, 3]`` / ``t_pos_idx [T, 3]`` with requests corrected by the
    shortfall until the cleaned result has ``triangles`` triangles, at most ``_ATTEMPTS`` runs;
    a request never leaves the range between the largest that gave too few and the smallest
    that gave too many (cleaning makes the count jump about). Stops where a run returns more
    than ``_NEARLY`` above its request (the setting stalled). Returns the result closest to the
    count ``(v_pos, t_pos_idx)``, in the unit frame."""
    best, request = None, triangles
    too_few, too_many = 0, len(t_pos_idx) + 1
    for _ in range(_ATTEMPTS):
        returned, out_pos, out_idx = setting.run(unit, t_pos_idx, request)
        got = len(out_idx)
        if best is None or abs(got - triangles) < abs(len(best[1]) - triangles):
            best = out_pos, out_idx
        if got == triangles or returned > request + _NEARLY:
            break
        if got < triangles:
            too_few = max(too_few, request)
        else:
            too_many = min(too_many, request)
        request += triangles - got
        if not too_few < request < too_many:
            request = (too_few + too_many) // 2
        if not too_few < request < too_many:
            break
    return best


@dataclass
class Candidate:
    """A setting's result ``v_pos [V, 3]`` / ``t_pos_idx [T, 3]`` (the input's units), its
    ``seconds``, and where it reached the count, its ``distance`` from the input and the seconds
    that measuring took; ``shards``: how many of its triangles lie beyond the guard's bound,
    where ``choose`` looked (``None`` where it did not)."""

    setting: Setting
    v_pos: np.ndarray
    t_pos_idx: np.ndarray
    seconds: float
    distance: SurfaceDistance | None = None
    shards: int | None = None
    measure_seconds: float = 0.0

    def key(self) -> tuple:
        """Order of preference: the least far area (shards), then the least mean distance."""
        combined = self.distance.combined
        return combined.far_area, combined.mean

    def row(self) -> dict:
        """The candidate as ``DecimationReport.candidates`` lists it."""
        row = {"setting": self.setting.label, "triangles": len(self.t_pos_idx), "seconds": self.seconds}
        if self.distance is not None:
            combined = self.distance.combined
            row.update(far_area=combined.far_area, mean=combined.mean, p99=combined.p99, shards=self.shards,
                       measure_seconds=self.measure_seconds)
        return row


def try_settings(v_pos: np.ndarray, t_pos_idx: np.ndarray, triangles: int, gauge: SurfaceGauge,
                 settings: tuple[Setting, ...] = CANDIDATES, fallbacks: tuple[Setting, ...] = FALLBACKS
                 ) -> list[Candidate]:
    """Every setting of ``settings`` landed on ``triangles`` (``land``) from ``v_pos [V, 3]`` /
    ``t_pos_idx [T, 3]`` (and its ``FASTER`` one where it stops above the count), and those of
    ``fallbacks`` too where none reaches the count; each that does measured by ``gauge`` on
    ``CHOICE_SAMPLES`` points each way. A frozen border is skipped where the mesh has none."""
    centre, scale = unit_frame(v_pos)
    unit = (v_pos - centre) / scale
    open_border = has_open_border(t_pos_idx)
    tried = []
    for group in (settings, fallbacks):
        queue = [setting for setting in group if open_border or not setting.preserve_border]
        while queue:
            setting = queue.pop(0)
            started = time.monotonic()
            out_pos, out_idx = land(setting, unit, t_pos_idx, triangles)
            candidate = Candidate(setting, out_pos * scale + centre, out_idx, time.monotonic() - started)
            if abs(len(out_idx) - triangles) <= _NEARLY:
                started = time.monotonic()
                candidate.distance = gauge.measure(candidate.v_pos, out_idx, CHOICE_SAMPLES)
                candidate.measure_seconds = time.monotonic() - started
            elif setting in FASTER:
                queue.insert(0, FASTER[setting])
            tried.append(candidate)
        if any(c.distance is not None for c in tried):
            break
    return tried


def choose(tried: list[Candidate], triangles: int, gauge: SurfaceGauge, bound: float) -> Candidate:
    """Of the candidates that reached the count, in order of ``Candidate.key`` (the first of
    equals first), the first with no triangle farther than ``bound`` from ``gauge``'s surface
    (each looked at gets its ``shards``), else the first; where none reached the count, the one
    closest to ``triangles`` (its ``distance`` ``None``)."""
    reached = sorted((c for c in tried if c.distance is not None), key=Candidate.key)
    for candidate in reached:
        started = time.monotonic()
        candidate.shards = int((gauge.triangle_distances(candidate.v_pos, candidate.t_pos_idx, bound) > bound).sum())
        candidate.measure_seconds += time.monotonic() - started
        if candidate.shards == 0:
            return candidate
    if reached:
        return reached[0]
    return min(tried, key=lambda c: abs(len(c.t_pos_idx) - triangles))


def repair_shards(gauge: SurfaceGauge, v_pos: np.ndarray, t_pos_idx: np.ndarray, bound: float
                  ) -> tuple[np.ndarray, np.ndarray, int]:
    """The guard's repair of ``v_pos [V, 3]`` / ``t_pos_idx [T, 3]``: the corners of triangles
    farther than ``bound`` from ``gauge``'s surface (``SurfaceGauge.triangle_distances``) moved
    to their closest points on it. Returns ``(v_pos [V, 3], keep [T] bool, corners moved)``,
    ``keep`` false for the triangles that still lie beyond ``bound`` (they span empty space)."""
    far = gauge.triangle_distances(v_pos, t_pos_idx, bound) > bound
    if not far.any():
        return v_pos, ~far, 0
    corners = np.unique(t_pos_idx[far])
    v_pos = np.array(v_pos, np.float64)
    v_pos[corners] = gauge.vertex_closest(v_pos[corners]).point
    return v_pos, gauge.triangle_distances(v_pos, t_pos_idx, bound) <= bound, len(corners)


def coarse_setting(settings: tuple[Setting, ...]) -> Setting:
    """The setting of a large input's coarse pass: the quadric collapse where it is among the
    candidates (a field's fine marching cubes: fast-simplification's coarse pass rounds their
    corners off, and the collapse cannot take back what it lost: twice the distance from the
    field at the count, ``docs/benchmarks.md``), else ``SCHEDULE``'s first."""
    return Setting(QUADRIC_COLLAPSE) if Setting(QUADRIC_COLLAPSE) in settings else SCHEDULE[0]


def _coarse_pass(v_pos: np.ndarray, t_pos_idx: np.ndarray, triangles: int, setting: Setting):
    """One decimation of ``v_pos [V, 3]`` / ``t_pos_idx [T, 3]`` by ``setting`` towards
    ``triangles`` (the count not exact), cleaned; in the input's units."""
    centre, scale = unit_frame(v_pos)
    _, out_pos, out_idx = setting.run((v_pos - centre) / scale, t_pos_idx, triangles)
    return out_pos * scale + centre, out_idx


@dataclass
class DecimationReport:
    """How a decimation went, and how far its result strays from the input.

    Attributes:
        setting: the chosen setting's label (and what followed it: parts dropped, shards repaired).
        triangles: the result's count.
        distance: its two-sided distance from the input (``lookalike.init.surface_distance``, in
            the input's bounding radii): from the whole welded input, or from the coarse mesh
            where ``against`` is ``"coarse"`` (``decimate`` of a large input); on all the
            gauge's points (``decimate_reported``) or ``CHOICE_SAMPLES`` (``decimate``).
        bound: the guard's bound, in bounding radii.
        snapped, removed: corners the guard moved onto the input, triangles it removed.
        candidates: each setting tried (``Candidate.row``), in order.
        seconds: the whole decimation; measure_seconds: of which measuring distances.
        against: ``"input"`` or ``"coarse"``.
        samples: points sampled on each surface for ``distance``.
    """

    setting: str
    triangles: int
    distance: SurfaceDistance
    bound: float
    snapped: int = 0
    removed: int = 0
    candidates: list[dict] = field(default_factory=list)
    seconds: float = 0.0
    measure_seconds: float = 0.0
    against: str = "input"
    samples: int = 0

    @property
    def far_area(self) -> float:
        return self.distance.combined.far_area

    @property
    def mean(self) -> float:
        return self.distance.combined.mean

    @property
    def p99(self) -> float:
        return self.distance.combined.p99

    def as_dict(self) -> dict:
        """Plain values, as ``metrics.json``'s ``start_distance`` holds them."""
        guard = {"bound": self.bound, "snapped": self.snapped, "removed": self.removed}
        return {"of": "our decimation", "setting": self.setting, "triangles": self.triangles,
                **self.distance.as_dict(), "against": self.against, "samples": self.samples, "guard": guard,
                "seconds": self.seconds, "measure_seconds": self.measure_seconds, "candidates": self.candidates}


def largest_parts(v_pos: np.ndarray, t_pos_idx: np.ndarray, triangles: int) -> tuple[np.ndarray, np.ndarray]:
    """The disjoint parts of ``v_pos [V, 3]`` / ``t_pos_idx [T, 3]`` (``lookalike.asset.parts``)
    kept by area, largest first, each while it still fits in ``triangles``; the others dropped,
    with their vertices. What is left of many small parts that quadric decimation cannot
    reduce further (a leaf is still a few triangles): at the budget, the smallest vanish."""
    parts = triangle_parts(v_pos, t_pos_idx)
    area = np.bincount(parts, weights=triangle_areas(v_pos, t_pos_idx))
    size = np.bincount(parts)
    kept = np.zeros(len(size), bool)
    room = triangles
    for part in np.argsort(-area, kind="stable"):
        if size[part] <= room:
            kept[part] = True
            room -= size[part]
    tri = t_pos_idx[kept[parts]]
    used, compact = np.unique(tri, return_inverse=True)
    return v_pos[used], compact.reshape(-1, 3)


def decimate(mesh: Mesh, triangles: int, crease_angle: float = DEFAULT_CREASE_ANGLE) -> Mesh:
    """Simplify ``mesh`` to ``triangles`` triangles by quadric error, keeping its attributes:
    ``decimate_reported``'s mesh, without measuring the result once more for the report (on all
    the points, and for a large input against the whole input)."""
    return _decimate(mesh, triangles, crease_angle, whole_input=False)[0]


def decimate_reported(mesh: Mesh, triangles: int, crease_angle: float = DEFAULT_CREASE_ANGLE,
                      settings: tuple[Setting, ...] = CANDIDATES) -> tuple[Mesh, DecimationReport]:
    """Simplify ``mesh`` to ``triangles`` triangles by quadric error, keeping its attributes,
    choosing among the settings by how far each strays from the input (module docstring).

    Args:
        mesh: the input; positions may be unwelded (coincident copies are merged within
            ``1e-5`` of the bounding-box diagonal).
        triangles: the target count, ``0 < triangles < mesh.num_triangles``. The result has
            exactly this many triangles unless fins or degenerate triangles had to be removed
            after the last correction run, or the count's parity cannot be reached (a collapse
            inside a surface removes two triangles, one on an open border one: a closed
            surface's count stays even), then within ``_NEARLY`` = 2; or unless the input is
            many disjoint parts that cannot be reduced to it: then its smallest parts are
            dropped until it fits (``largest_parts``), and it may have a few fewer; the guard
            may remove a few more (``DecimationReport.removed``).
        crease_angle: dihedral angle in degrees above which an edge of the result is hard
            (``lookalike.asset.normals.crease_normal_index``).
        settings: the candidates (``CANDIDATES``, or ``FIELD_CANDIDATES``).

    Returns:
        ``(mesh, report)``: a welded ``Mesh`` (``v_pos [V, 3]`` float32, ``t_pos_idx [T, 3]``
        int64) with the input's UV sets, materials, vertex colours and skin weights carried over
        (see ``lookalike.init.transfer``) and normal slots ``t_nrm_idx`` split at creases (no
        authored values), a watertight input giving a watertight result; and the
        ``DecimationReport`` (the distance measured against the whole welded input).

    Raises:
        ConfigError: the target is not a positive whole number below the input's count.
    """
    return _decimate(mesh, triangles, crease_angle, whole_input=True, settings=settings)


def _decimate(mesh: Mesh, triangles: int, crease_angle: float, whole_input: bool,
              settings: tuple[Setting, ...] = CANDIDATES) -> tuple[Mesh, DecimationReport]:
    """``decimate_reported``; ``whole_input``: measure a large input's result against the whole
    input too (else against its coarse mesh)."""
    started = time.monotonic()
    triangles = check_triangle_target(triangles, mesh.num_triangles)
    src_pos = mesh.v_pos.detach().cpu().numpy().astype(np.float64)
    welded_idx, whole = welded_input(src_pos, mesh.t_pos_idx.cpu().numpy())
    w_pos, w_idx = whole
    coarse = max(COARSE_TRIANGLES, 20 * triangles)
    coarsened = len(w_idx) > max(COARSE_ABOVE, 2 * coarse)
    if coarsened:
        w_pos, w_idx = _coarse_pass(w_pos, w_idx, coarse, coarse_setting(settings))
    measuring = time.monotonic()
    gauge = SurfaceGauge(w_pos, w_idx)
    measured = time.monotonic() - measuring
    bound = GUARD * feature_size(float(triangle_areas(w_pos, w_idx).sum()), triangles)
    tried, distance, shards = [], None, 0
    if len(w_idx) > triangles:
        tried = try_settings(w_pos, w_idx, triangles, gauge, settings)
        chosen = choose(tried, triangles, gauge, bound)
        w_pos, w_idx, setting = chosen.v_pos, chosen.t_pos_idx, chosen.setting.label
        distance, shards = chosen.distance, chosen.shards
        measured += sum(c.measure_seconds for c in tried)
    else:
        setting = "none: the welded input has no more triangles"
    if len(w_idx) > triangles + _NEARLY:
        w_pos, w_idx = largest_parts(w_pos, w_idx, triangles)
        setting, distance, shards = f"{setting}, its smallest parts dropped", None, None
    measuring = time.monotonic()
    snapped = removed = 0
    if shards != 0:                                  # not known to be free of shards
        w_pos, keep, snapped = repair_shards(gauge, w_pos, w_idx, bound)
        if snapped:
            count = len(w_idx)
            w_pos, w_idx = clean_triangles(w_pos, w_idx[keep])
            setting, distance, removed = f"{setting}, the guard's repair", None, count - len(w_idx)
    if whole_input:
        distance, samples = (SurfaceGauge(*whole) if coarsened else gauge).measure(w_pos, w_idx), gauge.samples
    else:
        samples = CHOICE_SAMPLES
        if distance is None:
            distance = gauge.measure(w_pos, w_idx, samples)
    measured += time.monotonic() - measuring
    against = "coarse" if coarsened and not whole_input else "input"
    low = transfer_attributes(mesh, w_pos, w_idx, welded_idx)
    low = replace(low, t_nrm_idx=crease_normal_index(low.v_pos, low.t_pos_idx, crease_angle))
    report = DecimationReport(setting=setting, triangles=low.num_triangles, distance=distance,
                              bound=bound / max(gauge.radius, 1e-300), snapped=snapped, removed=removed,
                              candidates=[c.row() for c in tried], seconds=time.monotonic() - started,
                              measure_seconds=measured, against=against, samples=samples)
    return low, report
