"""Seeded foliage assets for the ``cards`` application, drawn as real-time foliage is: leaves,
needles and blades as alpha-textured quads (cut-outs), unlike the leaf meshes of
``lookalike.samples.shrub``.

Frame and conventions as in ``lookalike.samples.shrub``: glTF, +Y up, metres, the foot at the
origin, linear colours, ``np.random.default_rng(seed)`` (the same seed gives the same arrays).

Bark. Branches are tapered tubes around quadratic Bezier curves (``shrub.branch_mesh``'s
rings), closed into one surface: the trunk has a bottom cap and every tube ends in a tip vertex;
a child tube starts from a socket, a block of ``width`` adjacent cells of one band of its
parent, whose two triangles per cell it replaces, and its first ring is stitched to the socket's
boundary loop. Sockets sit on odd bands and every (width + 1)-th side, so that no two share a
vertex; the bark of a tree is thus one part (positions compared exactly) in which every edge
joins two triangles, faces outwards.

Cards. A card is a flat quad (``shrub.leaf_strips``) placed like the shrub's leaves
(``shrub.leaf_bases``, ``shrub.leaf_frames``) and textured with one cell of a 2 x 2 atlas whose
alpha cuts out the twig, frond or blade it shows; the card materials are alpha-tested and
double-sided (``shrub.cutout_material``), the bark opaque.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, NamedTuple

import numpy as np
import torch

from ..asset import Asset, Material, Mesh, Texture
from ..colour import srgb_decode
from .shrub import (
    CHILD_RADIUS,
    LEAF_ASPECT,
    TIP_TAPER,
    bark_material,
    bezier,
    branch_mesh,
    cutout_material,
    leaf_bases,
    leaf_frames,
    leaf_strips,
    leaf_texture,
    shrub,
    unit,
)

TWO_PI = 2 * np.pi
Y = np.array([0.0, 1.0, 0.0])


class Level(NamedTuple):
    """One generation of branches: ``sides x rings`` tubes, ``count`` on each parent, in sockets
    ``width`` cells wide (``width + 1`` divides the parent's sides) between t = ``start[0]`` and
    ``start[1]`` along it; ``length`` times the parent's chord times (1.4 - t) (shorter towards the
    parent's tip), heading |along T + n + rise e_y + JITTER g| (T the parent's tangent, n the
    socket's outward normal, g ~ N(0, I))."""

    sides: int
    rings: int
    count: int
    start: tuple[float, float]
    width: int
    length: float
    along: float
    rise: float


TREE_HEIGHT, TREE_RADIUS, TREE_LEAN = 4.5, 0.16, 0.12      # the trunk's curve: chord, base radius, lean
TREE_SIDES, TREE_RINGS = 12, 28
TREE_LEVELS = (Level(9, 24, 8, (0.45, 0.92), 2, 0.55, 0.6, 0.4),     # main branches
               Level(6, 20, 4, (0.3, 0.9), 2, 0.5, 0.8, 0.4),        # sub-branches
               Level(4, 4, 3, (0.3, 0.95), 1, 0.45, 1.0, 0.3))       # twigs


class TreeShape(NamedTuple):
    """A tree's bark: the trunk's ``sides`` and ``rings``, and its generations of branches."""

    sides: int
    rings: int
    levels: tuple[Level, ...]


BROADLEAF = TreeShape(TREE_SIDES, TREE_RINGS, TREE_LEVELS)
GAME_LEVELS = (Level(6, 8, 8, (0.45, 0.92), 1, 0.55, 0.6, 0.4),       # main branches
               Level(4, 6, 4, (0.3, 0.9), 1, 0.5, 0.8, 0.4))         # sub-branches
GAME_TREE = TreeShape(10, 10, GAME_LEVELS)
GAME_CARDS, GAME_CARD_LENGTH = 1500, 1.1
JITTER = 0.3
TIP_V = 0.1                                                 # bark v from a tube's last ring to its tip

CARDS, CARD_LENGTH, CARD_ASPECT, CARD_SPREAD = 3000, 0.6, 0.8, 0.2
CARD_START, CARD_BALL = 0.3, 0.2                            # cards on the outer sub-branches and twigs
CARD_TEXTURE, CARD_LEAVES = 512, 9                          # 2 x 2 cells; leaves beside the stem (+1 at its tip)
STEM_TOP, STEM_WIDTH, STEM_BOW = 0.7, 0.012, 0.03           # in card lengths
TWIG_LEAF, TWIG_ANGLE = 0.3, (0.7, 1.05)                   # leaf length (card lengths), angle off the stem (rad)
STEM_SRGB = (0.33, 0.27, 0.16)

BLADES, BLADE_ROWS, TUFT_RADIUS = 300, 4, 0.08
BLADE_LENGTH, BLADE_HALF_WIDTH, BLADE_BEND = (0.18, 0.38), 0.007, (-0.5, -0.1)
BLADE_TEXTURE = 256                                         # 1 x 4 cells, each 64 texels wide
BLADE_SRGB = (((0.17, 0.32, 0.08), (0.48, 0.58, 0.22)),    # per variant: base and tip colour
              ((0.14, 0.28, 0.07), (0.36, 0.50, 0.16)),
              ((0.20, 0.35, 0.10), (0.58, 0.60, 0.28)),
              ((0.12, 0.25, 0.08), (0.30, 0.46, 0.15)))
SOIL_SIDES, SOIL_RADIUS, SOIL_DOME, SOIL_SRGB = 16, 0.13, 0.015, (0.24, 0.17, 0.11)

CONIFER_HEIGHT, CONIFER_RADIUS, CONIFER_SIDES, CONIFER_RINGS = 8.0, 0.2, 10, 12
WHORLS, WHORL_BRANCHES, CROWN = 30, 9, (0.28, 0.97)         # whorls between these fractions of the height
CROWN_RADIUS, BRANCH_MIN, DROOP, NEEDLE_ASPECT = 2.6, 0.3, np.radians((5.0, 20.0)), 0.5
NEEDLE_TEXTURE = 512                                        # 2 x 2 cells
SHOOT_SPACING, NEEDLE_SPACING, NEEDLE_LENGTH, NEEDLE_WIDTH = 0.09, 0.016, 0.045, 0.008  # in card lengths
NEEDLE_ANGLE = np.radians(50.0)
FROND_ANGLES = np.radians((55.0, 60.0, 48.0, 65.0))         # shoots off the frond's stem, per variant
NEEDLE_SRGB, SHOOT_TIP_SRGB = (0.10, 0.25, 0.12), (0.26, 0.42, 0.18)


class Vertices:
    """A growing position buffer; ``add`` returns the indices of what it appends."""

    def __init__(self):
        self.blocks: list[np.ndarray] = []
        self.count = 0

    def add(self, positions: np.ndarray) -> np.ndarray:
        """Appends ``positions [..., 3]``; their indices ``[...]``."""
        index = self.count + np.arange(positions.size // 3).reshape(positions.shape[:-1])
        self.blocks.append(positions.reshape(-1, 3))
        self.count += len(self.blocks[-1])
        return index

    def array(self) -> np.ndarray:
        return np.concatenate(self.blocks)


@dataclass
class Tubes:
    """Tubes of one generation: curves ``ctrl [B, 3, 3]``, base radii ``radius [B]``, the vertex
    indices of their first loops ``first [B, n0]`` and rings ``ring [B, rings + 1, sides]`` (row
    0 is ``first`` for the trunk, unused for branches), tips ``apex [B]``, and ``hole [B, rings,
    sides]``, the cells that sockets took."""

    ctrl: np.ndarray
    radius: np.ndarray
    first: np.ndarray
    ring: np.ndarray
    apex: np.ndarray
    hole: np.ndarray


def tubes(vertices: Vertices, ctrl: np.ndarray, radius: np.ndarray, sides: int, rings: int,
          first: np.ndarray | None = None) -> Tubes:
    """Adds the rings 1 .. rings and the tip of tubes around ``ctrl [B, 3, 3]`` (and ring 0 as
    their first loop where ``first`` is ``None``, else ``first [B, n0]``, existing vertices)."""
    count = len(ctrl)
    pos = branch_mesh(ctrl, radius, rings, sides)[0].reshape(count, rings + 1, sides, 3)
    if first is None:
        ring = vertices.add(pos)
        first = ring[:, 0]
    else:
        ring = np.concatenate([np.full((count, 1, sides), -1), vertices.add(pos[:, 1:])], axis=1)
    end, tangent = bezier(ctrl, np.ones(count))
    apex = vertices.add(end + TIP_TAPER * radius[:, None] * tangent)
    return Tubes(ctrl, radius, first, ring, apex, np.zeros((count, rings, sides), dtype=bool))


def sockets(rng: np.random.Generator, parent: Tubes, level: Level) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``level.count`` sockets on each tube of ``parent`` (fewer where it has fewer free): the
    parent ``[C]``, band ``[C]`` and first side ``[C]`` of each, on odd bands within
    ``level.start`` and sides that are multiples of ``level.width + 1``."""
    _, rings, sides = parent.hole.shape
    band = np.arange(1, rings, 2)
    band = band[((band + 0.5) / rings >= level.start[0]) & ((band + 0.5) / rings <= level.start[1])]
    cells = np.stack(np.meshgrid(band, np.arange(0, sides, level.width + 1), indexing="ij"), -1).reshape(-1, 2)
    count = min(level.count, len(cells))
    pick = np.concatenate([rng.choice(len(cells), count, replace=False) for _ in range(len(parent.ctrl))])
    return np.repeat(np.arange(len(parent.ctrl)), count), cells[pick, 0], cells[pick, 1]


def grow(rng: np.random.Generator, vertices: Vertices, v_pos: np.ndarray, parent: Tubes, level: Level) -> Tubes:
    """The children of ``parent`` (positions ``v_pos``) at ``level``: each starts from a socket,
    whose cells it marks as holes in the parent, leaving along the socket's outward normal and
    bending towards its heading."""
    b, band, j = sockets(rng, parent, level)
    sides = parent.ring.shape[2]
    cols = (j[:, None] + np.arange(level.width + 1)) % sides                # [C, width + 1]
    lower, upper = parent.ring[b[:, None], band[:, None], cols], parent.ring[b[:, None], band[:, None] + 1, cols]
    first = np.concatenate([lower, upper[:, ::-1]], axis=1)                 # counter-clockwise seen from outside
    parent.hole[b[:, None], band[:, None], cols[:, :-1]] = True
    p0 = v_pos[first].mean(1)
    centre = 0.5 * (v_pos[parent.ring[b, band]].mean(1) + v_pos[parent.ring[b, band + 1]].mean(1))
    normal = unit(p0 - centre)
    t = (band + 0.5) / parent.hole.shape[1]
    _, tangent = bezier(parent.ctrl[b], t)
    chord = np.linalg.norm(parent.ctrl[b, 2] - parent.ctrl[b, 0], axis=1)
    length = (level.length * chord * (1.4 - t) * rng.uniform(0.8, 1.2, len(b)))[:, None]
    heading = unit(level.along * tangent + normal + level.rise * Y + JITTER * rng.normal(size=(len(b), 3)))
    ctrl = np.stack([p0, p0 + 0.5 * length * unit(normal + heading), p0 + length * heading], axis=1)
    radius = CHILD_RADIUS * parent.radius[b] * (1 - (1 - TIP_TAPER) * t)
    return tubes(vertices, ctrl, radius, level.sides, level.rings, first)


def stitch(lower: tuple, upper: tuple) -> tuple[np.ndarray, np.ndarray]:
    """Triangles ``[n + m - d, 3]`` (vertex indices, facing outwards) and their corners' UVs
    ``[n + m - d, 3, 2]`` joining two closed loops around a tube, ``lower`` nearer its start. A
    loop is (indices ``[n]``, angles ``[n]`` counter-clockwise about the tube's axis, v); the
    walk advances along whichever loop's next vertex comes first in angle, so loops of any sizes
    join; the d triangles with a repeated vertex (a loop of one vertex: a cap, a tip) are dropped."""
    (ia, aa, va), (ib, ab, vb) = lower, upper
    aa = aa[0] + np.remainder(aa - aa[0], TWO_PI)
    start = int(np.argmin(np.abs(np.remainder(ab - aa[0] + np.pi, TWO_PI) - np.pi)))
    ib, ab = np.roll(ib, -start), np.roll(ab, -start)
    ab = ab[0] + np.remainder(ab - ab[0], TWO_PI)
    ab = ab + TWO_PI * np.round((aa[0] - ab[0]) / TWO_PI)
    ia, aa = np.append(ia, ia[0]), np.append(aa, aa[0] + TWO_PI)
    ib, ab = np.append(ib, ib[0]), np.append(ab, ab[0] + TWO_PI)
    n, m = len(ia) - 1, len(ib) - 1
    step_a = np.argsort(np.concatenate([aa[1:], ab[1:]]), kind="stable") < n
    i, j = np.cumsum(step_a) - step_a, np.cumsum(~step_a) - ~step_a
    i1, j1 = np.minimum(i + 1, n), np.minimum(j + 1, m)
    tri = np.stack([ia[i], np.where(step_a, ia[i1], ib[j1]), ib[j]], axis=1)
    angle = np.stack([aa[i], np.where(step_a, aa[i1], ab[j1]), ab[j]], axis=1)
    v = np.stack(np.broadcast_arrays(va, np.where(step_a, va, vb), vb), axis=1)
    keep = (tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 0] != tri[:, 2])
    return tri[keep], np.stack([angle / TWO_PI, v], axis=-1)[keep]


def loop_angles(points: np.ndarray, centre: np.ndarray, ring: np.ndarray) -> np.ndarray:
    """Angles ``[n]`` of ``points [n, 3]`` about ``centre [3]`` (a socket's centroid) in the frame
    of ``ring [S, 3]`` (a tube's ring, vertex j at angle 2 pi j / S about its own centre), so that
    a socket's loop spreads round the circle even where the tube leaves it obliquely."""
    theta = TWO_PI * np.arange(len(ring)) / len(ring)
    side, up = np.cos(theta) @ (ring - ring.mean(0)), np.sin(theta) @ (ring - ring.mean(0))
    return np.arctan2((points - centre) @ up, (points - centre) @ side)


def grid(tubes: Tubes, scale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The two triangles ``[T, 3]`` and corner UVs ``[T, 3, 2]`` of every cell of bands 1 ..
    rings - 1 that no socket took (u = j / sides around, v = scale t along)."""
    count, rings, sides = tubes.hole.shape
    b, i, j = np.nonzero(~tubes.hole[:, 1:])
    i = i + 1
    j1 = (j + 1) % sides
    a, bb = tubes.ring[b, i, j], tubes.ring[b, i, j1]
    c, d = tubes.ring[b, i + 1, j1], tubes.ring[b, i + 1, j]
    tri = np.stack([np.stack([a, bb, d], -1), np.stack([bb, c, d], -1)], axis=1).reshape(-1, 3)
    u0, u1 = j / sides, (j + 1) / sides
    v0, v1 = scale[b] * i / rings, scale[b] * (i + 1) / rings
    u = np.stack([np.stack([u0, u1, u0], -1), np.stack([u1, u1, u0], -1)], axis=1)
    v = np.stack([np.stack([v0, v0, v1], -1), np.stack([v0, v1, v1], -1)], axis=1)
    return tri, np.stack([u, v], axis=-1).reshape(-1, 3, 2)


def tube_triangles(tubes: Tubes, v_pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """All triangles ``[T, 3]`` and corner UVs ``[T, 3, 2]`` of ``tubes`` but a trunk's cap: the
    grid, the stitch from each first loop to ring 1 and the fan from the last ring to the tip.
    Bark UVs as the shrub's: one circumference of the base per texture height along."""
    count, rings, sides = tubes.hole.shape
    scale = np.linalg.norm(tubes.ctrl[:, 2] - tubes.ctrl[:, 0], axis=1) / (TWO_PI * tubes.radius)
    theta = TWO_PI * np.arange(sides) / sides
    bands = [grid(tubes, scale)]
    for b in range(count):
        angle = loop_angles(v_pos[tubes.first[b]], tubes.ctrl[b, 0], v_pos[tubes.ring[b, 1]])
        bands.append(stitch((tubes.first[b], angle, 0.0), (tubes.ring[b, 1], theta, scale[b] / rings)))
        tip = (tubes.apex[b:b + 1], np.zeros(1), scale[b] + TIP_V)
        bands.append(stitch((tubes.ring[b, rings], theta, scale[b]), tip))
    return np.concatenate([tri for tri, _ in bands]), np.concatenate([uv for _, uv in bands])


def bark_mesh(vertices: Vertices, generations: list[Tubes]) -> tuple[np.ndarray, ...]:
    """The closed bark of ``generations`` (row 0 of the first: the trunk, capped at its foot):
    ``v_pos [V, 3]``, ``t_pos_idx [T, 3]``, ``v_tex [VT, 2]`` and ``t_tex_idx [T, 3]``."""
    trunk = generations[0]
    sides = trunk.ring.shape[2]
    foot = vertices.add(trunk.ctrl[:1, 0])
    v_pos = vertices.array()
    tri, uv = stitch((foot, np.zeros(1), -TIP_V), (trunk.ring[0, 0], TWO_PI * np.arange(sides) / sides, 0.0))
    parts = [(tri, uv)] + [tube_triangles(tubes, v_pos) for tubes in generations]
    tri, uv = np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])
    v_tex, t_tex_idx = np.unique(uv.reshape(-1, 2), axis=0, return_inverse=True)
    return v_pos, tri, v_tex, t_tex_idx.reshape(-1, 3)


def assemble(parts: list[tuple[np.ndarray, ...]], materials: list[Material]) -> Asset:
    """One asset of ``parts`` (``v_pos, t_pos_idx, v_tex, t_tex_idx``; part k gets material k)."""
    v_pos, tri, v_tex, tex_idx, mat = [], [], [], [], []
    vertex_count = tex_count = 0
    for k, (pos, t_pos_idx, tex, t_tex_idx) in enumerate(parts):
        v_pos.append(pos)
        tri.append(t_pos_idx + vertex_count)
        v_tex.append(tex)
        tex_idx.append(t_tex_idx + tex_count)
        mat.append(np.full(len(t_pos_idx), k))
        vertex_count, tex_count = vertex_count + len(pos), tex_count + len(tex)
    mesh = Mesh(v_pos=torch.from_numpy(np.concatenate(v_pos)).float(),
                t_pos_idx=torch.from_numpy(np.concatenate(tri)).long(),
                uv=[(torch.from_numpy(np.concatenate(v_tex)).float(),
                     torch.from_numpy(np.concatenate(tex_idx)).long())],
                t_mat_idx=torch.from_numpy(np.concatenate(mat)).long())
    return Asset(mesh=mesh, materials=materials)


def cells(size: int, atlas: tuple[int, int] = (2, 2)) -> tuple[np.ndarray, np.ndarray]:
    """Across ``a [1, W]`` in (-1, 1) and along ``s [H, 1]`` in (0, 1) (the tip at the top) of the
    texels of one cell of an atlas ``size`` texels wide and tall of (rows, columns) cells."""
    height, width = size // atlas[0], size // atlas[1]
    return (2 * (np.arange(width) + 0.5) / width - 1)[None], (1 - (np.arange(height) + 0.5) / height)[:, None]


def tile(cell_images: list[np.ndarray], atlas: tuple[int, int] = (2, 2)) -> np.ndarray:
    """The atlas ``[H, W, 4]`` float32 of ``cell_images`` (row-major, linear RGBA)."""
    rows = [np.concatenate(cell_images[r * atlas[1]:(r + 1) * atlas[1]], axis=1) for r in range(atlas[0])]
    return np.concatenate(rows, axis=0).astype(np.float32)


def twig_cell(rng: np.random.Generator, leaves: np.ndarray, size: int) -> np.ndarray:
    """One card ``[size / 2, size / 2, 4]`` of the twig atlas: a bowed stem up the middle to
    ``STEM_TOP`` and ``CARD_LEAVES`` leaves alternately left and right of it plus one at its tip,
    each a variant of the shrub's leaf atlas ``leaves`` rotated, scaled and tinted."""
    a, s = cells(size)
    x, y = a * CARD_ASPECT / 2, s                                          # card lengths
    rgba = np.zeros((len(s), a.shape[1], 4))
    stem = (np.abs(x - STEM_BOW * np.sin(np.pi * y)) < STEM_WIDTH * (1 - 0.6 * y)) & (y < STEM_TOP)
    rgba[stem] = np.append(srgb_decode(np.asarray(STEM_SRGB)), 1.0)
    along = np.append(STEM_TOP * np.linspace(0.15, 0.95, CARD_LEAVES), STEM_TOP)
    side = np.append((-1.0) ** np.arange(CARD_LEAVES), 0.0)
    angle = side * rng.uniform(*TWIG_ANGLE, len(along))
    length = TWIG_LEAF * rng.uniform(0.85, 1.1, len(along)) * np.append(np.linspace(0.8, 1.0, CARD_LEAVES), 1.0)
    variant = rng.integers(0, 4, len(along))
    tint = rng.uniform(0.75, 1.15, (len(along), 1)) * (1 + rng.uniform(-0.12, 0.12, (len(along), 1)) * [1.0, 0.3, -1.0])
    for k in range(len(along)):
        dx, dy = x - STEM_BOW * np.sin(np.pi * along[k]), y - along[k]
        ls = (dx * np.sin(angle[k]) + dy * np.cos(angle[k])) / length[k]
        la = (dx * np.cos(angle[k]) - dy * np.sin(angle[k])) / (0.5 * LEAF_ASPECT * length[k])
        inside = (ls >= 0) & (ls < 1) & (np.abs(la) < 1)
        row, col = divmod(int(variant[k]), 2)
        px = np.clip(((col + (la + 1) / 2) / 2 * len(leaves)).astype(int), 0, len(leaves) - 1)
        py = np.clip(((row + 1 - ls) / 2 * len(leaves)).astype(int), 0, len(leaves) - 1)
        texel = leaves[py, px]
        take = inside & (texel[..., 3] > 0.5)
        rgba[take] = np.concatenate([texel[take][:, :3] * tint[k], np.ones((int(take.sum()), 1))], axis=1)
    return rgba


def twig_texture(rng: np.random.Generator, size: int = CARD_TEXTURE) -> np.ndarray:
    """The broadleaf tree's card atlas ``[size, size, 4]``: 2 x 2 twigs (``twig_cell``), linear
    colour, alpha 0 or 1."""
    leaves = leaf_texture()
    return tile([twig_cell(rng, leaves, size) for _ in range(4)])


def tree_bark(rng: np.random.Generator, branches: int, shape: TreeShape | None = None
              ) -> tuple[tuple[np.ndarray, ...], np.ndarray]:
    """A tree's bark (``bark_mesh``) of ``shape`` (default ``BROADLEAF``) with ``branches`` main
    branches, and the curves ``[C, 3, 3]`` of its two outermost generations, which carry the
    cards."""
    shape = BROADLEAF if shape is None else shape
    vertices = Vertices()
    lean = rng.normal(0.0, TREE_LEAN, 2)
    trunk = np.array([[[0.0, 0.0, 0.0], [0.0, TREE_HEIGHT / 2, 0.0], [lean[0], TREE_HEIGHT, lean[1]]]])
    generations = [tubes(vertices, trunk, np.array([TREE_RADIUS]), shape.sides, shape.rings)]
    for k, level in enumerate(shape.levels):
        level = level._replace(count=branches) if k == 0 else level
        generations.append(grow(rng, vertices, vertices.array(), generations[-1], level))
    carriers = np.concatenate([generation.ctrl for generation in generations[-2:]])
    return bark_mesh(vertices, generations), carriers


def broadleaf_tree(seed: int = 0, cards: int = CARDS, branches: int = TREE_LEVELS[0].count) -> Asset:
    """A broadleaf tree about 6 m tall for ``seed``: material 0, bark: one closed, connected
    surface of tapered tubes (the trunk, ``branches`` main branches, 4 sub-branches on each and 3
    twigs on each of those), 15,176 triangles by default whatever the seed; material 1, leaves:
    ``cards`` quads (2 triangles each) on the sub-branches and twigs, cut out of a 2 x 2 atlas of
    leafy twigs. By default 3,000 cards and 21,176 triangles in all."""
    return cut_out_tree(seed, cards, branches, BROADLEAF, CARD_LENGTH)


def game_tree(seed: int = 0, cards: int = GAME_CARDS, branches: int = GAME_LEVELS[0].count) -> Asset:
    """A broadleaf tree as game trees are made, for ``seed``: the broadleaf tree's kind of crown
    on a low-poly bark (``GAME_TREE``: the trunk, ``branches`` main branches and 4 sub-branches
    on each, no twigs; 2,604 triangles by default whatever the seed), and ``cards`` larger quads,
    each a cluster of leaves from the same 2 x 2 atlas of leafy twigs, on the main and
    sub-branches. By default 1,500 cards and 5,604 triangles in all: the budget of a game's tree,
    where the broadleaf tree's is a film's."""
    return cut_out_tree(seed, cards, branches, GAME_TREE, GAME_CARD_LENGTH)


def cut_out_tree(seed: int, cards: int, branches: int, shape: TreeShape, card_length: float) -> Asset:
    """A tree of ``shape`` with ``branches`` main branches (``tree_bark``) and ``cards`` quads of
    about ``card_length`` metres (``CARD_SPREAD``) on its outer branches, cut out of the twig
    atlas (``twig_texture``): bark material 0, leaves material 1."""
    rng = np.random.default_rng(seed)
    bark, carriers = tree_bark(rng, branches, shape)
    base, tangent = leaf_bases(rng, carriers, cards, CARD_START, CARD_BALL)
    frame = leaf_frames(rng, base, tangent)
    length = card_length * rng.uniform(1 - CARD_SPREAD, 1 + CARD_SPREAD, (cards, 1))
    cell = rng.integers(0, 4, (cards, 1))
    v_pos, tri, v_tex = leaf_strips(base, frame, length, 0.5 * CARD_ASPECT * length, 0.0, 0.0, cell, rows=1, cols=1)
    return assemble([bark, (v_pos, tri, v_tex, tri)],
                    [bark_material(), cutout_material("leaves", twig_texture(rng))])


def blade_texture(size: int = BLADE_TEXTURE) -> np.ndarray:
    """Grass blades ``[size, size, 4]``, a 1 x 4 atlas of ``BLADE_SRGB`` variants: a blade of
    half-width (in a) 0.9 (1 - s)^0.6 min(1, 0.6 + 4 s), pointed at the tip, its colour from
    base to tip along s^1.5, a lighter midrib; alpha 0 or 1."""
    a, s = cells(size, (1, 4))
    half = 0.9 * (1 - s) ** 0.6 * np.minimum(1.0, 0.6 + 4 * s)
    alpha = (np.abs(a) < half)[..., None]
    images = []
    for base, tip in BLADE_SRGB:
        srgb = np.asarray(base) + (np.asarray(tip) - np.asarray(base)) * (s ** 1.5)[..., None]
        srgb = srgb * np.where(np.abs(a) < 0.12, 1.15, 1 - 0.2 * np.abs(a))[..., None]
        images.append(np.concatenate([srgb_decode(srgb), np.broadcast_to(alpha, srgb.shape[:-1] + (1,))], axis=-1))
    return tile(images, (1, 4))


def soil(rng: np.random.Generator) -> tuple[tuple[np.ndarray, ...], Material]:
    """A low dome of ``SOIL_SIDES`` triangles under the tuft (``v_pos, t_pos_idx, v_tex,
    t_tex_idx``, UVs planar) and its opaque material, ``SOIL_SRGB`` with a seeded mottle."""
    theta = TWO_PI * np.arange(SOIL_SIDES) / SOIL_SIDES
    rim = SOIL_RADIUS * np.stack([np.cos(theta), np.zeros(SOIL_SIDES), np.sin(theta)], axis=-1)
    v_pos = np.concatenate([[[0.0, SOIL_DOME, 0.0]], rim])
    j = np.arange(SOIL_SIDES)
    tri = np.stack([np.zeros(SOIL_SIDES, int), 1 + (j + 1) % SOIL_SIDES, 1 + j], axis=1)   # facing up
    v_tex = 0.5 + 0.5 * v_pos[:, [0, 2]] / SOIL_RADIUS
    mottle = rng.uniform(0.75, 1.2, (32, 32, 1))
    kd = np.concatenate([srgb_decode(np.asarray(SOIL_SRGB) * mottle), np.ones((32, 32, 1))], axis=-1)
    material = Material(name="soil", kd=Texture(torch.from_numpy(kd.astype(np.float32))),
                        ks=Texture.constant([0.0, 0.95, 0.0]))
    return (v_pos, tri, v_tex, tri), material


def grass_tuft(seed: int = 0, blades: int = BLADES) -> Asset:
    """A grass tuft about 0.35 m tall for ``seed``: material 0, blades: ``blades`` strips of
    ``BLADE_ROWS`` quads (``2 BLADE_ROWS`` triangles, open, thin) rising from a disc of radius
    ``TUFT_RADIUS``, leaning out and drooping, cut out of a 1 x 4 atlas of blades (alpha-tested,
    double-sided); material 1, soil: an opaque dome of ``SOIL_SIDES`` triangles. By default 300
    blades, 2,416 triangles."""
    rng = np.random.default_rng(seed)
    r = TUFT_RADIUS * np.sqrt(rng.uniform(size=(blades, 1)))
    theta = rng.uniform(0, TWO_PI, (blades, 1))
    base = np.concatenate([r * np.cos(theta), np.zeros((blades, 1)), r * np.sin(theta)], axis=1)
    frame = leaf_frames(rng, base, np.zeros((blades, 3)), outward=0.35, upward=1.0, along=0.0, jitter=0.2, roll=0.5)
    length = rng.uniform(*BLADE_LENGTH, (blades, 1)) * (1.15 - 0.4 * r / TUFT_RADIUS)
    bend = rng.uniform(*BLADE_BEND, (blades, 1))
    cell = rng.integers(0, 4, (blades, 1))
    v_pos, tri, v_tex = leaf_strips(base, frame, length, np.full((blades, 1), BLADE_HALF_WIDTH), bend, 0.0,
                                    cell, atlas=(1, 4), rows=BLADE_ROWS, cols=1)
    ground, soil_material = soil(rng)
    return assemble([(v_pos, tri, v_tex, tri), ground], [cutout_material("blades", blade_texture()), soil_material])


def frond_cell(size: int, angle: float, tint: np.ndarray) -> np.ndarray:
    """One needle card ``[size / 2, size / 2, 4]``: a stem up the middle, shoots every
    ``SHOOT_SPACING`` on both sides at ``angle`` to it, as long as the card's half-width allows
    and shorter towards its tip, each with needles every ``NEEDLE_SPACING`` on both sides at
    ``NEEDLE_ANGLE``, lighter at the shoots' tips; colours times ``tint``."""
    a, s = cells(size)
    x, y = np.abs(a) * NEEDLE_ASPECT / 2, s
    rgba = np.zeros((len(s), a.shape[1], 4))
    nearest = np.round((y - x / np.tan(angle)) / SHOOT_SPACING)
    for k in (nearest - 1, nearest, nearest + 1):
        origin = k * SHOOT_SPACING
        reach = 0.95 * NEEDLE_ASPECT / 2 / np.sin(angle) * np.clip(1 - origin, 0, 1) ** 0.6
        rho = x * np.sin(angle) + (y - origin) * np.cos(angle)                 # along the shoot
        q = np.abs(x * np.cos(angle) - (y - origin) * np.sin(angle))         # off the shoot
        rho0 = rho - q / np.tan(NEEDLE_ANGLE)                                  # where its needle starts
        gap = np.abs(rho0 / NEEDLE_SPACING - np.round(rho0 / NEEDLE_SPACING)) * NEEDLE_SPACING
        needle = (gap * np.sin(NEEDLE_ANGLE) < NEEDLE_WIDTH / 2) & (q < NEEDLE_LENGTH * np.sin(NEEDLE_ANGLE))
        on = (origin > 0) & (rho0 > 0) & (rho0 < reach) & (needle | (q < 0.004))
        fresh = np.clip(rho / np.maximum(reach, 1e-6), 0, 1)[..., None] ** 3
        srgb = (np.asarray(NEEDLE_SRGB) + (np.asarray(SHOOT_TIP_SRGB) - np.asarray(NEEDLE_SRGB)) * fresh) * tint
        rgba[on] = np.concatenate([srgb_decode(srgb), np.ones(srgb.shape[:-1] + (1,))], axis=-1)[on]
    stem = (np.abs(a) * NEEDLE_ASPECT / 2 < 0.006 * (1.2 - y)) & (y > 0) & (y < 0.97)
    rgba[stem] = np.append(srgb_decode(np.asarray(STEM_SRGB)), 1.0)
    return rgba


def needle_texture(rng: np.random.Generator, size: int = NEEDLE_TEXTURE) -> np.ndarray:
    """The conifer's card atlas ``[size, size, 4]``: 2 x 2 fronds (``frond_cell``) with shoots
    at ``FROND_ANGLES`` and seeded tints, linear colour, alpha 0 or 1."""
    tints = rng.uniform(0.85, 1.15, (4, 1)) * (1 + rng.uniform(-0.1, 0.1, (4, 1)) * [1.0, 0.0, -1.0])
    return tile([frond_cell(size, angle, tint) for angle, tint in zip(FROND_ANGLES, tints)])


def whorl_cards(rng: np.random.Generator, whorls: int, trunk_radius: float) -> tuple[np.ndarray, ...]:
    """Bases ``[N, 3]``, frames ``[N, 3, 3]`` and lengths ``[N, 1]`` of the conifer's branches:
    ``WHORL_BRANCHES`` (+-1) per whorl at evenly spread, jittered azimuths, from the trunk's
    surface, drooping, as long as the crown's radius at their height, which shrinks to the top."""
    height = CONIFER_HEIGHT * np.linspace(*CROWN, whorls)
    count = WHORL_BRANCHES + rng.integers(-1, 2, whorls)
    y = np.repeat(height, count)
    azimuth = np.concatenate([(np.arange(c) + rng.uniform(-0.2, 0.2, c)) * TWO_PI / c + rng.uniform(0, TWO_PI)
                              for c in count])
    q = (y - y[0]) / (CONIFER_HEIGHT - y[0])                                # 0 at the lowest whorl, 1 at the top
    radius = trunk_radius * (1 - (1 - TIP_TAPER) * y / CONIFER_HEIGHT)
    base = np.stack([radius * np.cos(azimuth), y, radius * np.sin(azimuth)], axis=1)
    droop = DROOP[1] - (DROOP[1] - DROOP[0]) * q + rng.uniform(-0.05, 0.05, len(y))
    frame = leaf_frames(rng, base, np.zeros_like(base), outward=1.0, upward=-np.tan(droop)[:, None], along=0.0,
                        jitter=0.08, roll=0.25)
    length = (BRANCH_MIN + CROWN_RADIUS * (1 - q) ** 0.85)[:, None] * rng.uniform(0.85, 1.15, (len(y), 1))
    return base, frame, length


def conifer(seed: int = 0, whorls: int = WHORLS) -> Asset:
    """A conifer ``CONIFER_HEIGHT`` (8 m) tall for ``seed``: material 0, bark: a closed tapered
    trunk of ``2 CONIFER_SIDES (CONIFER_RINGS + 1)`` triangles (260); material 1, needles: in
    each of ``whorls`` whorls 8-10 branches, each two crossed cards (quads, 2 triangles each: one
    lying flat, one on edge) cut out of a 2 x 2 atlas of needle fronds. By default about 540
    cards, 1,350 triangles in all."""
    rng = np.random.default_rng(seed)
    vertices = Vertices()
    lean = rng.normal(0.0, 0.05, 2)
    ctrl = np.array([[[0.0, 0.0, 0.0], [0.0, CONIFER_HEIGHT / 2, 0.0], [lean[0], CONIFER_HEIGHT, lean[1]]]])
    trunk = tubes(vertices, ctrl, np.array([CONIFER_RADIUS]), CONIFER_SIDES, CONIFER_RINGS)
    bark = bark_mesh(vertices, [trunk])
    base, frame, length = whorl_cards(rng, whorls, CONIFER_RADIUS)
    on_edge = frame[:, [2, 1, 0]] * np.array([1.0, 1.0, -1.0])[:, None]    # a quarter turn about the branch
    base, length = np.concatenate([base, base]), np.concatenate([length, length])
    frame = np.concatenate([frame, on_edge])
    cell = rng.integers(0, 4, (len(base), 1))
    v_pos, tri, v_tex = leaf_strips(base, frame, length, 0.5 * NEEDLE_ASPECT * length, 0.0, 0.0, cell, rows=1, cols=1)
    return assemble([bark, (v_pos, tri, v_tex, tri)],
                    [bark_material(), cutout_material("needles", needle_texture(rng))])


FOLIAGE: dict[str, Callable[..., Asset]] = {"shrub": shrub, "broadleaf-tree": broadleaf_tree,
                                            "game-tree": game_tree, "grass-tuft": grass_tuft, "conifer": conifer}
"""The foliage assets of the benchmark by name: each ``(seed=0, ...) -> Asset``."""
