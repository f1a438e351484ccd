"""``shrub``: a seeded procedural shrub (a small tree of tapered branches carrying several
thousand alpha-tested leaves, about 200k triangles), the aggregate-geometry asset of the
``cards`` application (paper, Sec. 5.4), generated in code.

Frame: glTF, +Y up, the foot of the trunk at the origin; at the end every position is scaled by
``HEIGHT / max y``, so the shrub stands on y = 0 and is ``HEIGHT`` tall.

Branches. Each branch is a quadratic Bezier curve b(t) = (1 - t)^2 p0 + 2 t (1 - t) p1 + t^2 p2,
t in [0, 1], swept by a circle of radius r(t) = r0 (1 - (1 - TIP_TAPER) t) on a ``RINGS x SIDES``
grid (two triangles per cell, positions welded around the seam, both ends open), in the frame
side = T x ref / |T x ref|, up = T x side of its unit tangent T and a fixed ref perpendicular to
its chord p2 - p0. The trunk rises vertically from the origin (so its foot ring lies in y = 0) and
leans at its top; ``branches`` main branches leave its upper part at jittered, evenly spread
azimuths, ``MAIN_ELEVATION`` above the horizontal, with p1 ``BEND`` lower than p2, so that they
curve upwards; each carries ``SUB_BRANCHES`` sub-branches from its middle, alternately to its left
and right. A child's r0 is ``CHILD_RADIUS`` times its parent's r(t) where it starts. Bark UVs:
u = theta / 2 pi around, v = t |p2 - p0| / (2 pi r0) along (one circumference per texture
height), on a tiling bark texture. The grid is coarse (the branches are mostly hidden by the
leaves), so that all branches, which stochastic simplification keeps whole
(``lookalike.init.stochastic``), fit in 0.3 % of the triangles, below the smallest budget of
``lookalike bench cards`` (0.5 %).

Leaves. A leaf is a ``LEAF_ROWS x LEAF_COLS`` grid of cells over the rectangle a in [-1, 1]
across, s in [0, 1] from base to tip, bent in its own frame (x across, y along, z its normal):
(x, y, z) = (a W / 2, s L, bend L s^2 + curl (W / 2) a^2), a droop along the leaf and a V-fold
about its midrib. Its base sits on a branch at t = LEAF_START + (1 - LEAF_START) sqrt(xi) (leaves
thicken towards the ends) offset uniformly within a ball of radius ``TWIG`` (the twigs are not
modelled); it points along d = |OUTWARD o + UPWARD e_y + ALONG T + JITTER g| (o the horizontal
direction away from the trunk, g ~ N(0, I)), its normal is the upward direction e_y projected
perpendicular to d, rolled about d by an angle ~ N(0, ROLL). Each leaf has vertices of its own
(one part per leaf, ``lookalike.asset.parts``) and UVs onto one cell of a 2 x 2 atlas of leaf
variants whose alpha is the leaf's outline (blade and stalk) and whose colour has a light midrib,
secondary veins, darker rims and a faint mottle: the leaf material is alpha-tested (``MASK``,
cutoff 0.5) and double-sided, the bark opaque and rough.
"""

from __future__ import annotations

import numpy as np
import torch

from ..asset import Asset, Material, Mesh, Texture
from ..colour import srgb_decode

LEAVES = 4000
BRANCHES = 5
SUB_BRANCHES = 2
HEIGHT = 1.0

RINGS, SIDES = 3, 6                         # 36 triangles per branch: 576 in all, 0.3 % of the shrub
TRUNK_HEIGHT, TRUNK_RADIUS, TRUNK_LEAN = 0.4, 0.035, 0.04
MAIN_LENGTH = 0.5
MAIN_START = (0.6, 1.0)                     # where on the trunk main branches leave (t)
MAIN_ELEVATION = np.radians((30.0, 60.0))
BEND = np.radians(20.0)
SUB_START = (0.35, 0.75)                    # where on a main branch sub-branches leave (t)
SUB_LENGTH, SUB_SPREAD, SUB_RISE = 0.5, 0.8, 0.35
CHILD_RADIUS = 0.6
TIP_TAPER = 0.3

