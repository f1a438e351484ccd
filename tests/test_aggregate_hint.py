"""The aggregate-geometry hint (``lookalike.asset.parts.aggregate_traits``): many small or thin
parts that are open surfaces or alpha-tested, holding most of the area, suggest ``lookalike
cards``; solid parts, a skinned input, one closed body and a scan with loose crumbs do not.

Each case that must not fire stands beside a near twin that must, so that each assertion can fail."""

from __future__ import annotations

import numpy as np
import torch

from lookalike.asset import Asset, Material, Mesh, Texture
from lookalike.asset.parts import AGGREGATE_PARTS, aggregate_traits
from lookalike.jobs.simplify import aggregate_remarks
from mesh_factory import icosphere
from skin_factory import two_bone_skin

BOX_CORNERS = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
BOX_FACES = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                      [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
"""A closed unit box about the origin: 8 corners, 12 triangles; its last two are the +z face."""


def alpha_tested() -> Material:
    texture = torch.ones(8, 8, 4)
    texture[::2, ::2, 3] = 0.0
    return Material(name="leaf", kd=Texture(texture), alpha_mode="MASK", alpha_cutoff=0.5, double_sided=True)


def merged(pieces: list[tuple[np.ndarray, np.ndarray]], material: Material | None = None,
           skinned: bool = False, influences: bool = True) -> Asset:
    """One asset of disjoint ``pieces`` (``(v_pos [n, 3], triangles [m, 3])``, each with its own
    vertices); ``skinned``: bound to ``two_bone_skin`` (every vertex to the first joint unless
    not ``influences``)."""
    offsets = np.cumsum([0] + [len(v) for v, _ in pieces])
    v_pos = np.concatenate([v for v, _ in pieces])
    tri = np.concatenate([t + o for (_, t), o in zip(pieces, offsets)])
    joints = weights = None
    if skinned and influences:
        joints = torch.zeros(len(v_pos), 4, dtype=torch.int64)
        weights = torch.tensor([[1.0, 0.0, 0.0, 0.0]]).repeat(len(v_pos), 1)
    mesh = Mesh(v_pos=torch.from_numpy(v_pos).float(), t_pos_idx=torch.from_numpy(tri).long(),
                v_joints=joints, v_weights=weights)
    return Asset(mesh, [material or Material()], skin=two_bone_skin() if skinned else None)


def frame(rng: np.random.Generator) -> np.ndarray:
    """A random rotation ``[3, 3]``."""
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q


def leaves(count: int, seed: int = 0) -> list:
    """Small open leaves (a fan of six triangles folded along its midrib, 0.1 long) over a
    2 x 2 x 2 crown."""
    rng = np.random.default_rng(seed)
    angle = np.arange(6) * np.pi / 3
    outline = np.stack([0.05 * np.cos(angle), 0.025 * np.sin(angle), 0.01 * np.abs(np.sin(angle))], -1)
    fan = np.array([[6, i, (i + 1) % 6] for i in range(6)])
    shape = np.concatenate([outline, [[0.0, 0.0, 0.0]]])
    return [(shape @ frame(rng).T + rng.uniform(-1, 1, 3), fan) for _ in range(count)]


def quads(count: int, size: float, seed: int = 0) -> list:
    """Open squares of side ``size`` (two triangles) at random places and turns in a 2-unit cube."""
    rng = np.random.default_rng(seed)
    square = np.array([[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0], [-0.5, 0.5, 0]]) * size
    return [(square @ frame(rng).T + rng.uniform(-1, 1, 3), np.array([[0, 1, 2], [0, 2, 3]])) for _ in range(count)]


def armour(count: int = 100, open_top: bool = False, seed: int = 0) -> list:
    """``count`` solid plates (closed boxes about 0.2 x 0.15 x 0.05, turned at random) over a
    figure 2 tall; ``open_top``: each lacks its +z face, an open shell of the same shape."""
    rng = np.random.default_rng(seed)
    faces = BOX_FACES[:-2] if open_top else BOX_FACES
    pieces = []
    for _ in range(count):
        scale = np.array([0.2, 0.15, 0.05]) * rng.uniform(0.8, 1.2, 3)
        at = rng.uniform([-0.4, -0.3, 0.0], [0.4, 0.3, 2.0])
        pieces.append(((BOX_CORNERS * scale) @ frame(rng).T + at, faces))
    return pieces


def grass(count: int = 200, width: float = 0.03, seed: int = 0) -> list:
    """A 1 x 1 ground quad with ``count`` upright blades 0.5 long (half the patch's size): strips
    of four segments, ``width`` wide, leaning a little."""
    rng = np.random.default_rng(seed)
    ground = (np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float), np.array([[0, 1, 2], [0, 2, 3]]))
    height = np.linspace(0, 0.5, 5)
    strip = np.array([[[2 * i, 2 * i + 1, 2 * i + 3], [2 * i, 2 * i + 3, 2 * i + 2]] for i in range(4)]).reshape(-1, 3)
    pieces = [ground]
    for _ in range(count):
        side = np.array([np.cos(a := rng.uniform(0, np.pi)), np.sin(a), 0.0]) * width / 2
        lean = np.r_[rng.normal(scale=0.1, size=2), 1.0]
        spine = rng.uniform(0.05, 0.95, 3) * [1, 1, 0] + height[:, None] * lean / np.linalg.norm(lean)
        pieces.append((np.stack([spine - side, spine + side], 1).reshape(-1, 3), strip))
    return pieces


