"""Billboard clouds (Décoret et al. 2003): the initial guess of the ``cards`` application, where
foliage is approximated by alpha-textured quads ("cards") whose corners, base colour + alpha,
specular and normal maps the fit then optimises (paper, Sec. 5.4: "we replace the complex leaf
geometries with textured quads").

Elements. Every triangle has its area ``A``, centroid and sign-free orientation ``n n^T`` (``n``
its unit normal; a card is double-sided, so ``n`` and ``-n`` are one orientation); a part of the
input (``lookalike.asset.parts.triangle_parts``: a leaf, a twig) has the sum of its triangles'
areas and their area-weighted mean centroid and orientation. The clustering features of an
element at ``x`` with orientation ``O`` are ``((x - c) / s, ORIENTATION_WEIGHT * vec(O))``:
``c`` the area-weighted mean position of the elements clustered together, ``s = R k^(-1/3)``
the spacing of ``k`` clusters in their bounding ball of radius ``R`` (around ``c``), ``vec``
the 6 entries of the symmetric matrix, off-diagonal ones times ``sqrt(2)``, so that distances
are Frobenius norms: orientations ``theta`` apart are ``sqrt(2) |sin theta|`` apart. With
``ORIENTATION_WEIGHT = 1`` a perpendicular element is as far as one ``sqrt(2)`` cluster spacings
away: position and orientation matter alike at any card count.

Clustering, for a budget of ``Q = triangles // 2`` cards. More parts than cards: an
area-weighted k-means of the parts into ``Q`` clusters. At most as many parts as cards: every
part gets one card (the paper's Gardenia, each leaf a quad), and the spare cards go to the parts
by area (D'Hondt: ``k_p = max(1, floor(A_p / q))``, at most one per triangle, ``q`` such that
they add up to ``Q``); a part with ``k_p > 1`` is split by the same k-means over its own
triangles, so a single connected mesh becomes ``Q`` clusters of its triangles. The k-means
(``kmeans``) seeds by k-means++ (probability proportional to area times squared distance) from
a pool of at most ``SEED_POOL * k`` elements drawn by area, then runs Lloyd iterations (nearest
centre by k-d tree, area-weighted means) until no element changes cluster or
``MAX_ITERATIONS``; a cluster left empty is reseeded at the element farthest from its centre
(area times squared distance). All draws come from the caller's generator: a seed gives one
result.

Planes. Per cluster, the area-weighted covariance of its triangles as solid shapes (each
triangle's exact second moment ``(sum_i p_i p_i^T + (sum_i p_i)(sum_i p_i)^T) / 12``); the
card's normal ``n`` is the least-variance axis, its ``u`` axis the most-variance one, ``v = n x u``.
``n`` points away from the asset's centre (the side a viewer outside sees; where the cluster's
mean lies on the centre, along its area-weighted face normals). The quad is the bounding
rectangle of the cluster's vertices projected on ``(u, v)``, in the plane through the
cluster's area-weighted mean ``m`` (``n . x = n . m``), its axes ``(u, v)`` turned in the plane by
the one of ``ROTATIONS`` angles evenly spread over 90 degrees that gives the smallest rectangle
(principal axes alone miss it where the spread is round, e.g. a square); a side shorter than
``MIN_SIDE`` of the longer one (a line or point cluster) is widened to that about its middle.

Atlas. One chart per card, ``ceil(scale * side)`` texels along each side (area proportional to
the card's, aspect kept), shelf-packed tallest first with ``CHART_GAP`` texels between charts
(half that at the atlas border; shelves beside a top-left square ``reserved`` for a mesh kept
with the cards start right of it), ``scale`` the largest that fits (bisection). A quad's corners
sit on its chart's outer texel edges, ``u`` to the right and ``v`` up the image (glTF UVs, row 0
at the top), so seen from ``+n`` the chart shows the card upright and our tangent frame of the
quad (``lookalike.asset.tangents``) is ``(u, v, n)``.

Bake. Every cluster's triangles are projected orthographically along their card's normal into
the card's chart (in-plane coordinates to the chart, height along ``n`` to depth, nearest =
highest), all cards at once in one ``SUPERSAMPLES`` times finer image (charts never overlap),
and peeled front to back (``lookalike.render.DepthPeeler``). Each layer's fragments read the
input's material where they lie (``lookalike.init.reference_surface``: base colour, coverage as
the alpha mode applies it -- OPAQUE 1, MASK thresholded at the cutoff, BLEND alpha --, specular,
shading normal, emission and occlusion where the input has them) and are composited "over" the
ones in front: weight ``w = T alpha`` with ``T`` what still shows through, so the sample's
alpha is ``1 - prod(1 - alpha)``, the coverage. Peeling stops when no sample sees through more
than ``TRANSMITTANCE_LEFT`` or after ``MAX_LAYERS`` layers. Every triangle counts whichever way
it faces (the card is double-sided and stands for both sides of its cluster); a shading normal
of a triangle facing away from ``n`` is flipped, as the renderer flips it. A texel's alpha is the
mean of its samples', its base colour, specular, emission and occlusion the ``w``-weighted means
(straight, not premultiplied, alpha), its normal map the ``w``-weighted mean normal in the frame
``(u, v, n)``, normalised. Texels with no weight (transparent) take those values from the nearest
covered texel (``lookalike.init.projection_bake.nearest_covered``), keeping alpha 0, so bilinear and mip
sampling pull in no dark fringe.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import torch
from scipy.spatial import cKDTree

import lookalike.render as dr

from ..asset.asset import Asset
from ..asset.material import Material, Texture
from ..asset.mesh import Mesh
from ..asset.parts import triangle_parts
from ..errors import ConfigError
from ..phases import phase
from .projection_bake import nearest_covered, to_unit_normal
from .reference_surface import ReferenceSurface

ORIENTATION_WEIGHT = 1.0
"""Weight of the orientation features against the position features (see the module docstring)."""

SEED_POOL = 8
"""k-means++ seeds ``k`` clusters from at most ``SEED_POOL * k`` elements drawn by area (its cost
is ``k`` passes over the pool)."""

MAX_ITERATIONS = 30
"""Most Lloyd iterations of the k-means."""

ROTATIONS = 30
"""In-plane turns of a card's principal axes tried (evenly over 90 degrees) for its smallest
bounding rectangle."""

MIN_SIDE = 0.01
"""Shortest side of a card as a fraction of its longest."""

CHART_GAP = 2
"""Texels between two charts of the atlas."""

SUPERSAMPLES = 2
"""Bake samples per texel and axis."""

MAX_LAYERS = 16
"""Most depth layers composited per sample."""

TRANSMITTANCE_LEFT = 1.0 / 512
"""A sample stops compositing once less than this share of what lies behind would show through."""

_CARD_CORNERS = ((0, 1), (1, 1), (0, 0), (1, 0))
"""The quad's corners as (u side, v side), 0 = low, 1 = high: top-left, top-right, bottom-left,
bottom-right seen from ``+n``."""

_CARD_TRIANGLES = ((2, 3, 1), (2, 1, 0))
"""The quad's two triangles, counter-clockwise seen from ``+n``."""


