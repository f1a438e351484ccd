"""The cards' start with the input's solid parts kept as a mesh (``lookalike.init.trunk_and_cards``):
the broadleaf tree's bark stays one connected mesh of its share of the budget beside card quads,
in its own opaque square of the one atlas; inputs whose solid parts earn too few triangles get
exactly the billboard cloud; the share rule, the packing around the square, the channels'
merge, the split of parts into solid and card-like, and a ``cards`` run that writes the tree so."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from lookalike import io
from lookalike.asset import Material, Texture
from lookalike.asset.parts import card_like_parts, survey_parts, triangle_parts
from lookalike.init.billboard_cloud import CHART_GAP, billboard_cloud, shelf_pack
from lookalike.init.trunk_and_cards import (
    MIN_KEPT_TRIANGLES,
    kept_mesh,
    kept_triangles,
    merged_material,
    triangle_subset,
    trunk_and_cards,
)
from lookalike.jobs.cards import CARDS_DEFAULTS, cards
from lookalike.samples.foliage import broadleaf_tree, grass_tuft
from lookalike.samples.shrub import shrub
from lookalike.settings import config_from_dict

BUDGET, SIZE = 212, 128


@pytest.fixture(scope="module")
def tree():
    return broadleaf_tree(0, cards=300, branches=3)


@pytest.fixture(scope="module")
def tree_start(tree):
    return trunk_and_cards(tree, BUDGET, SIZE, np.random.default_rng(0))


def kept_square(cloud) -> float:
    """The side, in texels, of the atlas square the kept mesh's UVs reach (at most the square's)."""
    mesh = cloud.asset.mesh
    uv = mesh.uv[0][0].numpy()[mesh.uv[0][1][-cloud.kept:].numpy()]
    return float(uv.max()) * SIZE


def arrays(thing) -> list[torch.Tensor]:
    """Every tensor of a ``Mesh`` (positions, triangles, UVs) or a ``Material`` (its textures)."""
    if isinstance(thing, Material):
        return [t.data for t in (thing.kd, thing.ks, thing.normal, thing.emissive, thing.occlusion) if t is not None]
    return [thing.v_pos, thing.t_pos_idx, *thing.uv[0]]


def test_the_tree_keeps_its_bark_as_one_mesh_beside_card_quads(tree, tree_start):
    mesh = tree_start.asset.mesh
    kept = tree_start.kept
    assert MIN_KEPT_TRIANGLES <= kept <= BUDGET // 2 and mesh.num_triangles == BUDGET
    v_pos, tri = mesh.v_pos.numpy(), mesh.t_pos_idx.numpy()
    assert triangle_parts(v_pos, tri[-kept:]).max() == 0                     # one connected mesh
    height = float(tree.mesh.v_pos[:, 1].max())
    trunk_y = v_pos[np.unique(tri[-kept:]), 1]
    assert trunk_y.min() < 0.05 * height and trunk_y.max() > 0.5 * height   # the trunk, from its foot up
    cards = tri[:-kept]
    assert cards.max() < 4 * len(cards) // 2 <= tri[-kept:].min()           # quads first, the mesh after
    np.testing.assert_array_equal(np.bincount(triangle_parts(v_pos, cards)), np.full(len(cards) // 2, 2))
    quads = v_pos[np.arange(4 * (len(cards) // 2))].reshape(-1, 4, 3).astype(np.float64)
    normal = np.cross(quads[:, 1] - quads[:, 0], quads[:, 2] - quads[:, 0])
    assert np.abs(np.einsum("qd,qd->q", normal, quads[:, 3] - quads[:, 0])).max() < 1e-5   # flat quads
    bark = tree.mesh.t_mat_idx.numpy() == 0
    np.testing.assert_array_equal(tree_start.card_of_triangle < 0, bark)
    assert len(tree_start.normals) == len(cards) // 2
    assert f"kept as a mesh of {kept} triangles" in tree_start.notes[0]
    assert tree_start.kept_distance["triangles"] == kept                     # how far it strays from the bark
    assert tree_start.kept_distance["of"] == "the solid parts kept as a mesh beside the cards"


def test_the_kept_mesh_has_its_own_opaque_square_of_the_one_atlas(tree, tree_start):
    material, = tree_start.asset.materials
    assert material.alpha_mode == "BLEND" and material.double_sided and material.kd.wrap == "clamp"
    kd = material.kd.data.numpy()
    assert kd.shape == (SIZE, SIZE, 4) and material.normal.data.shape == (SIZE, SIZE, 3)
    side = kept_square(tree_start)
    assert 0 < side <= SIZE / 2
    square = kd[:math.ceil(side), :math.ceil(side)]
    assert (square[..., 3] == 1).all()
    bark = tree.materials[0].kd.data[..., :3].reshape(-1, 3).mean(0).numpy()
    np.testing.assert_allclose(square[..., :3].reshape(-1, 3).mean(0), bark, atol=0.01)   # bark, not leaves
    mesh = tree_start.asset.mesh
    cards = mesh.num_triangles - tree_start.kept
    uv = mesh.uv[0][0].numpy()[mesh.uv[0][1][:cards].numpy()].reshape(-1, 6, 2) * SIZE
    low = uv.min(axis=1)
    assert ((low[:, 0] >= side) | (low[:, 1] >= side)).all()                 # no card chart in the square


@pytest.mark.parametrize("make, triangles, size", [(lambda: shrub(0, leaves=300, branches=2), 120, 64),
                                                   (lambda: grass_tuft(0, blades=40), 60, 128)])
def test_solid_parts_below_their_minimum_give_exactly_the_billboard_cloud(make, triangles, size):
    asset = make()
    survey = survey_parts(asset)
    assert (~card_like_parts(survey)).any()                                  # a trunk, a soil: solid, but small
    ours = trunk_and_cards(asset, triangles, size, np.random.default_rng(3))
    cloud = billboard_cloud(asset, triangles, size, np.random.default_rng(3))
    assert ours.kept == 0 and ours.notes == cloud.notes
    np.testing.assert_array_equal(ours.card_of_triangle, cloud.card_of_triangle)
    for a, b in ((ours.asset.mesh, cloud.asset.mesh), (ours.asset.materials[0], cloud.asset.materials[0])):
        assert all(torch.equal(x, y) for x, y in zip(arrays(a), arrays(b)))


def test_the_solid_share_is_the_geometric_mean_at_most_half_with_the_budgets_parity():
    assert kept_triangles(212, 0.0096, 0.717) == 16                          # floor(212 * 0.0830) = 17, made even
    assert kept_triangles(213, 0.0096, 0.717) == 17
    assert kept_triangles(100, 0.5, 0.9) == 50 and kept_triangles(101, 0.5, 0.9) == 49
    assert kept_triangles(1926, 0.0029, 0.000187) == 0                       # the shrub's trunk: under the minimum
    assert kept_triangles(1000, 0.0, 0.5) == 0


def test_shelves_pack_around_the_reserved_square_without_overlap():
    rng = np.random.default_rng(2)
    sizes = rng.integers(1, 9, (40, 2))
    sizes[0] = (40, 5)                                                       # too wide beside the square
    order = np.lexsort((np.arange(len(sizes)), -sizes[:, 1]))
    size, reserved = 64, 30
    place = shelf_pack(sizes, order, size, reserved)
    assert place is not None
    low, high = place, place + sizes
    assert low.min() >= 0 and high.max() <= size
    assert ((low[:, 0] >= reserved) | (low[:, 1] >= reserved)).all()
    apart_x = np.maximum(low[:, None, 0] - high[None, :, 0], low[None, :, 0] - high[:, None, 0])
    apart_y = np.maximum(low[:, None, 1] - high[None, :, 1], low[None, :, 1] - high[:, None, 1])
    apart = np.maximum(apart_x, apart_y) >= CHART_GAP
    assert apart[~np.eye(len(sizes), dtype=bool)].all()
    assert (low[:, 1] < reserved).sum() > 1                                  # the strip beside it is used


def test_a_channel_only_one_bake_has_is_neutral_on_the_other_side():
    size, side = 16, 4
    cards = Material(kd=Texture(torch.rand(size, size, 4)), ks=Texture(torch.rand(size, size, 3)),
                     normal=Texture(torch.rand(size, size, 3)), occlusion=Texture(torch.full((size, size, 1), 0.5)),
                     alpha_mode="BLEND", double_sided=True)
    kept = Material(kd=Texture(torch.full((side, side, 4), 0.25)), ks=Texture(torch.rand(side, side, 3)),
                    normal=Texture(torch.rand(side, side, 3)), emissive=Texture(torch.full((side, side, 3), 2.0)))
    merged = merged_material(cards, kept, side)
    assert torch.equal(merged.kd.data[:side, :side, :3], kept.kd.data[..., :3])
    assert (merged.kd.data[:side, :side, 3] == 1).all()
    assert torch.equal(merged.kd.data[side:], cards.kd.data[side:]) and torch.equal(merged.ks.data[:side, :side],
                                                                                     kept.ks.data)
    assert (merged.emissive.data[:side, :side] == 2).all() and merged.emissive.data[side:].abs().max() == 0
    assert (merged.occlusion.data[:side, :side] == 1).all() and (merged.occlusion.data[side:] == 0.5).all()
    assert merged.alpha_mode == "BLEND" and merged.double_sided and merged.kd.wrap == "clamp"


def test_the_trees_bark_is_solid_and_its_cards_card_like(tree):
    survey = survey_parts(tree)
    solid = ~card_like_parts(survey)[survey.part]
    np.testing.assert_array_equal(solid, tree.mesh.t_mat_idx.numpy() == 0)


def test_decimating_by_halves_keeps_the_bark_one_piece(tree):
    bark = triangle_subset(tree, tree.mesh.t_mat_idx.numpy() == 0).mesh
    for triangles in (16, 40):
        low = kept_mesh(bark, triangles, 1)
        assert triangles - 2 <= low.num_triangles <= triangles
        assert triangle_parts(low.v_pos.numpy(), low.t_pos_idx.numpy()).max() == 0
        assert float(low.v_pos[:, 1].min()) < 0.05 * float(bark.v_pos[:, 1].max())


def test_a_cards_run_writes_the_tree_with_its_bark_one_mesh_among_quads(tmp_path, tree):
    io.save(tree, tmp_path / "tree.glb")
    settings = {"views": {"pool_size": 8, "refresh_every": 2, "heldout": 4, "validation": 2},
                "render": {"resolution": 48}, "latent": {"texture_size": 128}, "optim": {"checkpoint_seconds": 1e9}}
    result = cards(tmp_path / "tree.glb", tmp_path / "out", triangles=BUDGET, iterations=4,
                   config=config_from_dict(settings, base=CARDS_DEFAULTS), progress=False)
    model = io.load(result.model)
    assert model.mesh.num_triangles == BUDGET
    sizes = np.bincount(triangle_parts(model.mesh.v_pos.numpy(), model.mesh.t_pos_idx.numpy()))
    assert (sizes > 2).sum() == 1 and sizes.max() >= MIN_KEPT_TRIANGLES and (sizes[sizes != sizes.max()] == 2).all()
    assert "kept as a mesh of" in (tmp_path / "out" / "report.html").read_text()
