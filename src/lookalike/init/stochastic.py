"""Stochastic simplification of aggregate detail (Cook, Halstead, Planck and Ryu 2007,
"Stochastic Simplification of Aggregate Detail", ACM Transactions on Graphics 26(3)), the
baseline the paper's supplement compares its aggregate-geometry results with, done as the
supplement does it.

The aggregate's elements are the mesh's disjoint parts (``lookalike.asset.parts``). A random
share lambda of them is kept and the rest removed. Each kept part is scaled uniformly about its
area-weighted centroid m (A_t the area and c_t the centroid of its triangle t),

    x' = m + sqrt(1 / lambda) (x - m),    m = sum_t A_t c_t / sum_t A_t,

so that its area grows by 1 / lambda and the aggregate's total area is preserved (in
expectation); and as fewer, larger elements show more variance than many small ones, the
contrast of their materials' base colour is reduced,

    c' = mu + sqrt(lambda) (c - mu),

mu the mean colour of the material's opaque texels (alpha >= cutoff for ``MASK``, weighted by
alpha for ``BLEND``, every texel for ``OPAQUE``; every texel where none is opaque); alpha is kept.

Large solid parts (the trunk and branches of a plant) are not elements of the aggregate. A part
is *solid* when

- it uses only opaque materials while other parts use alpha (``MASK`` or ``BLEND``): the bark
  of a plant whose leaves are alpha-textured, however thin the twig; or
- its triangle count or its area exceeds ``SOLID_FACTOR`` times the median over all parts (the
  median part being a typical element: a leaf), for aggregates of opaque elements.

Solid parts are kept as they are and their triangles taken off the budget. The other (small)
parts are visited in a random order and kept while their running triangle count stays within
what is left (at least one is kept): lambda = kept / small parts. An asset of solid parts only
that fits the budget is returned whole.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import torch

from ..asset import Asset, Material, Mesh
from ..asset.parts import triangle_parts
from ..errors import ConfigError

SOLID_FACTOR = 4.0


def part_statistics(v_pos: np.ndarray, t_pos_idx: np.ndarray,
                    label: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Triangle count ``[P]``, area ``[P]`` and area-weighted centroid ``[P, 3]`` of each part,
    for positions ``v_pos [V, 3]``, triangles ``t_pos_idx [T, 3]`` and part labels ``label [T]``
    (``0 .. P - 1``). A part of zero area gets the mean of its triangles' centroids."""
    corners = v_pos[t_pos_idx]                                             # [T, 3, 3]
    area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    centre = corners.mean(axis=1)
    count = np.bincount(label)
    part_area = np.bincount(label, weights=area, minlength=len(count))
    weight = np.where(part_area[label] > 0, area, 1.0)
    centroid = np.stack([np.bincount(label, weights=weight * centre[:, k], minlength=len(count)) for k in range(3)], axis=1)
    centroid /= np.bincount(label, weights=weight, minlength=len(count))[:, None]
    return count, part_area, centroid