@dataclass
class CardCloud:
    """A billboard cloud: the start of the ``cards`` application.

    Attributes (Q cards, T triangles of the input):
        asset: the quads, 4 own vertices and 2 triangles each (card ``q`` is vertices
            ``4q .. 4q+3``, triangles ``2q, 2q+1``), then the ``kept`` triangles of a mesh kept
            beside them (``lookalike.init.trunk_and_cards``), UV set 0 the atlas, one material
            ``"lookalike"`` (kd ``[S, S, 4]``, ks ``[S, S, 3]``, normal ``[S, S, 3]``, emissive and
            occlusion where the input has them; ``"BLEND"``, double-sided, clamped textures).
        normals: ``[Q, 3]`` float64 unit normals of the card planes (pointing to the side the
            bake looked from).
        offsets: ``[Q]`` float64 plane offsets ``d``: the plane is ``normals[q] . x = d[q]``.
        card_of_triangle: ``[T]`` int64 card each input triangle went to, -1 where it went to
            the kept mesh.
        notes: remarks for the report.
        kept: the number of triangles of the kept mesh, the last ones of ``asset`` (0: all cards).
        kept_distance: how far the kept mesh strays from the solid parts it stands for
            (``lookalike.init.surface_distance``, as ``InitialGuess.start_distance`` holds it),
            or ``None`` (all cards).
    """

    asset: Asset
    normals: np.ndarray
    offsets: np.ndarray
    card_of_triangle: np.ndarray
    notes: list[str] = field(default_factory=list)
    kept: int = 0
    kept_distance: dict | None = None


@dataclass
class CardPlanes:
    """The Q card planes, in coordinates relative to the asset's centre.

    Attributes:
        origin: ``[Q, 3]`` the cluster's area-weighted mean ``m`` (a point of the plane).
        axes: ``[Q, 3, 3]`` rows ``u, v, n``: a right-handed orthonormal frame, ``n`` the normal.
        low: ``[Q, 2]`` the quad's low corner in ``(u, v)`` coordinates about ``origin``.
        extent: ``[Q, 2]`` its sides along ``u`` and ``v`` (positive).
        depth: ``[Q]`` the largest ``|height|`` of a cluster vertex along ``n`` off the plane.
    """

    origin: np.ndarray
    axes: np.ndarray
    low: np.ndarray
    extent: np.ndarray
    depth: np.ndarray


