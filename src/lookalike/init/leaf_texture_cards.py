"""A start of the ``cards`` application for an input that is already cards: its own leaf texture
kept, at its own resolution, on fewer and larger leaf quads.

Game foliage is made of alpha-tested quads that share one leaf texture, on a low-poly bark. A
billboard cloud bakes those leaves anew into an atlas whose texels are spread over every card, a
lower texel density than the input's texture; plain decimation of such an input keeps the
texture whole and draws sharper leaf edges. This start keeps it too:

- the solid parts (``lookalike.asset.parts.card_like_parts``'s rule: the bark) are decimated to
  ``k`` triangles (``lookalike.init.trunk_and_cards.kept_triangles``, the billboard cloud's
  budget), their own materials and UVs carried over (``lookalike.init.decimate``);
- the leaf quads are thinned, as stochastic simplification thins an aggregate
  (``lookalike.init.stochastic``), to a share ``lambda`` of them within the rest of the budget,
  each enlarged about its centroid, its area by ``(1 / lambda)^LEAF_GROWTH``; but where that
  draws them at random, these are spread over the crown (``spread_parts``: the leaf nearest
  each centre of a k-means clustering of the leaves' centroids), so that the thinned crown has
  no chance gaps or clumps.
  Their UVs and material are the input's: no texel is baked (the fit,
  ``lookalike.fit.tinted_mesh``, adds one colour tint per material).

It applies where every card-like part uses one alpha-textured material (``leaf_material``);
``cards`` offers it beside the billboard cloud and keeps whichever scores higher on the
validation views as written (``jobs.run.take_best_start``).
"""

from __future__ import annotations

import numpy as np
import torch

from ..asset.asset import Asset
from ..asset.mesh import Mesh
from ..asset.normals import crease_normal_index
from ..asset.parts import card_like_parts, survey_parts
from .decimate import decimate
from scipy.cluster.vq import kmeans2

from .stochastic import enlarge_parts, part_statistics
from .trunk_and_cards import kept_triangles, triangle_subset

LEAF_TEXTURE_START = "the input's leaf texture on fewer, larger leaf quads"
"""The label of this start in the run's notes and report."""

LEAF_GROWTH = 0.25
"""The exponent of a kept leaf's growth in area, ``(1 / lambda)^LEAF_GROWTH``. Stochastic
simplification's 1 keeps the leaves' total area, but a crown's leaves overlap, so its coverage
does not grow with their area, and an enlarged quad at the crown's edge bloats its outline
(``docs/benchmarks.md``)."""


def leaf_material(asset: Asset, card_triangles: np.ndarray) -> int | None:
    """The index of the one material that every card-like triangle (``card_triangles [T]``
    bool) uses, where it is alpha-tested or blended and its base colour a texture; else
    ``None``."""
    used = np.unique(asset.mesh.t_mat_idx.numpy()[card_triangles])
    if len(used) != 1:
        return None
    material = asset.materials[int(used[0])]
    textured = material.kd.data.shape[0] * material.kd.data.shape[1] > 1
    return int(used[0]) if material.uses_alpha and textured and asset.mesh.uv else None


