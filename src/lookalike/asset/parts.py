"""The disjoint parts of a mesh: the leaves of a bush, the links of a chain.

Two triangles belong to one part when a chain of triangles joins them, each sharing a corner
position with the next. Positions are compared exactly (``v_pos`` rows that are equal count as
one corner), so a part whose vertices are split at UV or normal seams stays one part.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse
from scipy.sparse.csgraph import connected_components


def triangle_parts(v_pos: np.ndarray, t_pos_idx: np.ndarray) -> np.ndarray:
    """``[T]`` int64 part label of each triangle, ``0 .. parts - 1``, numbered in the order of
    each part's first triangle.

    Args:
        v_pos: ``[V, 3]`` positions; t_pos_idx: ``[T, 3]`` int triangles.
    Cost: one sort of the positions and one sparse connected-components pass, O(V log V + T).
    """
    t_pos_idx = np.asarray(t_pos_idx, dtype=np.int64)
    if len(t_pos_idx) == 0:
        return np.zeros(0, dtype=np.int64)
    return _corner_parts(welded_corners(v_pos, t_pos_idx)[1])


def welded_corners(v_pos: np.ndarray, t_pos_idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct positions ``[C, 3]`` of ``v_pos`` and each triangle's corners among them,
    ``[T, 3]`` int64 (equal ``v_pos`` rows are one corner)."""
    positions, corner = np.unique(np.asarray(v_pos), axis=0, return_inverse=True)
    return positions, corner.reshape(-1)[np.asarray(t_pos_idx, dtype=np.int64)]


def _corner_parts(corner: np.ndarray) -> np.ndarray:
    """``triangle_parts`` of triangles given by their welded corners ``[T, 3]`` (``welded_corners``)."""
    count = int(corner.max()) + 1
    edges = np.concatenate([corner[:, [0, 1]], corner[:, [1, 2]]])
    graph = scipy.sparse.coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(count, count))
    label = connected_components(graph, directed=False)[1][corner[:, 0]]
    _, first, renumbered = np.unique(label, return_index=True, return_inverse=True)
    order = np.argsort(np.argsort(first))                                # rank of each part's first triangle
    return order[renumbered.reshape(-1)].astype(np.int64)


def triangle_parts_python(v_pos: np.ndarray, t_pos_idx: np.ndarray) -> np.ndarray:
    """``triangle_parts`` by a union-find over triangles, one corner at a time (the oracle)."""
    t_pos_idx = np.asarray(t_pos_idx, dtype=np.int64)
    parent = list(range(len(t_pos_idx)))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    owner: dict[tuple, int] = {}
    for t, tri in enumerate(t_pos_idx):
        for v in tri:
            key = tuple(np.asarray(v_pos)[v].tolist())
            if key in owner:
                parent[root(t)] = root(owner[key])
            else:
                owner[key] = t
    labels, out = {}, np.zeros(len(t_pos_idx), dtype=np.int64)
    for t in range(len(t_pos_idx)):
        out[t] = labels.setdefault(root(t), len(labels))
    return out


AGGREGATE_PARTS = 20
"""An input is aggregate geometry when at least this many of its parts are card-like (see
``aggregate_traits``): foliage and hair have hundreds, while a scan with a few loose crumbs or a
model with a handful of open panels has too few for cards to pay off."""

AGGREGATE_AREA_SHARE = 0.5
"""...and those card-like parts hold at least this share of its surface area, so that they,
not a solid body with some small bits attached, are what the input looks like."""

AGGREGATE_SMALL = 0.15
"""A part is small when the diagonal of its box along its principal axes is under this fraction
of the asset's bounding-box diagonal: a leaf on a plant, a tuft of hair; cards stand for many
such parts together, each too small to keep its shape at a low triangle count."""

AGGREGATE_THIN = 0.15
"""A part is thin when its second largest extent along its principal axes is under this
fraction of its largest: a grass blade or a strand, which decimation collapses into a line
however long it is."""