def sphere(radius: float = 1.0, subdivisions: int = 3) -> tuple[np.ndarray, np.ndarray]:
    mesh = icosphere(subdivisions, radius=radius)
    return mesh.v_pos.numpy().astype(np.float64), mesh.t_pos_idx.numpy()


def test_many_small_open_leaves_fire_and_say_why():
    crown = merged(leaves(1000))
    traits = aggregate_traits(crown)
    assert traits == ("1,000 disjoint parts, 1,000 of them alpha-tested or small or thin open surfaces, holding 100 % "
                      "of the area")
    assert aggregate_remarks(crown)[0].startswith(f"the input looks like aggregate geometry ({traits})")


def test_too_few_leaves_do_not_fire():
    assert aggregate_traits(merged(leaves(AGGREGATE_PARTS))) is not None
    assert aggregate_traits(merged(leaves(AGGREGATE_PARTS - 1))) is None


def test_many_alpha_textured_quads_fire():
    traits = aggregate_traits(merged(quads(300, 0.1), alpha_tested()))
    assert traits is not None and "300 disjoint parts, 300 of them" in traits


def test_solid_armour_does_not_fire_but_the_same_plates_open_or_alpha_tested_do():
    plates = armour()
    assert aggregate_traits(merged(plates)) is None
    assert aggregate_remarks(merged(plates)) == []
    assert aggregate_traits(merged(armour(open_top=True))) is not None
    assert aggregate_traits(merged(plates, alpha_tested())) is not None
    flat = [(v[:4], np.array([[0, 1, 3], [0, 3, 2]])) for v, _ in plates]   # one side of each plate
    assert aggregate_traits(merged(flat)) is not None


def test_a_skinned_input_never_fires():
    assert aggregate_traits(merged(armour(), skinned=True)) is None
    shells = armour(open_top=True)
    assert aggregate_traits(merged(shells, alpha_tested(), skinned=True)) is None
    assert aggregate_traits(merged(shells, alpha_tested(), skinned=True, influences=False)) is not None
    assert aggregate_traits(merged(shells, alpha_tested())) is not None


def test_one_closed_sphere_does_not_fire_but_its_triangles_scattered_apart_do():
    v, t = sphere()
    assert aggregate_traits(merged([(v, t)])) is None
    assert aggregate_traits(merged([(v, t)], alpha_tested())) is None
    shards = [(0.8 * v[tri] + 0.2 * v[tri].mean(0), np.array([[0, 1, 2]])) for tri in t]
    assert aggregate_traits(merged(shards)) is not None


def test_a_scan_with_loose_crumbs_does_not_fire_but_the_crumbs_alone_do():
    rng = np.random.default_rng(1)
    crumbs = [(rng.normal(size=3) * 0.3 + 0.01 * rng.normal(size=(3, 3)), np.array([[0, 1, 2]])) for _ in range(30)]
    assert aggregate_traits(merged([sphere(subdivisions=4)] + crumbs[:5])) is None
    assert aggregate_traits(merged([sphere(subdivisions=4)] + crumbs)) is None
    assert aggregate_traits(merged(crumbs)) is not None


def test_thin_open_blades_half_the_assets_size_fire_but_wide_quads_as_long_do_not():
    traits = aggregate_traits(merged(grass()))
    assert traits is not None and "201 disjoint parts, 200 of them" in traits
    assert aggregate_traits(merged(grass(width=0.3))) is None


def test_per_part_statistics_match_a_loop_over_parts():
    """The vectorised boundary edges and principal extents agree with each part's own, part by part."""
    from lookalike.asset.parts import AGGREGATE_SMALL, AGGREGATE_THIN, _corner_parts, _open_parts, \
        _small_or_thin_parts, welded_corners

    rng = np.random.default_rng(3)
    pieces = armour(30) + armour(30, open_top=True, seed=1) + grass(40)[1:] + leaves(30) + [sphere(0.3, 1)]
    pieces = [pieces[i] for i in rng.permutation(len(pieces))]
    asset = merged(pieces)
    positions, corner = welded_corners(asset.mesh.v_pos.numpy(), asset.mesh.t_pos_idx.numpy())
    part = _corner_parts(corner)
    parts = int(part.max()) + 1
    assert parts == len(pieces)
    positions = positions.astype(np.float64)
    diagonal = np.linalg.norm(np.ptp(positions[np.unique(corner)], axis=0))
    is_open = _open_parts(corner, part, parts)
    shaped = _small_or_thin_parts(positions, corner, part, np.ones(parts, bool), diagonal)
    some = rng.random(parts) < 0.5
    np.testing.assert_array_equal(_small_or_thin_parts(positions, corner, part, some, diagonal), shaped[some])
    for p in range(parts):
        mine = corner[part == p]
        edges, uses = np.unique(np.sort(mine[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0, return_counts=True)
        assert is_open[p] == bool((uses == 1).any())
        points = positions[np.unique(mine)]
        axes = np.linalg.eigh(np.cov(points.T, bias=True))[1]
        extent = np.sort(np.ptp(points @ axes, axis=0))
        expected = np.linalg.norm(extent) < AGGREGATE_SMALL * diagonal or extent[1] < AGGREGATE_THIN * extent[2]
        assert shaped[p] == expected
    assert is_open.sum() == 30 + 40 + 30 and 0 < shaped.sum() < parts
