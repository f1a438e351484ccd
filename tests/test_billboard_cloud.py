"""Billboard clouds: planes recovered from noisy planar clusters, a bake that reproduces colour,
coverage and front-to-back compositing, one card per part, spare cards that split parts without
mixing them, the card budget, triangle moments, determinism, and a non-overlapping atlas."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from mesh_factory import icosphere

from lookalike.asset import Asset, Material, Mesh, Texture
from lookalike.errors import ConfigError
from lookalike.init.billboard_cloud import (
    CHART_GAP,
    allocate_cards,
    billboard_cloud,
    triangle_moments,
)


def soup(corners: np.ndarray, uv: np.ndarray | None = None) -> Mesh:
    """A mesh of the triangles ``corners [T, 3, 3]``, each with its own vertices (and UVs ``[T, 3, 2]``)."""
    t_pos_idx = torch.arange(3 * len(corners)).reshape(-1, 3)
    uvs = [] if uv is None else [(torch.from_numpy(uv.reshape(-1, 2)).float(), t_pos_idx.clone())]
    return Mesh(v_pos=torch.from_numpy(corners.reshape(-1, 3)).float(), t_pos_idx=t_pos_idx, uv=uvs)


def frame(normal) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A right-handed orthonormal frame ``(e1, e2, n)`` around ``normal``."""
    n = np.asarray(normal, np.float64) / np.linalg.norm(normal)
    e1 = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(n, e1), n