@dataclass
class PartSurvey:
    """The disjoint parts of an asset's triangles and what ``card_like_parts`` reads of them.

    Attributes (T triangles, C welded corners, P parts):
        positions: ``[C, 3]`` float64 distinct positions; corner: ``[T, 3]`` int64 each
            triangle's corners among them.
        part: ``[T]`` int64 part label (as ``triangle_parts``); area: ``[P]`` float64 surface area.
        alpha_tested: ``[P]`` bool, a triangle of the part uses an alpha material.
        open_surface: ``[P]`` bool, the part has a boundary edge and is not alpha-tested.
    """

    positions: np.ndarray
    corner: np.ndarray
    part: np.ndarray
    area: np.ndarray
    alpha_tested: np.ndarray
    open_surface: np.ndarray


def survey_parts(asset, least_parts: int = 1) -> PartSurvey | None:
    """The ``PartSurvey`` of ``asset``'s mesh as stored, or ``None`` where it has no triangles
    or fewer than ``least_parts`` parts (the rest of the work skipped). One survey serves the
    aggregate hint and the cards' split of an input into a kept mesh and cards, so both classify
    parts by one rule.

    Cost: ``triangle_parts``, then one sort of the edges (``_open_parts``)."""
    mesh = asset.mesh
    tri = mesh.t_pos_idx.detach().cpu().numpy().astype(np.int64)
    if len(tri) == 0:
        return None
    positions, corner = welded_corners(mesh.v_pos.detach().cpu().numpy(), tri)
    part = _corner_parts(corner)
    parts = int(part.max()) + 1
    if parts < least_parts:
        return None
    positions = positions.astype(np.float64)
    at = positions[corner]
    area = 0.5 * np.linalg.norm(np.cross(at[:, 1] - at[:, 0], at[:, 2] - at[:, 0]), axis=1)
    uses_alpha = np.array([m.uses_alpha for m in asset.materials], bool)[mesh.t_mat_idx.cpu().numpy()]
    alpha_tested = np.bincount(part, uses_alpha, parts) > 0
    return PartSurvey(positions=positions, corner=corner, part=part, area=np.bincount(part, area, parts),
                      alpha_tested=alpha_tested, open_surface=_open_parts(corner, part, parts) & ~alpha_tested)


def card_like_parts(survey: PartSurvey) -> np.ndarray:
    """``[P]`` bool: the part is card-like, alpha-tested or an open surface that is small
    (``AGGREGATE_SMALL``) or thin (``AGGREGATE_THIN``); the others are solid (the rule of
    ``aggregate_traits``). Cost: per-part sums over the corners of the open parts only."""
    used = np.zeros(len(survey.positions), bool)
    used[survey.corner.reshape(-1)] = True
    diagonal = float(np.linalg.norm(survey.positions[used].max(0) - survey.positions[used].min(0)))
    shaped = survey.open_surface.copy()
    if shaped.any():
        shaped[shaped] = _small_or_thin_parts(survey.positions, survey.corner, survey.part, shaped, diagonal)
    return shaped | survey.alpha_tested


def aggregate_traits(asset) -> str | None:
    """What makes ``asset`` look like aggregate geometry, in a few words (e.g. ``"4,012
    disjoint parts, 4,000 of them alpha-tested or small or thin open surfaces, holding 83 % of
    the area"``), or ``None`` where it does not.

    A part is card-like when it is drawn with an alpha-using material (any of its triangles: a
    card already, whatever its size), or when it is an open surface (an edge of its welded
    corners is used by one of its triangles only: a leaf, a blade) that is small
    (``AGGREGATE_SMALL``) or thin (``AGGREGATE_THIN``). A closed part (every edge shared by two
    triangles) is solid and never card-like unless alpha-tested (``card_like_parts``).
    The input is aggregate when at least ``AGGREGATE_PARTS`` parts are card-like and they hold
    at least ``AGGREGATE_AREA_SHARE`` of the area. A skinned input (a skin with per-vertex
    influences) never is: a character's parts move with its joints, which cards cannot follow.

    Cost: ``survey_parts``, then per-part sums over the corners of the open parts only, where
    the open or alpha-tested parts could make the input aggregate; no loop over parts or
    triangles.
    """
    if asset.skin is not None and asset.mesh.v_joints is not None:
        return None
    survey = survey_parts(asset, AGGREGATE_PARTS)
    if survey is None:
        return None
    total = max(float(survey.area.sum()), 1e-30)
    candidate = survey.open_surface | survey.alpha_tested
    if candidate.sum() < AGGREGATE_PARTS or survey.area[candidate].sum() < AGGREGATE_AREA_SHARE * total:
        return None                                                      # too few open or alpha-tested parts
    card_like = card_like_parts(survey)
    count = int(card_like.sum())
    share = float(survey.area[card_like].sum() / total)
    if count < AGGREGATE_PARTS or share < AGGREGATE_AREA_SHARE:
        return None
    return (f"{len(survey.area):,} disjoint parts, {count:,} of them alpha-tested or small or thin open surfaces, "
            f"holding {100 * share:.0f} % of the area")


