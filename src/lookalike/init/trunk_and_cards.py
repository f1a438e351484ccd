"""The start of the ``cards`` application: the input's large solid parts (a trunk with its
branches, a pot) kept as a decimated mesh, and a billboard cloud (``lookalike.init.billboard_cloud``)
of the rest, in one asset with one material and one texture atlas.

Split. A part of the input (``lookalike.asset.parts``) is card-like when it is alpha-tested, or
an open surface that is small or thin (``card_like_parts``, the rule of the aggregate hint); the
other parts are solid. Cards show card-like parts well and solid ones badly: a trunk, one part
of thousands of triangles, becomes one card among the leaves, its bark smeared over the crown.

Budget. The solid parts keep ``k = floor(N sqrt(a t))`` of the ``N`` triangles, at most
``N / 2``: ``a`` their share of the input's area (what they show; leaves' cut-out cards have far
more area than a trunk) and ``t`` their share of its triangles (what their shape needs; a leaf is
two triangles, a trunk hundreds), the geometric mean so that neither share alone decides. ``k``
has the parity of ``N``, so that the cards (two triangles each) fill the rest exactly. Where ``k``
is under ``MIN_KEPT_TRIANGLES`` (too few for a solid shape), the input has no solid part or the
atlas is under twice ``MIN_KEPT_TEXELS`` across, everything is cards, exactly the billboard cloud.

Mesh. The solid parts are welded and decimated to ``k`` triangles (``lookalike.init.decimate``,
whose guard keeps every half free of shards) by halves, each time keeping only as many
connected parts as there are solid parts, those of
largest area (thin branching tubes decimated to a few dozen triangles at once fall apart into
floating pieces), unwrapped (``lookalike.init.unwrap``) into a square of
``r = ceil(S sqrt(a))`` texels (the atlas side ``S`` times the square root of their area share,
so they get the cards' texel density; at least ``MIN_KEPT_TEXELS``, at most ``S / 2``; doubled
while their charts do not fit, and where none fits up to ``S / 2``, everything is cards) and baked
by projection from the solid parts alone (``lookalike.init.projection_bake``): leaves behind
which the bark shows are on the cards already.

Atlas. The square is the atlas's top-left corner; the cloud packs its charts around it
(``billboard_cloud``'s ``reserved``). The two bakes are merged channel by channel (the kept mesh's
alpha 1; a channel only one side has takes its neutral value on the other: no emission, no
occlusion) into the cloud's material: ``"BLEND"``, double-sided, clamped. The mesh is the card
quads followed by the kept mesh; UV set 0 is the atlas.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from ..asset.asset import Asset
from ..asset.material import Material, Texture
from ..asset.mesh import Mesh
from ..asset.normals import crease_normal_index
from ..asset.parts import card_like_parts, survey_parts, triangle_parts
from ..errors import ConfigError
from ..phases import phase
from .billboard_cloud import CHART_GAP, CardCloud, billboard_cloud
from .decimate import decimate
from .projection_bake import bake
from .surface_distance import surface_distance
from .unwrap import unwrap
from .weld import weld_tolerance, weld_vertices

MIN_KEPT_TRIANGLES = 12
"""Fewest triangles the solid parts are kept as a mesh with: fewer cannot hold a solid shape (a
trunk as a prism), and the cards show it better."""

MIN_KEPT_TEXELS = 16
"""Shortest side, in texels, of the atlas square the kept mesh is baked into."""

_NEUTRAL = {"emissive": 0.0, "occlusion": 1.0}
"""Value of a channel where one of the merged bakes lacks it: no emission, no occlusion."""


def trunk_and_cards(asset: Asset, triangles: int, texture_size: int, rng: np.random.Generator) -> CardCloud:
    """The start of ``asset`` within ``triangles`` triangles and a ``texture_size`` atlas (module
    docstring): its solid parts as a mesh beside a billboard cloud of the rest, or the billboard
    cloud of it all.

    Args:
        asset: the input (its mesh as stored).
        triangles: the triangle budget ``N``; texture_size: side S of the square atlas.
        rng: draws the k-means seeds of the cloud.
    Returns:
        ``CardCloud`` whose ``kept`` last triangles are the kept mesh.
    Raises:
        ConfigError: as ``billboard_cloud``.
    """
    survey = survey_parts(asset)
    if (survey is None or isinstance(texture_size, bool) or not isinstance(texture_size, (int, np.integer))
            or texture_size < 2 * MIN_KEPT_TEXELS):
        return billboard_cloud(asset, triangles, texture_size, rng)
    solid_part = ~card_like_parts(survey)
    solid = solid_part[survey.part]
    area_share = float(survey.area[solid_part].sum() / max(survey.area.sum(), 1e-30))
    kept = kept_triangles(int(triangles), area_share, float(solid.mean()))
    if kept == 0:
        return billboard_cloud(asset, triangles, texture_size, rng)
    side = min(max(math.ceil(texture_size * math.sqrt(area_share)), MIN_KEPT_TEXELS), texture_size // 2)
    solid_asset, card_asset = triangle_subset(asset, solid), triangle_subset(asset, ~solid)
    with phase("kept mesh"):
        low, side = unwrapped_square(kept_mesh(solid_asset.mesh, kept, int(solid_part.sum())), side,
                                     texture_size // 2)
        if low is None:
            cloud = billboard_cloud(asset, triangles, texture_size, rng)
            cloud.notes.append(f"the solid parts were not kept as a mesh: its UV charts fit in no square of up to "
                               f"{texture_size // 2} texels (raise the texture size)")
            return cloud
        trunk = bake(solid_asset, low, side).material
    cloud = billboard_cloud(card_asset, int(triangles) - low.num_triangles, texture_size, rng, reserved=side)
    card_of_triangle = np.full(len(solid), -1, np.int64)
    card_of_triangle[~solid] = cloud.card_of_triangle
    start = Asset(mesh=joined_mesh(cloud.asset.mesh, low, side / texture_size),
                  materials=[merged_material(cloud.asset.materials[0], trunk, side)], source=asset.source)
    distance = surface_distance(solid_asset.mesh.v_pos.detach().double().numpy(), solid_asset.mesh.t_pos_idx.numpy(),
                                low.v_pos.detach().double().numpy(), low.t_pos_idx.numpy())
    return CardCloud(asset=start, normals=cloud.normals, offsets=cloud.offsets, card_of_triangle=card_of_triangle,
                     notes=[split_note(solid_part, int(solid.sum()), low.num_triangles, cloud)] + cloud.notes,
                     kept=low.num_triangles,
                     kept_distance={"of": "the solid parts kept as a mesh beside the cards",
                                    "triangles": low.num_triangles, **distance.as_dict()})


def split_note(solid_part: np.ndarray, solid_triangles: int, kept: int, cloud: CardCloud) -> str:
    """The report's line on the split: how many parts ``solid_part [P]`` (bool) were solid and
    kept as a mesh of ``kept`` triangles, and what the cards ``cloud`` made of the rest."""
    return (f"the solid parts ({int(solid_part.sum()):,} of {len(solid_part):,}, {solid_triangles:,} triangles) "
            f"kept as a mesh of {kept:,} triangles; {cloud.asset.mesh.num_triangles:,} triangles made "
            f"{len(cloud.normals):,} cards of the {int((~solid_part).sum()):,} alpha-tested or small or thin parts")


def kept_triangles(triangles: int, area_share: float, triangle_share: float) -> int:
    """Triangles of the ``triangles`` budget the solid parts keep, ``floor(N sqrt(a t))`` at
    most ``N / 2``, of ``N``'s parity, from their share ``a`` of the area and ``t`` of the
    triangles; 0 (all cards) where that is under ``MIN_KEPT_TRIANGLES`` (module docstring)."""
    kept = min(math.floor(triangles * math.sqrt(area_share * triangle_share)), triangles // 2)
    kept -= (triangles - kept) % 2
    return kept if kept >= MIN_KEPT_TRIANGLES else 0


def triangle_subset(asset: Asset, keep: np.ndarray) -> Asset:
    """``asset`` with only its triangles where ``keep [T]`` (bool), in order, and the vertices,
    UV rows and normal slots they use; materials, skin and source as they are."""
    mesh = asset.mesh.detach()
    select = torch.from_numpy(np.asarray(keep, bool))

    def compacted(index: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """The rows ``[U]`` that ``index [T', 3]`` uses and ``index`` renumbered to them."""
        used, inverse = torch.unique(index, return_inverse=True)
        return used, inverse.reshape(index.shape)

    rows, t_pos_idx = compacted(mesh.t_pos_idx[select])
    uv = [(v_tex[used], t_tex) for v_tex, t_tex_idx in mesh.uv for used, t_tex in [compacted(t_tex_idx[select])]]
    v_nrm = t_nrm_idx = None
    if mesh.t_nrm_idx is not None:
        slots, t_nrm_idx = compacted(mesh.t_nrm_idx[select])
        v_nrm = None if mesh.v_nrm is None else mesh.v_nrm[slots]

    def per_vertex(values: torch.Tensor | None) -> torch.Tensor | None:
        return None if values is None else values[rows]

    out = Mesh(v_pos=mesh.v_pos[rows], t_pos_idx=t_pos_idx, uv=uv, v_nrm=v_nrm, t_nrm_idx=t_nrm_idx,
               v_color=per_vertex(mesh.v_color), t_mat_idx=mesh.t_mat_idx[select],
               v_joints=per_vertex(mesh.v_joints), v_weights=per_vertex(mesh.v_weights))
    return Asset(mesh=out, materials=list(asset.materials), skin=asset.skin, source=asset.source)


def kept_mesh(solid: Mesh, triangles: int, parts: int) -> Mesh:
    """The positions and triangles of ``solid``, welded, decimated to ``triangles`` by halves,
    each time keeping only its ``parts`` connected parts of largest area (``largest_parts_of``),
    normal slots split at creases; nothing else: the atlas and the material come later.

    Decimating thin branching tubes to a few dozen triangles in one go breaks them into floating
    pieces and can lose the trunk itself; by halves, the pieces that come loose are dropped while
    they are small and the rest stays one mesh (where ``solid`` is ``parts`` connected parts).
    """
    v_pos = solid.v_pos.detach().double().numpy()
    w_pos, w_idx, _ = weld_vertices(v_pos, solid.t_pos_idx.numpy(), weld_tolerance(v_pos))
    low = Mesh(v_pos=torch.from_numpy(w_pos).float(), t_pos_idx=torch.from_numpy(w_idx))
    while low.num_triangles > triangles:
        smaller = largest_parts_of(decimate(low, max(triangles, low.num_triangles // 2)), parts)
        if smaller.num_triangles >= low.num_triangles:
            break
        low = smaller
    return Mesh(v_pos=low.v_pos, t_pos_idx=low.t_pos_idx, t_nrm_idx=crease_normal_index(low.v_pos, low.t_pos_idx))


def largest_parts_of(mesh: Mesh, parts: int) -> Mesh:
    """The positions and triangles of the ``parts`` connected parts of ``mesh`` of largest area
    (``lookalike.asset.parts.triangle_parts``), in order, unused vertices dropped."""
    v_pos, t_pos_idx = mesh.v_pos.detach().double().numpy(), mesh.t_pos_idx.numpy()
    label = triangle_parts(v_pos, t_pos_idx)
    corners = v_pos[t_pos_idx]
    area = np.bincount(label, 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0],
                                                               corners[:, 2] - corners[:, 0]), axis=1))
    chosen = np.zeros(len(area), bool)
    chosen[np.argsort(-area, kind="stable")[:parts]] = True
    used, index = np.unique(t_pos_idx[chosen[label]], return_inverse=True)
    return Mesh(v_pos=mesh.v_pos[torch.from_numpy(used)], t_pos_idx=torch.from_numpy(index.reshape(-1, 3)))


def unwrapped_square(mesh: Mesh, side: int, largest: int) -> tuple[Mesh | None, int]:
    """``(mesh unwrapped, side)`` into the smallest square of ``side`` texels, doubled up to
    ``largest``, that holds its atlas (``unwrap`` with ``CHART_GAP`` texels of padding), or
    ``(None, largest)`` where none does: a mesh of many small charts needs room for their gaps."""
    while True:
        try:
            return unwrap(mesh, int(side), padding=CHART_GAP), int(side)
        except ConfigError:
            if side >= largest:
                return None, int(largest)
            side = min(2 * side, largest)


def joined_mesh(cards: Mesh, kept: Mesh, scale: float) -> Mesh:
    """The card quads ``cards`` followed by ``kept``, its UV set 0 scaled by ``scale`` into the
    atlas's top-left square; each card's 4 vertices one smooth normal slot each, ``kept``'s slots
    after them."""
    corners = cards.num_vertices
    (card_tex, card_tex_idx), (kept_tex, kept_tex_idx) = cards.uv[0], kept.uv[0]
    t_pos_idx = torch.cat([cards.t_pos_idx, kept.t_pos_idx + corners])
    t_tex_idx = torch.cat([card_tex_idx, kept_tex_idx + len(card_tex)])
    return Mesh(v_pos=torch.cat([cards.v_pos, kept.v_pos.float()]), t_pos_idx=t_pos_idx,
                uv=[(torch.cat([card_tex, kept_tex * scale]), t_tex_idx)],
                t_nrm_idx=torch.cat([cards.t_pos_idx, kept.t_nrm_idx + corners]))


def merged_material(cards: Material, kept: Material, side: int) -> Material:
    """``cards``' material with ``kept``'s textures ``[side, side, C]`` in the top-left square of
    each channel, the kept mesh's alpha 1 (module docstring)."""
    size = cards.kd.data.shape[0]
    channels = {}
    for name in ("kd", "ks", "normal", "emissive", "occlusion"):
        atlas, square = getattr(cards, name), getattr(kept, name)
        if atlas is None and square is None:
            continue
        data = (atlas.data.clone() if atlas is not None
                else torch.full((size, size, square.data.shape[-1]), _NEUTRAL[name], dtype=square.data.dtype))
        data[:side, :side] = square.data if square is not None else _NEUTRAL[name]
        channels[name] = Texture(data, wrap="clamp")
    channels["kd"].data[:side, :side, 3] = 1.0
    return Material(name=cards.name, alpha_mode=cards.alpha_mode, double_sided=cards.double_sided, **channels)