def leaf_texture_cards(asset: Asset, triangles: int, rng: np.random.Generator) -> Asset | None:
    """The start of ``asset`` within ``triangles`` triangles that keeps its leaf texture (module
    docstring): the decimated solid parts followed by the kept, enlarged leaf quads, the input's
    materials as they are; ``None`` where it does not apply (no card-like part, leaves of several
    materials or of an untextured one, or a budget that leaves the solid parts too few triangles
    or the leaves none). ``rng`` draws the kept leaves."""
    survey = survey_parts(asset)
    if survey is None:
        return None
    card_part = card_like_parts(survey)
    cards = card_part[survey.part]
    if not cards.any() or leaf_material(asset, cards) is None:
        return None
    pieces = []
    if not cards.all():
        area_share = float(survey.area[~card_part].sum() / max(survey.area.sum(), 1e-30))
        kept = kept_triangles(int(triangles), area_share, float((~cards).mean()))
        if kept == 0:
            return None
        solid = triangle_subset(asset, ~cards).mesh
        low = decimate(solid, kept) if kept < solid.num_triangles else solid
        pieces.append(Mesh(v_pos=low.v_pos, t_pos_idx=low.t_pos_idx, uv=low.uv, t_mat_idx=low.t_mat_idx,
                           t_nrm_idx=crease_normal_index(low.v_pos, low.t_pos_idx)))
    budget = int(triangles) - sum(piece.num_triangles for piece in pieces)
    if budget < 1:
        return None
    leaves = triangle_subset(asset, cards).mesh
    v_pos, t_pos_idx = leaves.v_pos.detach().double().numpy().copy(), leaves.t_pos_idx.numpy()
    label = survey.part[cards]
    parts, label = np.unique(label, return_inverse=True)
    count, _, centroid = part_statistics(v_pos, t_pos_idx, label)
    keep = spread_parts(centroid, count, budget, rng)
    enlarge_parts(v_pos, t_pos_idx, label, centroid, keep[label], (keep.sum() / len(keep)) ** LEAF_GROWTH)
    moved = Asset(mesh=Mesh(v_pos=torch.from_numpy(v_pos).float(), t_pos_idx=leaves.t_pos_idx, uv=leaves.uv,
                            t_mat_idx=leaves.t_mat_idx), materials=asset.materials)
    pieces.insert(0, triangle_subset(moved, keep[label]).mesh)
    return Asset(mesh=joined_meshes(pieces), materials=list(asset.materials), source=asset.source)


def spread_parts(centroid: np.ndarray, count: np.ndarray, budget: int, rng: np.random.Generator) -> np.ndarray:
    """``[P]`` bool: the parts kept of ``P`` with centroids ``centroid [P, 3]`` and triangle
    counts ``count [P]``, within ``budget`` triangles (at least one): ``K = budget // median
    count`` k-means centres of the centroids (k-means++ seeds drawn from ``rng``), and of each
    cluster the part nearest its centre, while their running triangle count fits the budget.
    Spread so, a thinned crown draws closer to the input than one drawn at random
    (``docs/benchmarks.md``)."""
    clusters = min(len(count), max(1, budget // max(int(np.median(count)), 1)))
    keep = np.zeros(len(count), bool)
    if clusters == len(count):
        keep[:] = True
    else:
        centres, cluster = kmeans2(centroid, clusters, minit="++", seed=rng)
        distance = ((centroid - centres[cluster]) ** 2).sum(axis=1)
        order = np.lexsort((distance, cluster))                       # by cluster, nearest first
        first = order[np.r_[True, cluster[order][1:] != cluster[order][:-1]]]
        keep[first] = True
    chosen = np.flatnonzero(keep)
    over = np.cumsum(count[chosen]) > budget
    over[0] = False                                                  # at least one
    keep[chosen[over]] = False
    return keep


def joined_meshes(meshes: list[Mesh]) -> Mesh:
    """``meshes`` as one mesh, in order: positions, UV sets (each must have as many), normal
    slots (one per position where a mesh has none) and material indices, each index offset by
    the rows before it; authored normals, vertex colours and skins are not carried."""
    offset = {"pos": 0, "nrm": 0, "tex": [0] * len(meshes[0].uv)}
    v_pos, t_pos, t_nrm, t_mat = [], [], [], []
    v_tex = [[] for _ in meshes[0].uv]
    t_tex = [[] for _ in meshes[0].uv]
    for mesh in meshes:
        if len(mesh.uv) != len(v_tex):
            raise ValueError("joined meshes must have as many UV sets")
        slots = mesh.t_pos_idx if mesh.t_nrm_idx is None else mesh.t_nrm_idx
        v_pos.append(mesh.v_pos.detach().float())
        t_pos.append(mesh.t_pos_idx + offset["pos"])
        t_nrm.append(slots + offset["nrm"])
        t_mat.append(mesh.t_mat_idx)
        for k, (coords, index) in enumerate(mesh.uv):
            v_tex[k].append(coords)
            t_tex[k].append(index + offset["tex"][k])
            offset["tex"][k] += len(coords)
        offset["pos"] += mesh.num_vertices
        offset["nrm"] += int(slots.max()) + 1 if slots.numel() else 0
    return Mesh(v_pos=torch.cat(v_pos), t_pos_idx=torch.cat(t_pos),
                uv=[(torch.cat(c), torch.cat(i)) for c, i in zip(v_tex, t_tex)],
                t_nrm_idx=torch.cat(t_nrm), t_mat_idx=torch.cat(t_mat))