def _open_parts(corner: np.ndarray, part: np.ndarray, parts: int) -> np.ndarray:
    """``[P]`` bool: the part has a boundary edge, one of its welded corners ``corner [T, 3]``
    used by one triangle only (edges of a degenerate triangle's repeated corner aside)."""
    edges = np.sort(corner[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    proper = np.flatnonzero(edges[:, 0] != edges[:, 1])
    key = edges[proper, 0] * (int(corner.max()) + 1) + edges[proper, 1]
    order = np.argsort(key)
    key = key[order]
    single = np.ones(len(key), bool)                                     # unlike both neighbours once sorted
    single[1:] &= key[1:] != key[:-1]
    single[:-1] &= key[:-1] != key[1:]
    return np.bincount(part[proper[order[single]] // 3], minlength=parts) > 0


def _small_or_thin_parts(positions: np.ndarray, corner: np.ndarray, part: np.ndarray, chosen: np.ndarray,
                         diagonal: float) -> np.ndarray:
    """``[chosen.sum()]`` bool, of each part where ``chosen [P]``: the part is small (the diagonal
    of its box along its principal axes, the eigenvectors of its corners' covariance, is under
    ``AGGREGATE_SMALL`` of ``diagonal``, the asset's) or thin (its second largest extent along
    those axes is under ``AGGREGATE_THIN`` of its largest). Principal axes make both
    independent of how a part is turned.

    A part whose axis-aligned box diagonal is small even times sqrt(3) is small without them:
    no extent exceeds the part's diameter, and no box diagonal is under it.
    """
    label, points, groups = _corners_of(positions, corner, part, chosen)
    box = np.stack([_group_extent(label, points[:, i], groups) for i in range(3)], 1)
    shaped = np.sqrt(3) * np.linalg.norm(box, axis=1) < AGGREGATE_SMALL * diagonal
    rest = chosen.copy()
    rest[chosen] = ~shaped
    if rest.any():
        label, points, groups = _corners_of(positions, corner, part, rest)
        mean = np.stack([np.bincount(label, points[:, i], groups) for i in range(3)], 1)
        offset = points - (mean / np.bincount(label, minlength=groups)[:, None])[label]
        covariance = np.empty((groups, 3, 3))
        for i, j in ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)):
            covariance[:, i, j] = covariance[:, j, i] = np.bincount(label, offset[:, i] * offset[:, j], groups)
        axes = np.linalg.eigh(covariance)[1]                            # [G, 3, 3], one axis a column
        extent = np.sort(np.stack([_group_extent(label, np.einsum("ci,ci->c", offset, axes[label, :, k]), groups)
                                   for k in range(3)], 1), axis=1)
        small = np.linalg.norm(extent, axis=1) < AGGREGATE_SMALL * diagonal
        shaped[~shaped] = small | (extent[:, 1] < AGGREGATE_THIN * extent[:, 2])
    return shaped


def _corners_of(positions: np.ndarray, corner: np.ndarray, part: np.ndarray,
                chosen: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """The welded corners of the parts where ``chosen [P]``: each one's group ``[C']`` (the rank
    of its part among the chosen), its position ``[C', 3]``, and the number of groups."""
    groups = int(chosen.sum())
    group = np.full(len(chosen), -1, dtype=np.int64)
    group[chosen] = np.arange(groups)
    corner_group = np.full(len(positions), -1, dtype=np.int64)
    corner_group[corner.reshape(-1)] = np.repeat(group[part], 3)
    used = np.flatnonzero(corner_group >= 0)
    return corner_group[used], positions[used], groups


def _group_extent(label: np.ndarray, values: np.ndarray, groups: int) -> np.ndarray:
    """``[G]`` largest minus smallest of ``values`` in each group ``label``."""
    low, high = np.full(groups, np.inf), np.full(groups, -np.inf)
    np.minimum.at(low, label, values)
    np.maximum.at(high, label, values)
    return high - low
