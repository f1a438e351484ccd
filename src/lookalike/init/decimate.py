"""Quadric-error decimation to a triangle budget, the paper's initial guess.

Positions are welded first (so that UV-seam duplicates do not open cracks), the maintained
``fast-simplification`` library collapses edges by quadric error (Garland and Heckbert 1997),
the result is cleaned of degenerate triangles and zero-volume fins, and UVs, materials,
vertex colours and skin weights are carried over from the input (``transfer``). Its normals are
split at creases sharper than ``lookalike.asset.normals.DEFAULT_CREASE_ANGLE`` (normal slots
only: the values follow the positions).

fast-simplification's ``agg`` sets how fast its error threshold grows; low values keep the
shape better than its default 7 (``docs/benchmarks.md``) but may stop above the requested
count. Its quadrics do not guard open borders, so small flat parts (a quad
of two triangles) and the rims of open sheets collapse first unless border vertices are frozen
(``preserve_border``), which in turn stalls on meshes that are mostly border. So the mesh is
scaled to a unit bounding-box diagonal (making the threshold independent of units) and the
first setting of ``SCHEDULE`` that reaches the count is used.

Landing on the exact count takes several runs, each over the whole input; on a large input
(over ``COARSE_ABOVE`` triangles) one run first brings it to ``COARSE_TRIANGLES``, and the
runs that land on the count start from there, so that the whole input is decimated once.
"""

from __future__ import annotations

from dataclasses import replace

import fast_simplification
import numpy as np

from ..asset.index_tables import triple_copies
from ..asset.mesh import Mesh
from ..asset.parts import triangle_parts
from ..asset.normals import DEFAULT_CREASE_ANGLE, crease_normal_index
from ..errors import ConfigError
from .transfer import transfer_attributes
from .triangle_kernels import triangle_areas, triangle_areas_python
from .weld import weld_tolerance, weld_vertices

SCHEDULE = tuple((frozen, agg) for frozen in (True, False) for agg in (3.0, 5.0, 7.0, 10.0))
"""``(preserve_border, agg)`` settings of fast-simplification, tried in order."""
_ATTEMPTS = 4                      # runs per setting with a corrected request to land on the exact count
_NEARLY = 2                        # a result this close to the count is accepted; a run this far above its request stalled
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


def _unit_frame(v_pos: np.ndarray) -> tuple[np.ndarray, float]:
    """``(centre [3], scale)`` that map ``v_pos [V, 3]`` to a unit bounding-box diagonal."""
    lo, hi = v_pos.min(axis=0), v_pos.max(axis=0)
    return 0.5 * (lo + hi), max(float(np.linalg.norm(hi - lo)), 1e-30)


def _simplify_to_count(v_pos: np.ndarray, t_pos_idx: np.ndarray, triangles: int):
    """Quadric decimation of ``v_pos [V, 3]`` / ``t_pos_idx [T, 3]`` to ``triangles`` cleaned
    triangles: for each setting of ``SCHEDULE`` in turn, run with a request corrected by the
    shortfall until the count is exact; move to the next setting when one stops above its
    request. Returns the closest result found ``(v_pos, t_pos_idx)``, in the input's units."""
    centre, scale = _unit_frame(v_pos)
    unit = (v_pos - centre) / scale
    best = None
    for frozen, agg in SCHEDULE:
        request = triangles
        for _ in range(_ATTEMPTS):
            request = int(np.clip(request, 1, len(t_pos_idx)))
            out_pos, out_idx = fast_simplification.simplify(unit, t_pos_idx, target_count=request, agg=agg,
                                                             preserve_border=frozen)
            result = clean_triangles(np.asarray(out_pos, np.float64), np.asarray(out_idx, np.int64))
            got = len(result[1])
            if best is None or abs(got - triangles) < abs(len(best[1]) - triangles):
                best = result
            if got == triangles or len(out_idx) > request + _NEARLY:
                break
            request += triangles - got
        if abs(len(best[1]) - triangles) <= _NEARLY:
            break
    return best[0] * scale + centre, best[1]


def _coarse_pass(v_pos: np.ndarray, t_pos_idx: np.ndarray, triangles: int):
    """One quadric decimation of ``v_pos [V, 3]`` / ``t_pos_idx [T, 3]`` towards ``triangles``
    (``SCHEDULE``'s first setting, the count not exact), cleaned; in the input's units."""
    centre, scale = _unit_frame(v_pos)
    frozen, agg = SCHEDULE[0]
    out_pos, out_idx = fast_simplification.simplify((v_pos - centre) / scale, t_pos_idx, target_count=triangles,
                                                     agg=agg, preserve_border=frozen)
    out_pos, out_idx = clean_triangles(np.asarray(out_pos, np.float64), np.asarray(out_idx, np.int64))
    return out_pos * scale + centre, out_idx


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
    """Simplify ``mesh`` to ``triangles`` triangles by quadric error, keeping its attributes.

    Args:
        mesh: the input; positions may be unwelded (coincident copies are merged within
            ``1e-5`` of the bounding-box diagonal).
        triangles: the target count, ``0 < triangles < mesh.num_triangles``. The result has
            exactly this many triangles unless fins or degenerate triangles had to be removed
            after the last correction run (then within ``_NEARLY`` = 2), or unless the input is
            many disjoint parts that cannot be reduced to it: then its smallest parts are
            dropped until it fits (``largest_parts``), and it may have a few fewer.
        crease_angle: dihedral angle in degrees above which an edge of the result is hard
            (``lookalike.asset.normals.crease_normal_index``).

    Returns:
        A welded ``Mesh`` (``v_pos [V, 3]`` float32, ``t_pos_idx [T, 3]`` int64) with the input's
        UV sets, materials, vertex colours and skin weights carried over (see
        ``lookalike.init.transfer``) and normal slots ``t_nrm_idx`` split at creases (no
        authored values). A watertight input gives a watertight result.

    Raises:
        ConfigError: the target is not a positive whole number below the input's count.
    """
    triangles = check_triangle_target(triangles, mesh.num_triangles)
    src_pos = mesh.v_pos.detach().cpu().numpy().astype(np.float64)
    w_pos, welded_idx, _ = weld_vertices(src_pos, mesh.t_pos_idx.cpu().numpy(), weld_tolerance(src_pos))
    w_pos, w_idx = clean_triangles(w_pos, welded_idx)
    coarse = max(COARSE_TRIANGLES, 20 * triangles)
    if len(w_idx) > max(COARSE_ABOVE, 2 * coarse):
        w_pos, w_idx = _coarse_pass(w_pos, w_idx, coarse)
    if len(w_idx) > triangles:
        w_pos, w_idx = _simplify_to_count(w_pos, w_idx, triangles)
    if len(w_idx) > triangles + _NEARLY:
        w_pos, w_idx = largest_parts(w_pos, w_idx, triangles)
    low = transfer_attributes(mesh, w_pos, w_idx, welded_idx)
    return replace(low, t_nrm_idx=crease_normal_index(low.v_pos, low.t_pos_idx, crease_angle))