LEAF_ROWS, LEAF_COLS = 6, 4                 # 48 triangles per leaf
LEAF_LENGTH, LEAF_ASPECT, LEAF_SIZE_SPREAD = 0.09, 0.55, 0.2
LEAF_BEND, LEAF_CURL = (-0.35, 0.1), (0.0, 0.3)
LEAF_START, TWIG = 0.35, 0.06
OUTWARD, UPWARD, ALONG, JITTER, ROLL = 0.8, 0.5, 0.5, 0.45, 0.6

LEAF_TEXTURE, BARK_TEXTURE = 512, 256
# leaf variants of the 2 x 2 atlas, cell k = 2 row + col: sRGB blade colour, where along the blade
# it is widest, its largest half-width (in a), depth of its serration
VARIANTS = (((0.32, 0.52, 0.17), 0.45, 0.85, 0.0),
            ((0.22, 0.40, 0.13), 0.55, 0.70, 0.0),
            ((0.42, 0.56, 0.18), 0.40, 0.95, 0.08),
            ((0.27, 0.46, 0.21), 0.50, 0.60, 0.05))
VEIN_SRGB = (0.62, 0.72, 0.40)
BLADE = (0.12, 0.97)                        # the blade's span in s; the stalk runs below it
STALK, STALK_WIDTH = 0.02, 0.04
MIDRIB, VEINS, VEIN_WIDTH, SERRATIONS = 0.035, 9, 0.07, 14
BARK_SRGB = (0.36, 0.27, 0.19)
BARK_WAVES = ((5, 2, 0.1), (11, 3, 0.6), (23, 5, 0.3))   # furrows: cycles around, wiggles along, phase
LEAF_ROUGHNESS, BARK_ROUGHNESS = 0.5, 0.85