def solid_parts(count: np.ndarray, area: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """``[P]`` bool, the solid parts (module docstring) of parts with triangle counts
    ``count [P]``, areas ``area [P]`` and ``alpha [P]`` (bool: uses a material with alpha)."""
    return ((~alpha & alpha.any()) | (count > SOLID_FACTOR * np.median(count))
            | (area > SOLID_FACTOR * np.median(area)))


def pulled_contrast(material: Material, share: float) -> Material:
    """A copy of ``material`` whose base colour RGB is ``mu + sqrt(share) (c - mu)``, ``mu [3]``
    the mean colour of its opaque texels (see the module docstring), alpha unchanged; other
    channels are shared with ``material``, the base colour's prefiltered mips dropped."""
    kd = material.kd.data.detach()
    rgb, alpha = kd[..., :3].double(), kd[..., 3:].double()
    if material.alpha_mode == "MASK":
        weight = (alpha >= material.alpha_cutoff).double()
    elif material.alpha_mode == "BLEND":
        weight = alpha
    else:
        weight = torch.ones_like(alpha)
    if weight.sum() == 0:
        weight = torch.ones_like(alpha)
    mu = (rgb * weight).sum(dim=(0, 1)) / weight.sum()
    data = torch.cat([(mu + share ** 0.5 * (rgb - mu)).to(kd.dtype), kd[..., 3:]], dim=-1)
    return replace(material, kd=replace(material.kd, data=data, mips=None))


def drawn_parts(count: np.ndarray, candidates: np.ndarray, budget: int,
                rng: np.random.Generator) -> tuple[np.ndarray, float]:
    """``(parts [K], lambda)``: the ``candidates`` (part indices) visited in a random order and
    kept while their running triangle count (``count [P]``) stays within ``budget`` (at least
    one is kept), and the share lambda of the candidates kept (1 without candidates)."""
    order = rng.permutation(candidates)
    kept = min(len(order), max(1, int((np.cumsum(count[order]) <= budget).sum())))
    return order[:kept], kept / len(order) if len(order) else 1.0


def enlarge_parts(v_pos: np.ndarray, t_pos_idx: np.ndarray, label: np.ndarray, centroid: np.ndarray,
                  moved: np.ndarray, share: float) -> None:
    """Scale, in place in ``v_pos [V, 3]``, the vertices of the triangles where ``moved [T]``
    about their part's centroid (``centroid [P, 3]``, ``label [T]``) by ``sqrt(1 / share)``,
    so that kept parts make up the area of the ``1 / share`` times as many they stand for."""
    vertex_part = np.full(len(v_pos), -1)
    vertex_part[t_pos_idx[moved].reshape(-1)] = np.repeat(label[moved], 3)
    inside = vertex_part >= 0
    m = centroid[vertex_part[inside]]
    v_pos[inside] = m + (1 / share) ** 0.5 * (v_pos[inside] - m)


def _compacted(index: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """The rows ``[U]`` (ascending) of a table that ``index [T', 3]`` uses, and ``index``
    renumbered to them."""
    used, inverse = torch.unique(index, return_inverse=True)
    return used, inverse.reshape(index.shape)


def stochastic_simplification(asset: Asset, triangles: int, rng: np.random.Generator) -> Asset:
    """``asset`` stochastically simplified to about ``triangles`` triangles (at most, unless one
    small part alone exceeds the budget), as the module docstring describes; ``rng`` picks the
    kept parts.

    The result keeps the kept triangles in their order and only the vertices, UV rows and normal
    slots they use, the skin, animations and source of ``asset``, and its materials list with
    each material of the kept small parts replaced by its ``pulled_contrast`` copy, or, where
    kept solid parts use it too, that copy appended for the small parts. ``asset`` is not changed.
    Raises ``ConfigError`` when the solid parts alone have ``triangles`` or more.
    """
    mesh = asset.mesh.detach()
    v_pos = mesh.v_pos.numpy().astype(np.float64)  # a copy: moved below
    t_pos_idx = mesh.t_pos_idx.numpy()
    label = triangle_parts(v_pos, t_pos_idx)
    count, area, centroid = part_statistics(v_pos, t_pos_idx, label)
    t_mat_idx = mesh.t_mat_idx.numpy()
    uses_alpha = np.array([m.uses_alpha for m in asset.materials])[t_mat_idx]
    solid = solid_parts(count, area, np.bincount(label, weights=uses_alpha, minlength=len(count)) > 0)
    budget = triangles - int(count[solid].sum())
    if budget <= 0:
        raise ConfigError(f"stochastic simplification to {triangles} triangles leaves none for the aggregate: "
                          f"its solid parts ({int(solid.sum())}, kept whole) alone have {int(count[solid].sum())} triangles")

    drawn, share = drawn_parts(count, np.flatnonzero(~solid), budget, rng)
    keep = solid.copy()
    keep[drawn] = True
    tri_small = ~solid[label] & keep[label]                               # [T] kept triangles of small parts
    tri_kept = solid[label] | tri_small
    enlarge_parts(v_pos, t_pos_idx, label, centroid, tri_small, share)

    materials = list(asset.materials)
    remap = np.arange(len(materials))
    for index in np.unique(t_mat_idx[tri_small]):
        pulled = pulled_contrast(asset.materials[index], share)
        if (t_mat_idx[solid[label]] == index).any():
            remap[index] = len(materials)
            materials.append(pulled)
        else:
            materials[index] = pulled
    t_mat_idx = np.where(tri_small, remap[t_mat_idx], t_mat_idx)[tri_kept]

    select = torch.from_numpy(tri_kept)
    rows, t_new = _compacted(mesh.t_pos_idx[select])
    uv = []
    for v_tex, t_tex_idx in mesh.uv:
        tex_rows, t_tex = _compacted(t_tex_idx[select])
        uv.append((v_tex[tex_rows], t_tex))
    v_nrm, t_nrm_idx = mesh.v_nrm, mesh.t_nrm_idx
    if t_nrm_idx is not None:
        slots, t_nrm_idx = _compacted(t_nrm_idx[select])
        v_nrm = None if v_nrm is None else v_nrm[slots]

    def per_vertex(x: torch.Tensor | None) -> torch.Tensor | None:
        return None if x is None else x[rows]

    out = Mesh(v_pos=torch.from_numpy(v_pos).to(mesh.v_pos.dtype)[rows], t_pos_idx=t_new, uv=uv,
               v_nrm=v_nrm, t_nrm_idx=t_nrm_idx, v_color=per_vertex(mesh.v_color),
               t_mat_idx=torch.from_numpy(t_mat_idx), v_joints=per_vertex(mesh.v_joints),
               v_weights=per_vertex(mesh.v_weights))
    return Asset(mesh=out, materials=materials, skin=asset.skin, animations=list(asset.animations), source=asset.source)