def billboard_cloud(asset: Asset, triangles: int, texture_size: int, rng: np.random.Generator,
                    reserved: int = 0) -> CardCloud:
    """The billboard cloud of ``asset`` within a budget of ``triangles`` (see the module
    docstring).

    Args:
        asset: the input (its mesh as stored).
        triangles: the triangle budget; ``triangles // 2`` cards (fewer where the input has
            fewer triangles).
        texture_size: side S of the square atlas.
        rng: draws the k-means seeds.
        reserved: the atlas's top-left ``reserved x reserved`` texels hold no chart (they are
            left to a mesh kept beside the cards, ``lookalike.init.trunk_and_cards``); the
            textures there are the nearest charts' colours.
    Returns:
        ``CardCloud``.
    Raises:
        ConfigError: the budget allows no card, the texture size is not positive, the input has
            no triangles or no extent, the atlas cannot hold the cards, or nothing of the input
            is visible (all of it transparent).
    """
    cards = int(triangles) // 2
    if cards < 1:
        raise ConfigError(f"a billboard cloud needs at least 2 triangles (one card), got {triangles}")
    if isinstance(texture_size, bool) or not isinstance(texture_size, (int, np.integer)) or texture_size < 1:
        raise ConfigError(f"texture size must be a positive whole number, got {texture_size!r}")
    mesh = asset.mesh
    if mesh.num_triangles == 0:
        raise ConfigError("the input has no triangles to make cards of")
    v_pos = mesh.v_pos.detach().double().numpy()
    t_pos_idx = mesh.t_pos_idx.numpy()
    used = v_pos[t_pos_idx.reshape(-1)]
    centre = 0.5 * (used.min(axis=0) + used.max(axis=0))
    radius = float(np.linalg.norm(used - centre, axis=-1).max())
    if radius == 0:
        raise ConfigError("the input has no extent: all its vertices coincide")
    with phase("cluster cards"):
        moments = triangle_moments(v_pos[t_pos_idx] - centre)
        card, notes = cluster_triangles(moments, triangle_parts(v_pos, t_pos_idx), cards, rng)
        planes = fit_planes(moments, card)
        charts = pack_charts(planes.extent, texture_size, reserved)
    with phase("bake cards"):
        textures, bake_notes = bake_cards(asset, moments, card, planes, charts, texture_size)
    material = Material(name="lookalike", kd=Texture(textures["kd"], wrap="clamp"),
                        ks=Texture(textures["ks"], wrap="clamp"), normal=Texture(textures["normal"], wrap="clamp"),
                        emissive=Texture(textures["emissive"], wrap="clamp") if "emissive" in textures else None,
                        occlusion=Texture(textures["occlusion"], wrap="clamp") if "occlusion" in textures else None,
                        alpha_mode="BLEND", double_sided=True)
    normals = planes.axes[:, 2]
    start = Asset(mesh=card_mesh(planes, charts, texture_size, centre), materials=[material], source=asset.source)
    return CardCloud(asset=start, normals=normals, offsets=np.einsum("qd,qd->q", normals, planes.origin + centre),
                     card_of_triangle=card, notes=notes + bake_notes)


@dataclass
class TriangleMoments:
    """T triangles and their moments, float64.

    Attributes:
        corners: ``[T, 3, 3]`` corner positions (about the asset's centre).
        area: ``[T]``; normal: ``[T, 3]`` ``(p1 - p0) x (p2 - p0)`` normalised (zero where
            degenerate).
        second: ``[T, 3, 3]`` second moment ``E[x x^T]`` of a point uniform on the triangle,
            ``(sum_i p_i p_i^T + (sum_i p_i)(sum_i p_i)^T) / 12``.
    """

    corners: np.ndarray
    area: np.ndarray
    normal: np.ndarray
    second: np.ndarray


def triangle_moments(corners: np.ndarray) -> TriangleMoments:
    """The ``TriangleMoments`` of triangles ``corners [T, 3, 3]`` (float64)."""
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(cross, axis=-1)
    total = corners.sum(axis=1)
    second = (np.einsum("tci,tcj->tij", corners, corners) + total[:, :, None] * total[:, None, :]) / 12.0
    normal = cross / np.where(length > 0, length, 1.0)[:, None]
    return TriangleMoments(corners=corners, area=0.5 * length, normal=normal, second=second)


def element_weights(area: np.ndarray) -> np.ndarray:
    """``[N]`` positive clustering weights: the areas plus ``1e-9`` of their mean (all 1 where
    every area is zero), so a degenerate element still has a place."""
    mean = float(area.mean()) if len(area) else 0.0
    return area + 1e-9 * mean if mean > 0 else np.ones_like(area)


def orientation_features(normal: np.ndarray) -> np.ndarray:
    """``[N, 6]`` ``vec(n n^T)`` of unit normals ``normal [N, 3]``: ``(xx, yy, zz, sqrt2 xy,
    sqrt2 xz, sqrt2 yz)``, so Euclidean distances are Frobenius distances of the outer products."""
    x, y, z = normal.T
    root2 = math.sqrt(2.0)
    return np.stack([x * x, y * y, z * z, root2 * x * y, root2 * x * z, root2 * y * z], axis=1)