def bezier(ctrl: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points ``[..., 3]`` and unit tangents ``[..., 3]`` of quadratic Bezier curves with control
    points ``ctrl [..., 3, 3]`` (p0, p1, p2) at parameters ``t [...]`` (broadcast together)."""
    w = np.stack([(1 - t) ** 2, 2 * t * (1 - t), t ** 2], axis=-1)[..., None]
    dw = np.stack([2 * t - 2, 2 - 4 * t, 2 * t], axis=-1)[..., None]
    tangent = (dw * ctrl).sum(-2)
    return (w * ctrl).sum(-2), tangent / np.linalg.norm(tangent, axis=-1, keepdims=True)


def unit(x: np.ndarray) -> np.ndarray:
    """Rows of ``x [..., 3]`` scaled to unit length."""
    return x / np.linalg.norm(x, axis=-1, keepdims=True)


def direction(azimuth: np.ndarray, elevation: np.ndarray) -> np.ndarray:
    """Unit vectors ``[N, 3]`` at ``azimuth [N]`` about +Y and ``elevation [N]`` above y = 0."""
    return np.stack([np.cos(elevation) * np.cos(azimuth), np.sin(elevation),
                     np.cos(elevation) * np.sin(azimuth)], axis=-1)


def skeleton(rng: np.random.Generator, branches: int = BRANCHES) -> tuple[np.ndarray, np.ndarray]:
    """Control points ``[B, 3, 3]`` and base radii ``[B]`` of the trunk (row 0), the main
    branches (rows ``1 .. branches``) and their sub-branches; ``B = 1 + branches (1 + SUB_BRANCHES)``."""
    lean = rng.normal(0.0, TRUNK_LEAN, 2)
    trunk = np.array([[0.0, 0.0, 0.0], [0.0, TRUNK_HEIGHT / 2, 0.0], [lean[0], TRUNK_HEIGHT, lean[1]]])

    t = rng.uniform(*MAIN_START, branches)
    azimuth = 2 * np.pi * (np.arange(branches) + rng.uniform(-0.3, 0.3, branches)) / branches + rng.uniform(0, 2 * np.pi)
    elevation = rng.uniform(*MAIN_ELEVATION, branches)
    length = MAIN_LENGTH * rng.uniform(0.8, 1.2, branches)[:, None]
    p0, _ = bezier(trunk, t)
    main = np.stack([p0, p0 + 0.5 * length * direction(azimuth, elevation - BEND),
                     p0 + length * direction(azimuth, elevation)], axis=1)
    main_radius = CHILD_RADIUS * TRUNK_RADIUS * (1 - (1 - TIP_TAPER) * t)

    parent = np.repeat(np.arange(branches), SUB_BRANCHES)
    t = rng.uniform(*SUB_START, len(parent))
    q0, tangent = bezier(main[parent], t)
    side = (-1.0) ** np.arange(len(parent))[:, None] * unit(np.cross(tangent, [0.0, 1.0, 0.0]))
    start = unit(tangent + SUB_SPREAD * side + 0.2 * rng.normal(size=(len(parent), 3)))
    end = unit(start + SUB_RISE * np.array([0.0, 1.0, 0.0]))
    length = SUB_LENGTH * np.linalg.norm(main[parent, 2] - main[parent, 0], axis=1)[:, None]
    sub = np.stack([q0, q0 + 0.5 * length * start, q0 + length * end], axis=1)
    sub_radius = CHILD_RADIUS * main_radius[parent] * (1 - (1 - TIP_TAPER) * t)
    return np.concatenate([trunk[None], main, sub]), np.concatenate([[TRUNK_RADIUS], main_radius, sub_radius])


def branch_mesh(ctrl: np.ndarray, radius: np.ndarray, rings: int = RINGS,
                sides: int = SIDES) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Tapered tubes around the curves ``ctrl [B, 3, 3]`` with base radii ``radius [B]``:
    ``v_pos [B (rings + 1) sides, 3]``, ``t_pos_idx [2 B rings sides, 3]``, ``v_tex
    [B (rings + 1) (sides + 1), 2]`` and ``t_tex_idx`` like ``t_pos_idx``; faces point outwards."""
    count = len(ctrl)
    t = np.arange(rings + 1) / rings
    centre, tangent = bezier(ctrl[:, None], t[None])                       # [B, R + 1, 3]
    chord = ctrl[:, 2] - ctrl[:, 0]
    least = np.eye(3)[np.argmin(np.abs(chord), axis=1)]
    ref = unit(np.cross(chord, least))[:, None]                            # [B, 1, 3], perpendicular to the chord
    side = unit(np.cross(tangent, ref))
    up = np.cross(tangent, side)
    theta = 2 * np.pi * np.arange(sides) / sides
    ring = np.cos(theta)[:, None] * side[:, :, None] + np.sin(theta)[:, None] * up[:, :, None]  # [B, R + 1, S, 3]
    r = radius[:, None] * (1 - (1 - TIP_TAPER) * t)                        # [B, R + 1]
    v_pos = (centre[:, :, None] + r[..., None, None] * ring).reshape(-1, 3)

    b, i, j = np.meshgrid(np.arange(count), np.arange(rings), np.arange(sides), indexing="ij")
    base, j1 = b * (rings + 1) * sides, (j + 1) % sides
    a, bb, c, d = base + i * sides + j, base + i * sides + j1, base + (i + 1) * sides + j1, base + (i + 1) * sides + j
    t_pos_idx = np.stack([np.stack([a, bb, d], -1), np.stack([bb, c, d], -1)], axis=-2).reshape(-1, 3)

    length = np.linalg.norm(chord, axis=1) / (2 * np.pi * radius)          # [B] circumferences along
    tu, tv = np.meshgrid(np.arange(sides + 1) / sides, t, indexing="xy")   # [R + 1, S + 1]
    v_tex = np.stack(np.broadcast_arrays(tu, tv * length[:, None, None]), axis=-1).reshape(-1, 2)
    base = b * (rings + 1) * (sides + 1)
    ta, tb = base + i * (sides + 1) + j, base + i * (sides + 1) + j + 1
    tc, td = base + (i + 1) * (sides + 1) + j + 1, base + (i + 1) * (sides + 1) + j
    t_tex_idx = np.stack([np.stack([ta, tb, td], -1), np.stack([tb, tc, td], -1)], axis=-2).reshape(-1, 3)
    return v_pos, t_pos_idx, v_tex, t_tex_idx


def leaf_grid(rows: int = LEAF_ROWS, cols: int = LEAF_COLS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One leaf's grid: across ``a [P]`` in [-1, 1], along ``s [P]`` in [0, 1] (``P = (rows + 1)
    (cols + 1)``) and its ``[2 rows cols, 3]`` triangles, counter-clockwise seen from +z."""
    s, a = np.meshgrid(np.arange(rows + 1) / rows, -1 + 2 * np.arange(cols + 1) / cols, indexing="ij")
    i, j = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    p00, p01 = i * (cols + 1) + j, i * (cols + 1) + j + 1
    p10, p11 = p00 + cols + 1, p01 + cols + 1
    t_idx = np.stack([np.stack([p00, p01, p10], -1), np.stack([p01, p11, p10], -1)], axis=-2).reshape(-1, 3)
    return a.reshape(-1), s.reshape(-1), t_idx


def leaf_bases(rng: np.random.Generator, ctrl: np.ndarray, leaves: int, start: float = LEAF_START,
               twig: float = TWIG) -> tuple[np.ndarray, np.ndarray]:
    """Bases ``[N, 3]`` of ``leaves`` leaves on the curves ``ctrl [B, 3, 3]`` (each chosen with
    probability proportional to its chord length, at t = start + (1 - start) sqrt(xi), offset
    uniformly within a ball of radius ``twig``) and the curves' unit tangents ``[N, 3]`` there."""
    carrier = np.linalg.norm(ctrl[:, 2] - ctrl[:, 0], axis=1)
    which = rng.choice(len(carrier), size=leaves, p=carrier / carrier.sum())
    t = start + (1 - start) * np.sqrt(rng.uniform(size=leaves))
    point, tangent = bezier(ctrl[which], t)
    ball = unit(rng.normal(size=(leaves, 3))) * rng.uniform(size=(leaves, 1)) ** (1 / 3)
    return point + twig * ball, tangent


def leaf_frames(rng: np.random.Generator, base: np.ndarray, tangent: np.ndarray, outward: float = OUTWARD,
                upward: float = UPWARD, along: float = ALONG, jitter: float = JITTER, roll: float = ROLL) -> np.ndarray:
    """Frames ``[N, 3, 3]`` (rows: across x, along d, normal z) of leaves at ``base [N, 3]`` on
    curves with unit tangents ``tangent [N, 3]``: d = |outward o + upward e_y + along T + jitter g|
    (o the horizontal direction away from the y axis, g ~ N(0, I)), the normal e_y projected
    perpendicular to d and rolled about d by an angle ~ N(0, roll)."""
    y = np.array([0.0, 1.0, 0.0])
    away = unit(base * [1.0, 0.0, 1.0])
    d = unit(outward * away + upward * y + along * tangent + jitter * rng.normal(size=(len(base), 3)))
    n0 = unit(y - d[:, 1:2] * d)
    angle = rng.normal(0.0, roll, (len(base), 1))
    n = np.cos(angle) * n0 + np.sin(angle) * np.cross(d, n0)
    return np.stack([np.cross(d, n), d, n], axis=1)


def leaf_mesh(rng: np.random.Generator, ctrl: np.ndarray, leaves: int = LEAVES) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``leaves`` leaves on the branches ``ctrl [B, 3, 3]`` (all rows but the trunk, row 0, each
    chosen with probability proportional to its chord length): ``v_pos [N P, 3]``, ``t_pos_idx
    [N 2 LEAF_ROWS LEAF_COLS, 3]`` and ``v_tex [N P, 2]``, one UV row per vertex (so the UV
    triangles are ``t_pos_idx`` too)."""
    base, tangent = leaf_bases(rng, ctrl[1:], leaves)                      # [N, 3]
    frame = leaf_frames(rng, base, tangent)                                # [N, 3, 3]: rows x, y, z
    length = LEAF_LENGTH * rng.uniform(1 - LEAF_SIZE_SPREAD, 1 + LEAF_SIZE_SPREAD, (leaves, 1))
    bend, curl = rng.uniform(*LEAF_BEND, (leaves, 1)), rng.uniform(*LEAF_CURL, (leaves, 1))
    cell = rng.integers(0, len(VARIANTS), (leaves, 1))
    return leaf_strips(base, frame, length, 0.5 * LEAF_ASPECT * length, bend, curl, cell)


def leaf_strips(base: np.ndarray, frame: np.ndarray, length: np.ndarray, half_width: np.ndarray,
                bend: np.ndarray | float, curl: np.ndarray | float, cell: np.ndarray, atlas: tuple[int, int] = (2, 2),
                rows: int = LEAF_ROWS, cols: int = LEAF_COLS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """N bent ``rows x cols`` grids (leaves, cards, blades; ``P = (rows + 1) (cols + 1)``
    vertices each) at ``base [N, 3]`` in ``frame [N, 3, 3]`` (rows x, y, z), of ``length`` and
    ``half_width`` (``[N, 1]``), bent as (x, y, z) = (a w, s L, bend L s^2 + curl w a^2), each
    textured with cell ``cell [N, 1]`` (row-major) of an ``atlas`` of (rows, columns) cells, its
    tip at the top: ``v_pos [N P, 3]``, ``t_pos_idx [N 2 rows cols, 3]`` and ``v_tex [N P, 2]``, one UV row
    per vertex (so the UV triangles are ``t_pos_idx`` too)."""
    a, s, t_idx = leaf_grid(rows, cols)
    local = np.stack([a * half_width, s * length, bend * length * s ** 2 + curl * half_width * a ** 2], axis=-1)
    v_pos = (base[:, None] + np.einsum("npk,nkd->npd", local, frame)).reshape(-1, 3)
    row, col = np.divmod(cell, atlas[1])
    v_tex = np.stack([(col + (a + 1) / 2) / atlas[1], (row + 1 - s) / atlas[0]], axis=-1).reshape(-1, 2)
    t_pos_idx = (t_idx[None] + len(a) * np.arange(len(base))[:, None, None]).reshape(-1, 3)
    return v_pos, t_pos_idx, v_tex


def leaf_texture(size: int = LEAF_TEXTURE) -> np.ndarray:
    """Leaf atlas ``[size, size, 4]``: linear colour and alpha (0 or 1) of the 2 x 2 cells of
    ``VARIANTS``. In cell (row, col) a texel at atlas coordinates (u, v) has across
    a = 2 frac(2u) - 1 and along s = 1 - frac(2v) (the tip at the top); the blade spans
    s' = (s - BLADE[0]) / (BLADE[1] - BLADE[0]) in (0, 1) with half-width
    w(s') = width sin(pi s'^p)^0.7 (1 - serration |sin(pi SERRATIONS s')|), p = log 0.5 / log widest,
    widest at s' = widest."""
    coordinate = 2 * (np.arange(size) + 0.5) / size
    cell, frac = np.divmod(coordinate, 1.0)
    s, a = (1 - frac)[:, None], (2 * frac - 1)[None, :]                    # [size, 1], [1, size]
    k = (2 * cell[:, None] + cell[None, :]).astype(np.int64)               # [size, size] variant
    colour, widest, width, serration = (np.asarray(x, dtype=np.float64)[k] for x in zip(*VARIANTS))
    blade = np.clip((s - BLADE[0]) / (BLADE[1] - BLADE[0]), 0.0, 1.0)
    half = (width * np.sin(np.pi * blade ** (np.log(0.5) / np.log(widest))) ** 0.7
            * (1 - serration * np.abs(np.sin(np.pi * SERRATIONS * blade))))
    stalk = (s > STALK) & (s < BLADE[0] + 0.05) & (np.abs(a) < STALK_WIDTH)
    alpha = ((blade > 0) & (blade < 1) & (np.abs(a) < half)) | stalk

    rim = np.clip(np.abs(a) / np.maximum(half, 1e-3), 0.0, 1.0)
    mottle = 1 + 0.08 * np.sin(2 * np.pi * (7 * a + 3 * s)) * np.sin(2 * np.pi * (5 * s - 2 * a))
    srgb = colour * ((1 - 0.3 * rim ** 2) * mottle)[..., None]
    phase = VEINS * (blade - 0.6 * np.abs(a))                              # veins run out towards the tip
    vein = (np.abs(phase - np.round(phase)) < VEIN_WIDTH) & (blade > 0.05)
    midrib = (np.abs(a) < MIDRIB * (1 - 0.7 * blade)) | stalk
    srgb = np.where(vein[..., None], 0.6 * srgb + 0.4 * np.asarray(VEIN_SRGB), srgb)
    srgb = np.where(midrib[..., None], VEIN_SRGB, srgb)
    return np.concatenate([srgb_decode(srgb), alpha[..., None]], axis=-1).astype(np.float32)


def bark_texture(size: int = BARK_TEXTURE) -> np.ndarray:
    """Tiling bark ``[size, size, 4]``, linear colour and alpha 1: ``BARK_SRGB`` darkened in
    furrows along v, sum_k sin(2 pi (f_k u + 0.03 sin(2 pi (m_k v + phase_k)))) over
    ``BARK_WAVES``."""
    u = (np.arange(size) + 0.5) / size
    uu, vv = np.meshgrid(u, u)                                             # rows follow v, columns u
    f, m, phase = (np.asarray(x, dtype=np.float64)[:, None, None] for x in zip(*BARK_WAVES))
    ridge = np.sin(2 * np.pi * (f * uu + 0.03 * np.sin(2 * np.pi * (m * vv + phase)))).mean(0)  # [-1, 1]
    srgb = np.asarray(BARK_SRGB) * (0.8 + 0.2 * ridge)[..., None]
    return np.concatenate([srgb_decode(srgb), np.ones((size, size, 1))], axis=-1).astype(np.float32)


def shrub(seed: int = 0, leaves: int = LEAVES, branches: int = BRANCHES) -> Asset:
    """The shrub for ``seed`` (the same seed gives the same arrays): ``1 + branches (1 +
    SUB_BRANCHES)`` branches of ``2 RINGS SIDES`` triangles (material 0, bark) and ``leaves``
    leaves of ``2 LEAF_ROWS LEAF_COLS`` triangles (material 1, leaves); by default 16 branches
    and 4000 leaves, 192,576 triangles, ``HEIGHT`` tall."""
    rng = np.random.default_rng(seed)
    ctrl, radius = skeleton(rng, branches)
    b_pos, b_idx, b_tex, b_tex_idx = branch_mesh(ctrl, radius)
    l_pos, l_idx, l_tex = leaf_mesh(rng, ctrl, leaves)
    v_pos = np.concatenate([b_pos, l_pos])
    v_pos *= HEIGHT / v_pos[:, 1].max()
    mesh = Mesh(v_pos=torch.from_numpy(v_pos).float(),
                t_pos_idx=torch.from_numpy(np.concatenate([b_idx, l_idx + len(b_pos)])).long(),
                uv=[(torch.from_numpy(np.concatenate([b_tex, l_tex])).float(),
                     torch.from_numpy(np.concatenate([b_tex_idx, l_idx + len(b_tex)])).long())],
                t_mat_idx=torch.cat([torch.zeros(len(b_idx), dtype=torch.int64),
                                     torch.ones(len(l_idx), dtype=torch.int64)]))
    return Asset(mesh=mesh, materials=[bark_material(), cutout_material("leaves", leaf_texture())])


def bark_material() -> Material:
    """Opaque, rough bark coloured by the tiling ``bark_texture()``."""
    return Material(name="bark", kd=Texture(torch.from_numpy(bark_texture())),
                    ks=Texture.constant([0.0, BARK_ROUGHNESS, 0.0]))


def cutout_material(name: str, texture: np.ndarray, roughness: float = LEAF_ROUGHNESS) -> Material:
    """Alpha-tested (``MASK``, cutoff 0.5), double-sided material coloured and cut out by
    ``texture [H, W, 4]`` (an atlas: clamped at its border), as leaves and cards are drawn."""
    return Material(name=name, kd=Texture(torch.from_numpy(texture), wrap="clamp"),
                    ks=Texture.constant([0.0, roughness, 0.0]), alpha_mode="MASK", alpha_cutoff=0.5,
                    double_sided=True)