def square(centre, normal, half: float) -> np.ndarray:
    """``[2, 3, 3]`` a square of side ``2 half`` about ``centre`` facing ``normal`` (counter-clockwise)."""
    e1, e2, _ = frame(normal)
    c = np.asarray(centre, np.float64)
    p = [c + half * (sx * e1 + sy * e2) for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    return np.array([[p[0], p[1], p[2]], [p[0], p[2], p[3]]])


def square_uv() -> np.ndarray:
    """``[2, 3, 2]`` UVs of ``square``'s corners: the whole texture, upright."""
    uv = [(0.0, 1.0), (1.0, 1.0), (1.0, 0.0), (0.0, 0.0)]
    return np.array([[uv[0], uv[1], uv[2]], [uv[0], uv[2], uv[3]]])


KNOWN_PLANES = [((-2.0, 0.0, 0.0), (0.0, 0.0, 1.0)), ((2.0, 0.0, 0.5), (1.0, 0.0, 0.3)),
                ((0.0, 2.5, 0.0), (0.2, 1.0, 0.7))]


def noisy_planes(rng: np.random.Generator, per_plane: int = 100, jitter: float = 0.01) -> np.ndarray:
    """``[3 per_plane, 3, 3]`` small separate triangles (side ~0.1) scattered over a unit disc of
    each plane of ``KNOWN_PLANES``, their corners jittered off it by up to ``jitter``."""
    triangles = []
    for centre, normal in KNOWN_PLANES:
        e1, e2, n = frame(normal)
        radius, angle = np.sqrt(rng.uniform(0, 1, per_plane)), rng.uniform(0, 2 * np.pi, per_plane)
        middle = np.asarray(centre) + (radius * np.cos(angle))[:, None] * e1 + (radius * np.sin(angle))[:, None] * e2
        offsets = rng.uniform(-0.05, 0.05, (per_plane, 3, 2))
        corners = middle[:, None] + offsets[..., :1] * e1 + offsets[..., 1:] * e2
        triangles.append(corners + rng.uniform(-jitter, jitter, (per_plane, 3, 1)) * n)
    return np.concatenate(triangles)


def leaves(rng: np.random.Generator, count: int) -> np.ndarray:
    """``[2 count, 3, 3]`` separate unit-ish squares (side 0.2 .. 0.4) at random places and orientations."""
    return np.concatenate([square(rng.uniform(-2, 2, 3), rng.normal(size=3), rng.uniform(0.1, 0.2))
                           for _ in range(count)])


def chart_boxes(cloud) -> np.ndarray:
    """``[Q, 4]`` each card's UV rectangle ``(u0, v0, u1, v1)``."""
    uv = cloud.asset.mesh.uv[0][0].numpy().reshape(-1, 4, 2)
    return np.concatenate([uv.min(axis=1), uv.max(axis=1)], axis=1)


def texel_world_points(cloud, card: int, size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(rows [K], cols [K], points [K, 3])``: the texels of ``card``'s chart and the world points
    their centres map to on the card (the affine map of its first triangle's UVs to positions)."""
    mesh = cloud.asset.mesh
    corners = mesh.v_pos.double().numpy()[mesh.t_pos_idx[2 * card].numpy()]
    uv = mesh.uv[0][0].double().numpy()[mesh.uv[0][1][2 * card].numpy()]
    u0, v0, u1, v1 = np.rint(chart_boxes(cloud)[card] * size).astype(int)
    rows, cols = np.meshgrid(np.arange(v0, v1), np.arange(u0, u1), indexing="ij")
    rows, cols = rows.reshape(-1), cols.reshape(-1)
    centre_uv = np.stack([(cols + 0.5) / size, (rows + 0.5) / size], axis=1)
    basis = np.stack([uv[1] - uv[0], uv[2] - uv[0]], axis=1)                      # [2 uv, 2 edges]
    weights = np.linalg.solve(basis, (centre_uv - uv[0]).T).T                     # [K, 2] edge weights
    points = corners[0] + weights[:, :1] * (corners[1] - corners[0]) + weights[:, 1:] * (corners[2] - corners[0])
    return rows, cols, points


def test_the_cards_recover_the_planes_of_noisy_planar_clusters():
    corners = noisy_planes(np.random.default_rng(1))
    asset = Asset(mesh=soup(corners), materials=[Material(double_sided=True)])
    cloud = billboard_cloud(asset, triangles=6, texture_size=64, rng=np.random.default_rng(0))
    assert len(cloud.normals) == 3 and cloud.notes[0].startswith("3 cards over 300 parts")
    for index, (centre, normal) in enumerate(KNOWN_PLANES):
        cards = np.unique(cloud.card_of_triangle[index * 100:(index + 1) * 100])
        assert len(cards) == 1
        card = int(cards[0])
        n = np.asarray(normal) / np.linalg.norm(normal)
        assert abs(cloud.normals[card] @ n) > math.cos(math.radians(2.0))
        assert abs(cloud.normals[card] @ centre - cloud.offsets[card]) < 0.03
        quad = cloud.asset.mesh.v_pos.double().numpy()[4 * card:4 * card + 4]
        assert np.abs(quad @ cloud.normals[card] - cloud.offsets[card]).max() < 1e-5       # the quad lies in its plane
        face = np.cross(quad[3] - quad[2], quad[1] - quad[2])
        assert face @ cloud.normals[card] > 0                                               # and faces +n
        sides = np.linalg.norm(quad[1] - quad[0]), np.linalg.norm(quad[2] - quad[0])
        assert 1.7 < min(sides) and max(sides) < 2.2                                        # spans the unit disc


def test_a_textured_square_bakes_onto_its_card_with_its_colour_and_coverage():
    """In the square's own coordinates ``(s, t)`` (``frame``): left half (s < 0) red, right half
    blue, alpha masked to a disc of radius 0.8: the card shows it."""
    res = 64
    x = 2 * (np.arange(res) + 0.5) / res - 1
    s, t = np.meshgrid(x, -x, indexing="xy")                     # (s, t) at each texel of the source
    kd = np.zeros((res, res, 4), np.float32)
    kd[..., :3] = np.where((s < 0)[..., None], [0.8, 0.1, 0.1], [0.1, 0.2, 0.9])
    kd[..., 3] = s ** 2 + t ** 2 < 0.64
    material = Material(kd=Texture(torch.from_numpy(kd)), alpha_mode="MASK")
    asset = Asset(mesh=soup(square((0, 0, 0), (0, 0, 1), 1.0), square_uv()), materials=[material])
    size = 64
    cloud = billboard_cloud(asset, triangles=2, texture_size=size, rng=np.random.default_rng(0))
    made = cloud.asset.materials[0]
    assert cloud.notes == ["one card per part (1 part)"]
    assert (made.alpha_mode, made.double_sided, made.kd.wrap) == ("BLEND", True, "clamp")
    rows, cols, points = texel_world_points(cloud, 0, size)
    texels = made.kd.data.numpy()[rows, cols]
    e1, e2, _ = frame((0, 0, 1))
    s, t = points @ e1, points @ e2
    radius = np.hypot(s, t)
    inside = (radius < 0.7) & (np.abs(s) > 0.1)
    outside = radius > 0.9
    assert np.abs(points[:, 2]).max() < 1e-6 and inside.sum() > 1000 and outside.sum() > 300
    assert np.abs(texels[inside, 3] - 1).max() < 1e-3 and np.abs(texels[outside, 3]).max() < 1e-3
    red = inside & (s < 0)
    assert np.abs(texels[red, :3] - [0.8, 0.1, 0.1]).max() < 1e-3
    assert np.abs(texels[inside & ~red, :3] - [0.1, 0.2, 0.9]).max() < 1e-3
    quad = cloud.asset.mesh.v_pos.double().numpy()
    quad_area = np.linalg.norm(np.cross(quad[1] - quad[0], quad[2] - quad[0]))
    assert 4.0 - 1e-5 < quad_area < 4.25                                   # the square, give or take a turn
    texel_area = quad_area / len(rows)
    assert made.kd.data[..., 3].sum().item() * texel_area == pytest.approx(math.pi * 0.64, rel=0.02)
    normal = made.normal.data.numpy()[rows, cols]
    assert np.abs(normal - [0, 0, 1]).max() < 1e-4                                          # flat, facing the card
    assert (made.kd.data[..., :3].numpy().min(axis=-1) > 0.05).all()                       # no black under alpha 0


def test_layers_are_composited_front_to_back():
    """Two parallel half-transparent squares 0.01 apart on one card: red in front (the side the
    card faces), blue behind: alpha 1 - 0.5^2, colour (0.5 red + 0.25 blue) / 0.75."""
    def layer(colour):
        return Material(kd=Texture.constant([*colour, 0.5]), alpha_mode="BLEND")

    corners = np.concatenate([square((0, 0, 0.01), (0, 0, 1), 1.0), square((0, 0, 0), (0, 0, 1), 1.0)])
    mesh = soup(corners)
    mesh.t_mat_idx = torch.tensor([0, 0, 1, 1])
    asset = Asset(mesh=mesh, materials=[layer((1.0, 0.0, 0.0)), layer((0.0, 0.0, 1.0))])
    cloud = billboard_cloud(asset, triangles=3, texture_size=32, rng=np.random.default_rng(0))
    assert len(cloud.normals) == 1 and cloud.normals[0] @ [0, 0, 1] > 0.999
    rows, cols, points = texel_world_points(cloud, 0, 32)
    on_both = np.abs(points[:, :2]).max(axis=1) < 0.95
    kd = cloud.asset.materials[0].kd.data.numpy()[rows[on_both], cols[on_both]]
    assert on_both.sum() > 500 and np.abs(kd - [2 / 3, 0, 1 / 3, 0.75]).max() < 1e-4


def test_one_card_per_part_when_the_budget_allows_and_spare_cards_split_the_largest():
    corners = leaves(np.random.default_rng(2), 5)                         # 5 parts of 2 triangles
    corners[8:] = 3 * (corners[8:] - corners[8:].mean(axis=(0, 1))) + corners[8:].mean(axis=(0, 1))   # the largest
    asset = Asset(mesh=soup(corners))
    cloud = billboard_cloud(asset, triangles=10, texture_size=64, rng=np.random.default_rng(0))
    assert cloud.notes == ["one card per part (5 parts)"]
    pairs = cloud.card_of_triangle.reshape(5, 2)
    assert (pairs[:, 0] == pairs[:, 1]).all() and len(np.unique(pairs)) == 5
    more = billboard_cloud(asset, triangles=12, texture_size=64, rng=np.random.default_rng(0))
    assert len(more.normals) == 6 and more.notes[0].startswith("6 cards over 5 parts")
    assert len(np.unique(more.card_of_triangle[8:])) == 2 and len(np.unique(more.card_of_triangle[:8])) == 4
    most = billboard_cloud(asset, triangles=40, texture_size=64, rng=np.random.default_rng(0))
    assert len(most.normals) == 10 and "only 10 of the 20 cards" in most.notes[-1]   # one per triangle at most


def grid_leaf(centre, normal, half: float, cells: int = 3) -> np.ndarray:
    """``[2 cells^2, 3, 3]`` a square of side ``2 half`` about ``centre`` facing ``normal``, as a
    ``cells x cells`` grid of quads (one part: neighbours share exact corner positions)."""
    e1, e2, _ = frame(normal)
    g = np.linspace(-half, half, cells + 1)
    points = np.asarray(centre, np.float64) + g[:, None, None] * e1 + g[None, :, None] * e2    # [c+1, c+1, 3]
    a, b, c, d = points[:-1, :-1], points[1:, :-1], points[1:, 1:], points[:-1, 1:]
    return np.concatenate([np.stack([a, b, c], -2).reshape(-1, 3, 3), np.stack([a, c, d], -2).reshape(-1, 3, 3)])


def test_spare_cards_split_parts_without_mixing_them():
    """Six overlapping grid leaves crossing one another: each card still holds one leaf's triangles,
    and each leaf gets the cards ``allocate_cards`` gives it."""
    rng = np.random.default_rng(6)
    parts = [grid_leaf(rng.uniform(-0.1, 0.1, 3), rng.normal(size=3), rng.uniform(0.5, 1.0)) for _ in range(6)]
    cloud = billboard_cloud(Asset(mesh=soup(np.concatenate(parts))), triangles=30, texture_size=128,
                            rng=np.random.default_rng(0))
    part_of_triangle = np.repeat(np.arange(6), 18)
    assert len(cloud.normals) == 15
    for card in range(15):
        assert len(np.unique(part_of_triangle[cloud.card_of_triangle == card])) == 1
    area = np.array([np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=-1).sum() / 2 for p in parts])
    per_part = [len(np.unique(cloud.card_of_triangle[part_of_triangle == k])) for k in range(6)]
    np.testing.assert_array_equal(per_part, allocate_cards(area, np.full(6, 18), 15))


def test_triangle_moments_match_sampling():
    corners = np.random.default_rng(8).normal(size=(1, 3, 3))
    moments = triangle_moments(corners)
    r = np.random.default_rng(9).uniform(size=(200000, 2))
    r = np.where(r.sum(axis=1, keepdims=True) > 1, 1 - r, r)                 # uniform on the triangle
    points = corners[0, 0] + r[:, :1] * (corners[0, 1] - corners[0, 0]) + r[:, 1:] * (corners[0, 2] - corners[0, 0])
    np.testing.assert_allclose(moments.second[0], points.T @ points / len(points), atol=0.02)
    assert moments.area[0] == pytest.approx(0.5 * np.linalg.norm(np.cross(*(corners[0, 1:] - corners[0, 0]))))


def test_a_connected_mesh_is_split_into_clusters_of_its_triangles():
    sphere = icosphere(2)
    cloud = billboard_cloud(Asset(mesh=sphere), triangles=24, texture_size=64, rng=np.random.default_rng(0))
    assert len(cloud.normals) == 12 and "the triangles of the input's one part" in cloud.notes[0]
    centres = np.stack([sphere.v_pos.numpy()[sphere.t_pos_idx.numpy()[cloud.card_of_triangle == q]].mean(axis=(0, 1))
                        for q in range(12)])
    outward = (cloud.normals * centres).sum(axis=1) / np.linalg.norm(centres, axis=1)
    assert outward.min() > 0.8                                              # each card faces out of its patch


def test_allocate_cards_gives_the_spare_cards_by_area():
    np.testing.assert_array_equal(allocate_cards(np.array([1.0, 1.0, 4.0]), np.array([10, 10, 10]), 6), [1, 1, 4])
    np.testing.assert_array_equal(allocate_cards(np.array([1.0, 1.0, 4.0]), np.array([10, 10, 2]), 6), [2, 2, 2])
    np.testing.assert_array_equal(allocate_cards(np.array([1.0, 2.0]), np.array([3, 3]), 9), [3, 3])
    np.testing.assert_array_equal(allocate_cards(np.array([1.0, 1.0, 1.0]), np.array([5, 5, 5]), 4), [2, 1, 1])


def test_the_same_seed_gives_the_same_cloud():
    corners = noisy_planes(np.random.default_rng(5), per_plane=60, jitter=0.2)
    asset = Asset(mesh=soup(corners))
    first, second = (billboard_cloud(asset, triangles=20, texture_size=64, rng=np.random.default_rng(11))
                     for _ in range(2))
    np.testing.assert_array_equal(first.card_of_triangle, second.card_of_triangle)
    np.testing.assert_array_equal(first.normals, second.normals)
    np.testing.assert_array_equal(first.offsets, second.offsets)
    for a, b in ((first.asset.mesh.v_pos, second.asset.mesh.v_pos),
                 (first.asset.mesh.uv[0][0], second.asset.mesh.uv[0][0]),
                 (first.asset.materials[0].kd.data, second.asset.materials[0].kd.data)):
        assert torch.equal(a, b)


def test_uvs_lie_in_the_atlas_and_charts_keep_apart():
    asset = Asset(mesh=soup(leaves(np.random.default_rng(4), 40)))
    size = 128
    cloud = billboard_cloud(asset, triangles=60, texture_size=size, rng=np.random.default_rng(0))
    boxes = chart_boxes(cloud) * size
    assert len(boxes) == 30 and boxes.min() >= 0 and boxes.max() <= size
    assert np.allclose(boxes, np.round(boxes), atol=1e-3)                    # corners on texel edges
    gap_u = np.maximum(boxes[:, None, 0] - boxes[None, :, 2], boxes[None, :, 0] - boxes[:, None, 2])
    gap_v = np.maximum(boxes[:, None, 1] - boxes[None, :, 3], boxes[None, :, 1] - boxes[:, None, 3])
    apart = np.maximum(gap_u, gap_v) >= CHART_GAP - 1e-3
    assert apart[~np.eye(len(boxes), dtype=bool)].all()
    area = (boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1])
    assert area.sum() > 0.3 * size * size                                   # the charts fill the atlas


def test_bad_budgets_and_sizes_are_config_errors():
    asset = Asset(mesh=soup(leaves(np.random.default_rng(0), 3)))
    with pytest.raises(ConfigError, match="at least 2 triangles"):
        billboard_cloud(asset, triangles=1, texture_size=64, rng=np.random.default_rng(0))
    with pytest.raises(ConfigError, match="texture size"):
        billboard_cloud(asset, triangles=4, texture_size=0, rng=np.random.default_rng(0))
    with pytest.raises(ConfigError, match="cannot hold"):
        billboard_cloud(asset, triangles=6, texture_size=4, rng=np.random.default_rng(0))
    invisible = Asset(mesh=asset.mesh, materials=[Material(kd=Texture.constant([1, 1, 1, 0]), alpha_mode="BLEND")])
    with pytest.raises(ConfigError, match="transparent all over"):
        billboard_cloud(invisible, triangles=6, texture_size=64, rng=np.random.default_rng(0))


def test_triangles_edge_on_to_their_card_bake_no_undefined_texels():
    """A tree's bark has triangles seen edge-on from their card; they add nothing to its
    texels, which stay finite (their barycentrics are not)."""
    from lookalike.samples.foliage import broadleaf_tree

    cloud = billboard_cloud(broadleaf_tree(3), 500, 1024, np.random.default_rng((0, 2)))
    for material in cloud.asset.materials:
        for texture in (material.kd, material.ks, material.normal):
            assert torch.isfinite(texture.data).all()