def cluster_features(position: np.ndarray, orientation: np.ndarray, weights: np.ndarray, groups: np.ndarray,
                     counts: np.ndarray) -> np.ndarray:
    """``[N, 9]`` k-means features ``((x - c_g) / s_g, ORIENTATION_WEIGHT * orientation)`` of N
    elements (module docstring): ``c_g`` the ``weights``-weighted mean of ``position [N, 3]`` over
    group ``g`` (``groups [N]``), ``s_g = R_g counts[g]^(-1/3)`` with ``R_g`` the group's largest
    distance from ``c_g`` (1 where that is 0); ``orientation [N, 6]`` from ``orientation_features``."""
    mass = np.bincount(groups, weights, len(counts))
    mean = np.stack([np.bincount(groups, weights * position[:, d], len(counts)) for d in range(3)], 1) / mass[:, None]
    offset = position - mean[groups]
    reach = np.zeros(len(counts))
    np.maximum.at(reach, groups, np.linalg.norm(offset, axis=-1))
    spacing = np.where(reach > 0, reach, 1.0) * np.asarray(counts, np.float64) ** (-1.0 / 3.0)
    return np.concatenate([offset / spacing[groups, None], ORIENTATION_WEIGHT * orientation], axis=1)


def smallest_per_group(groups: np.ndarray, key: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Indices of the ``counts[g]`` elements of smallest ``key`` in each group ``g`` (all of the
    group where it has fewer), sorted by group, then key (ties: lower index first).

    Args:
        groups: ``[N]`` int64 group of each element; key: ``[N]`` float; counts: ``[G]`` int.
    """
    order = np.lexsort((key, groups))
    sorted_groups = groups[order]
    rank = np.arange(len(order)) - np.searchsorted(sorted_groups, sorted_groups)
    return order[rank < np.asarray(counts)[sorted_groups]]


def seed_centres(features: np.ndarray, weights: np.ndarray, groups: np.ndarray, counts: np.ndarray,
                 rng: np.random.Generator) -> np.ndarray:
    """``[K, D]`` k-means++ seeds, ``K = sum(counts)``, cluster ``j`` of group ``g`` at row
    ``first[g] + j`` (``first`` the exclusive running sum of ``counts``).

    Each group's seeds come from a pool of at most ``SEED_POOL * counts[g]`` of its elements drawn
    without replacement with probability proportional to ``weights`` (Efraimidis-Spirakis: the
    smallest keys ``E / w``, ``E ~ Exp(1)``); the first seed is drawn from the pool by weight, each
    next one by weight times the squared distance to the nearest seed so far (the same race).
    Every group draws its ``j``-th seed in one vectorised pass.
    """
    group_size = np.bincount(groups, minlength=len(counts))
    pool = smallest_per_group(groups, rng.exponential(size=len(groups)) / weights,
                              np.minimum(SEED_POOL * counts, group_size))
    pool_group, pool_features, pool_weights = groups[pool], features[pool], weights[pool]
    start = np.searchsorted(pool_group, np.arange(len(counts)))          # pool is sorted by group
    first = np.cumsum(counts) - counts
    centres = np.empty((int(counts.sum()), features.shape[1]))
    score, nearest = pool_weights.copy(), np.full(len(pool), np.inf)
    for j in range(int(counts.max())):
        key = np.where(score > 0, rng.exponential(size=len(pool)) / np.where(score > 0, score, 1.0), np.inf)
        hit = np.flatnonzero(key == np.minimum.reduceat(key, start)[pool_group])
        chosen = hit[np.unique(pool_group[hit], return_index=True)[1]]     # [G] one per group
        active = np.flatnonzero(counts > j)
        centres[first[active] + j] = pool_features[chosen[active]]
        nearest = np.minimum(nearest, ((pool_features - pool_features[chosen[pool_group]]) ** 2).sum(axis=1))
        score = pool_weights * nearest
    return centres


def kmeans(features: np.ndarray, weights: np.ndarray, groups: np.ndarray, counts: np.ndarray,
           rng: np.random.Generator) -> np.ndarray:
    """Weighted k-means of N elements with ``counts[g]`` clusters in group ``g``, an element
    joining only clusters of its own group (module docstring).

    Groups are kept apart by one more feature, ``g * L`` with ``L`` more than any distance within
    a group (twice the norm of the features' largest magnitudes, plus one).

    Args:
        features: ``[N, D]`` float64; weights: ``[N]`` positive; groups: ``[N]`` int64
            ``0 .. G-1``; counts: ``[G]`` int64, ``1 <= counts[g] <=`` the group's size.
    Returns:
        ``[N]`` int64 cluster of each element, cluster ``j`` of group ``g`` numbered
        ``first[g] + j`` (``first`` the exclusive running sum of ``counts``). A cluster may end
        empty (where its group has fewer distinct elements than clusters, or the iterations ran
        out just after reseeding it).
    """
    apart = 2.0 * float(np.linalg.norm(np.abs(features).max(axis=0))) + 1.0
    features = np.concatenate([features, apart * groups[:, None].astype(np.float64)], axis=1)
    centres = seed_centres(features, weights, groups, counts, rng)
    centre_group = np.repeat(np.arange(len(counts)), counts)
    distance, label = cKDTree(centres).query(features)
    for _ in range(MAX_ITERATIONS):
        mass = np.bincount(label, weights, len(centres))
        sums = np.stack([np.bincount(label, weights * column, len(centres)) for column in features.T], axis=1)
        held = mass > 0
        centres = np.where(held[:, None], sums / np.where(held, mass, 1.0)[:, None], centres)
        empty = np.flatnonzero(~held)                                       # sorted by group
        if len(empty):
            far = smallest_per_group(groups, -weights * distance ** 2,
                                     np.bincount(centre_group[empty], minlength=len(counts)))
            centres[empty] = features[far]
        distance, nearest = cKDTree(centres).query(features)
        if np.array_equal(nearest, label):
            break
        label = nearest
    return label


def allocate_cards(area: np.ndarray, size: np.ndarray, cards: int) -> np.ndarray:
    """``[P]`` int64 cards per part, at least 1 and at most the part's ``size`` (triangle count),
    adding up to ``min(cards, sum(size))``: D'Hondt on ``area [P]``, ``k_p = clip(floor(A_p / q),
    1, size_p)`` with ``q`` the smallest divisor (bisection) for which they add up to at most
    ``cards``; the rest go one each to the parts of largest ``A_p / (k_p + 1)`` (ties: lower
    index). Needs ``P <= cards``."""
    size = np.asarray(size, np.int64)
    if size.sum() <= cards:
        return size
    area = np.maximum(np.asarray(area, np.float64), 1e-300)

    def seats(divisor: float) -> np.ndarray:
        return np.clip(np.floor(area / divisor), 1, size).astype(np.int64)

    low, high = float(area.min()) / (2.0 * (float(size.max()) + 1.0)), float(area.sum())   # seats: all, 1 each
    for _ in range(200):
        middle = math.sqrt(low * high)
        if not low < middle < high:
            break
        if seats(middle).sum() > cards:
            low = middle
        else:
            high = middle
    count = seats(high)
    rest = cards - int(count.sum())
    priority = np.where(count < size, area / (count + 1), -np.inf)
    count[np.argsort(-priority, kind="stable")[:rest]] += 1
    return count


def cluster_triangles(moments: TriangleMoments, parts: np.ndarray, cards: int,
                      rng: np.random.Generator) -> tuple[np.ndarray, list[str]]:
    """``([T] int64 card of each triangle, notes)``: the clustering of the module docstring.

    Args:
        moments: the T triangles; parts: ``[T]`` int64 part labels ``0 .. P-1``; cards: the
            budget ``Q``; rng: draws the k-means seeds.
    Cards are numbered ``0 .. Q'-1`` with no gap (``Q' < Q`` where the input has fewer
    triangles, or fewer distinct elements, than cards).
    """
    weights = element_weights(moments.area)
    centroid = moments.corners.mean(axis=1)
    orientation = orientation_features(moments.normal)
    count = int(parts.max()) + 1
    part_mass = np.bincount(parts, weights, count)
    divided = np.zeros(0, np.int64)
    if count > cards:
        position = np.stack([np.bincount(parts, weights * centroid[:, d], count) for d in range(3)], 1)
        shape = np.stack([np.bincount(parts, weights * orientation[:, d], count) for d in range(6)], 1)
        position, shape = position / part_mass[:, None], shape / part_mass[:, None]
        groups, counts = np.zeros(count, np.int64), np.array([cards])
        label = kmeans(cluster_features(position, shape, part_mass, groups, counts), part_mass, groups, counts, rng)
        card = label[parts]
    else:
        split = allocate_cards(part_mass, np.bincount(parts, minlength=count), cards)
        card = (np.cumsum(split) - split)[parts]
        divided = np.flatnonzero(split > 1)
        if len(divided):
            group_of_part = np.full(count, -1)
            group_of_part[divided] = np.arange(len(divided))
            members = np.flatnonzero(group_of_part[parts] >= 0)
            groups, counts = group_of_part[parts[members]], split[divided]
            label = kmeans(cluster_features(centroid[members], orientation[members], weights[members], groups, counts),
                           weights[members], groups, counts, rng)
            card[members] += label - (np.cumsum(counts) - counts)[groups]
    used, card = np.unique(card, return_inverse=True)
    made = f"{len(used)} card{'s' if len(used) > 1 else ''}"
    if count > cards:
        notes = [f"{made} over {count} parts: area-weighted k-means of the parts' positions and orientations"]
    elif count == 1 and len(divided):
        notes = [f"{made} over the triangles of the input's one part: k-means of their positions and orientations"]
    elif len(divided):
        notes = [(f"{made} over {count} parts: one per part, the spare ones to the largest parts (by area), "
                  f"{len(divided)} of them split by k-means of their triangles' positions and orientations")]
    else:
        notes = [f"one card per part ({count} part{'s' if count > 1 else ''})"]
    if len(used) < cards:
        notes.append(f"only {len(used)} of the {cards} cards the budget allows: the input has too few triangles "
                     "or distinct parts for more")
    return card.astype(np.int64), notes


def card_coordinates(corners: np.ndarray, card: np.ndarray, planes: CardPlanes) -> np.ndarray:
    """``[T, 3, 3]`` coordinates ``(u, v, height along n)`` of each triangle corner about its
    card's ``origin``, in its card's frame; ``corners [T, 3, 3]``, ``card [T]``."""
    return np.einsum("tcd,tkd->tck", corners - planes.origin[card][:, None], planes.axes[card])


def fit_planes(moments: TriangleMoments, card: np.ndarray) -> CardPlanes:
    """The card planes and quads of the clusters ``card [T]`` (``0 .. Q-1``, none empty) of the
    triangles ``moments`` (module docstring). A quad side shorter than ``MIN_SIDE`` of the longer
    one, or than ``1e-6`` of the asset's radius, is widened to that. Cost: ``ROTATIONS`` passes
    over the corners."""
    corners = moments.corners
    weights = element_weights(moments.area)
    count = int(card.max()) + 1
    mass = np.bincount(card, weights, count)

    def mean(values: np.ndarray) -> np.ndarray:
        """``[Q, ...]`` weighted mean over each card's triangles of ``values [T, ...]``."""
        flat = values.reshape(len(values), -1)
        sums = np.stack([np.bincount(card, weights * column, count) for column in flat.T], axis=1)
        return (sums / mass[:, None]).reshape((count,) + values.shape[1:])

    origin = mean(corners.mean(axis=1))
    covariance = mean(moments.second) - origin[:, :, None] * origin[:, None, :]
    vectors = np.linalg.eigh(covariance)[1]                                 # columns, eigenvalues ascending
    u, n = vectors[:, :, 2], vectors[:, :, 0]
    radius = float(np.linalg.norm(corners, axis=-1).max())
    side = (origin * n).sum(axis=1)
    outward = np.where(np.abs(side) > 1e-9 * radius, side, (mean(moments.normal) * n).sum(axis=1))
    n = np.where(outward[:, None] < 0, -n, n)
    planes = CardPlanes(origin=origin, axes=np.stack([u, np.cross(n, u), n], axis=1), low=np.zeros((count, 2)),
                        extent=np.zeros((count, 2)), depth=np.zeros(count))
    order = np.argsort(card, kind="stable")
    start = np.searchsorted(card[order], np.arange(count))

    def bounds(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per card ``(min [Q], max [Q])`` of ``values [T, 3]`` (corners, in ``order``)."""
        flat = values.reshape(-1)
        return np.minimum.reduceat(flat, 3 * start), np.maximum.reduceat(flat, 3 * start)

    local = card_coordinates(corners, card, planes)[order]
    smallest, turn = np.full(count, np.inf), np.zeros(count)
    for angle in np.arange(ROTATIONS) * (0.5 * math.pi / ROTATIONS):
        (a0, a1), (b0, b1) = (bounds(math.cos(angle) * local[..., 0] + math.sin(angle) * local[..., 1]),
                              bounds(math.cos(angle) * local[..., 1] - math.sin(angle) * local[..., 0]))
        area = (a1 - a0) * (b1 - b0)
        turn = np.where(area < smallest, angle, turn)
        smallest = np.minimum(area, smallest)
    cos, sin = np.cos(turn)[:, None], np.sin(turn)[:, None]
    u, v = cos * u + sin * planes.axes[:, 1], cos * planes.axes[:, 1] - sin * u
    planes.axes = np.stack([u, v, n], axis=1)
    local = card_coordinates(corners, card, planes)[order]
    low, high = np.stack([bounds(local[..., k]) for k in range(3)], axis=-1)                   # [Q, 3] each
    extent = high[:, :2] - low[:, :2]
    shortest = np.maximum(MIN_SIDE * extent.max(axis=1, keepdims=True), 1e-6 * radius)
    widen = np.maximum(shortest - extent, 0.0)
    planes.low, planes.extent = low[:, :2] - 0.5 * widen, extent + widen
    planes.depth = np.maximum(-low[:, 2], high[:, 2])
    return planes


def chart_sizes(extent: np.ndarray, scale: float) -> np.ndarray:
    """``[Q, 2]`` int64 chart sides in texels, ``max(1, ceil(scale * extent))``."""
    return np.maximum(np.ceil(extent * scale), 1).astype(np.int64)


def shelf_pack(sizes: np.ndarray, order: np.ndarray, size: int, reserved: int = 0) -> np.ndarray | None:
    """``[Q, 2]`` int64 (column, row) of each chart's top-left texel when the charts of ``sizes
    [Q, 2]`` (width, height) are placed in ``order`` left to right on shelves (a new shelf below
    the tallest chart of the last when a row is full) in a ``size x size`` image, ``CHART_GAP``
    texels between charts and half that at the border, the top-left ``reserved x reserved``
    texels left free (shelves that start above its bottom start right of it); ``None`` where
    they do not fit."""
    widths, heights = (sizes[:, 0] + CHART_GAP).tolist(), (sizes[:, 1] + CHART_GAP).tolist()
    place = [(0, 0)] * len(sizes)
    x, y, shelf = reserved, 0, 0
    half = CHART_GAP // 2
    for i in order.tolist():
        if x + widths[i] > size:
            y, shelf = y + shelf, 0
            x = reserved if y < reserved else 0
        if x + widths[i] > size and shelf == 0 and y < reserved:
            x, y = 0, reserved                                          # too wide beside the reserved square
        if x + widths[i] > size or y + heights[i] > size:
            return None
        place[i] = (x + half, y + half)
        x += widths[i]
        shelf = max(shelf, heights[i])
    return np.array(place, np.int64).reshape(-1, 2)


def pack_charts(extent: np.ndarray, size: int, reserved: int = 0) -> np.ndarray:
    """``[Q, 4]`` int64 charts ``(column, row, width, height)`` in texels of the cards of sides
    ``extent [Q, 2]`` (world units) in a ``size x size`` atlas whose top-left ``reserved x
    reserved`` texels stay free: ``chart_sizes`` at the largest ``scale`` for which
    ``shelf_pack`` (tallest first) fits them, found by bisection.

    Raises:
        ConfigError: not even 1-texel charts fit.
    """
    order = np.lexsort((np.arange(len(extent)), -extent[:, 1]))
    fit = shelf_pack(chart_sizes(extent, 0.0), order, size, reserved)
    if fit is None:
        raise ConfigError(f"a {size}x{size} texture cannot hold {len(extent)} cards with {CHART_GAP} texels "
                          "between them: raise the texture size or lower the triangle budget")
    low, high = 0.0, size / math.sqrt(float((extent[:, 0] * extent[:, 1]).sum()))   # high never fits
    for _ in range(40):
        middle = 0.5 * (low + high)
        place = shelf_pack(chart_sizes(extent, middle), order, size, reserved)
        if place is None:
            high = middle
        else:
            low, fit = middle, place
    return np.concatenate([fit, chart_sizes(extent, low)], axis=1)


def card_mesh(planes: CardPlanes, charts: np.ndarray, size: int, centre: np.ndarray) -> Mesh:
    """The quads of ``planes`` (moved back by ``centre [3]``) with their charts ``charts [Q, 4]``
    in UV set 0 of a ``size``-texel atlas: corners ``_CARD_CORNERS``, triangles
    ``_CARD_TRIANGLES``, ``u`` to the right and ``v`` up the chart."""
    sides = np.array(_CARD_CORNERS, np.float64)                                       # [4, 2]
    local = planes.low[:, None] + sides[None] * planes.extent[:, None]                  # [Q, 4, 2]
    v_pos = (centre + planes.origin[:, None] + local[..., :1] * planes.axes[:, None, 0]
             + local[..., 1:] * planes.axes[:, None, 1])
    uv = np.stack([charts[:, None, 0] + sides[None, :, 0] * charts[:, None, 2],
                   charts[:, None, 1] + (1.0 - sides[None, :, 1]) * charts[:, None, 3]], axis=-1) / size
    t_pos_idx = torch.from_numpy((4 * np.arange(len(charts))[:, None, None] + np.array(_CARD_TRIANGLES)).reshape(-1, 3))
    return Mesh(v_pos=torch.from_numpy(v_pos.reshape(-1, 3)).float(), t_pos_idx=t_pos_idx,
                uv=[(torch.from_numpy(uv.reshape(-1, 2)).float(), t_pos_idx.clone())])


def bake_cards(asset: Asset, moments: TriangleMoments, card: np.ndarray, planes: CardPlanes, charts: np.ndarray,
               size: int) -> tuple[dict[str, torch.Tensor], list[str]]:
    """The card atlas's textures by projecting each cluster along its card's normal (module
    docstring).

    Args:
        asset: the input; moments: its T triangles (about the asset's centre).
        card: ``[T]`` card of each triangle.
        planes, charts: the cards and their charts (``fit_planes``, ``pack_charts``).
        size: the atlas side S.
    Returns:
        ``({"kd": [S, S, 4], "ks": [S, S, 3], "normal": [S, S, 3], and "emissive" [S, S, 3],
        "occlusion" [S, S, 1] where the input has them}, notes)``, float32.
    Raises:
        ConfigError: no sample sees anything (the input is transparent all over).
    """
    local = card_coordinates(moments.corners, card, planes)
    chart, low, extent = charts[card][:, None], planes.low[card][:, None], planes.extent[card][:, None]
    column = chart[..., 0] + (local[..., 0] - low[..., 0]) / extent[..., 0] * chart[..., 2]
    row = chart[..., 1] + (low[..., 1] + extent[..., 1] - local[..., 1]) / extent[..., 1] * chart[..., 3]
    depth = np.where(planes.depth > 0, planes.depth, 1.0)[card][:, None]
    clip = np.stack([2.0 * column / size - 1.0, 2.0 * row / size - 1.0, -0.5 * local[..., 2] / depth,
                     np.ones_like(column)], axis=-1)                                   # nearest = highest
    pos = torch.from_numpy(clip.reshape(1, -1, 4).astype(np.float32))
    tri = torch.arange(3 * len(card)).reshape(-1, 3)
    step = planes.extent / (charts[:, 2:] * SUPERSAMPLES)                               # [Q, 2] world per sample
    footprint = torch.from_numpy(np.sqrt(step[:, 0] * step[:, 1])[card])
    facing = np.where((moments.normal * planes.axes[card, 2]).sum(axis=-1) < 0, -1.0, 1.0)
    to_card = torch.from_numpy(planes.axes[card] * facing[:, None, None]).float()   # [T, 3, 3] seen normal -> (u,v,n)
    surface = ReferenceSurface(asset)
    pixels = size * SUPERSAMPLES
    transmit = np.ones(pixels * pixels, np.float32)
    mass = np.zeros(pixels * pixels, np.float32)
    sums: dict[str, np.ndarray] = {}
    notes = []
    with dr.DepthPeeler(None, pos, tri, (pixels, pixels), grad_db=False) as peeler:
        for _ in range(MAX_LAYERS):
            rast = peeler.rasterize_next_layer()[0].reshape(-1, 4)
            seen = (rast[:, 3] > 0) & torch.isfinite(rast[:, :2]).all(dim=1)   # an edge-on triangle: no area, no hit
            pixel = np.flatnonzero(seen.numpy() & (transmit > TRANSMITTANCE_LEFT))
            if len(pixel) == 0:
                break
            found = rast[torch.from_numpy(pixel)]
            triangle = found[:, 3].long() - 1
            values = surface.sample(triangle, torch.stack([found[:, 0], found[:, 1], 1 - found[:, 0] - found[:, 1]], 1),
                                    footprint[triangle])
            alpha = values.kd[:, 3].numpy()
            weight = transmit[pixel] * alpha
            channels = {"kd": values.kd[:, :3], "ks": values.ks, "emissive": values.emissive,
                        "occlusion": values.occlusion,
                        "normal": torch.einsum("nij,nj->ni", to_card[triangle], values.normal)}
            for name, value in channels.items():
                if value is not None:
                    total = sums.setdefault(name, np.zeros((pixels * pixels, value.shape[1]), np.float32))
                    total[pixel] += weight[:, None] * value.numpy()
            mass[pixel] += weight
            transmit[pixel] *= 1.0 - alpha
        else:
            clear = int(((transmit > TRANSMITTANCE_LEFT) & (mass > 0)).sum())
            if clear:
                notes.append(f"the bake stopped after {MAX_LAYERS} depth layers, where {clear / (mass > 0).sum():.1%} "
                             "of the covered samples still saw through (deeper layers, if any, are left out)")

    def texels(values: np.ndarray) -> np.ndarray:
        """``[S*S, C]`` sums over each texel's samples of ``values [pixels^2, C]``."""
        grid = values.reshape(size, SUPERSAMPLES, size, SUPERSAMPLES, -1)
        return sum(grid[:, i, :, j] for i in range(SUPERSAMPLES) for j in range(SUPERSAMPLES)).reshape(size * size, -1)

    weight = texels(mass[:, None])[:, 0].astype(np.float64)
    covered = np.flatnonzero(weight > 0)
    if len(covered) == 0:
        raise ConfigError("nothing of the input shows on its cards: it is transparent all over")
    near_row, near_col = nearest_covered(covered // size, covered % size, size)
    nearest = (near_row * size + near_col).reshape(-1)
    held = np.where(weight > 0, weight, 1.0)[:, None]
    means = {name: (texels(total) / held)[nearest] for name, total in sums.items()}
    means["kd"] = np.concatenate([means["kd"], weight[:, None] / SUPERSAMPLES ** 2], axis=1)
    means["normal"] = to_unit_normal(means["normal"])
    textures = {name: torch.from_numpy(value.reshape(size, size, -1).astype(np.float32))
                for name, value in means.items()}
    return textures, notes
