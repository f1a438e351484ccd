"""The generated foliage of the ``cards`` application: seeded; leaves, needles and blades drawn
as alpha cut-outs on quads; the broadleaf tree's bark one closed part; counts as documented; and
a glTF round trip keeps them."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from lookalike import io
from lookalike.asset.parts import triangle_parts
from lookalike.samples.foliage import (
    BLADE_ROWS,
    BLADES,
    CARDS,
    CONIFER_RINGS,
    CONIFER_SIDES,
    FOLIAGE,
    GAME_CARDS,
    SOIL_SIDES,
    WHORL_BRANCHES,
    WHORLS,
    broadleaf_tree,
    conifer,
    game_tree,
    grass_tuft,
    stitch,
)
from lookalike.samples.shrub import shrub

SMALL = {"broadleaf-tree": lambda seed: broadleaf_tree(seed, cards=150, branches=3),
         "game-tree": lambda seed: game_tree(seed, cards=60, branches=3),
         "grass-tuft": lambda seed: grass_tuft(seed, blades=40),
         "conifer": lambda seed: conifer(seed, whorls=6)}


@pytest.fixture(scope="module")
def default_assets():
    return {"broadleaf-tree": broadleaf_tree(), "game-tree": game_tree(), "grass-tuft": grass_tuft(),
            "conifer": conifer()}


def _arrays(asset):
    mesh = asset.mesh
    return [mesh.v_pos, mesh.t_pos_idx, mesh.t_mat_idx, *mesh.uv[0], *(m.kd.data for m in asset.materials)]


def _triangles(asset, name):
    """Positions ``[V, 3]`` and the triangles ``[T, 3]`` of the material called ``name``."""
    mesh = asset.mesh
    k = [m.name for m in asset.materials].index(name)
    return mesh.v_pos.numpy(), mesh.t_pos_idx[mesh.t_mat_idx == k].numpy()


def _closed_and_outward(v_pos, tri):
    """Every edge joins two triangles that traverse it in opposite directions, and the enclosed
    volume is positive (the faces point outwards)."""
    directed = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    undirected, count = np.unique(np.sort(directed, axis=1), axis=0, return_counts=True)
    corners = v_pos[tri].astype(np.float64)
    volume = np.einsum("ij,ij->i", corners[:, 0], np.cross(corners[:, 1], corners[:, 2])).sum() / 6
    return bool((count == 2).all()) and len(np.unique(directed, axis=0)) == len(directed) and volume > 0


def test_the_registry_names_the_shrub_and_the_four_generators():
    assert FOLIAGE == {"shrub": shrub, "broadleaf-tree": broadleaf_tree, "game-tree": game_tree,
                       "grass-tuft": grass_tuft, "conifer": conifer}


@pytest.mark.parametrize("name", sorted(SMALL))
def test_a_seed_gives_the_same_asset_and_another_seed_another(name):
    first, again, other = SMALL[name](3), SMALL[name](3), SMALL[name](4)
    assert all(torch.equal(a, b) for a, b in zip(_arrays(first), _arrays(again)))
    assert first.fingerprint() == again.fingerprint() != other.fingerprint()
    assert first.mesh.v_pos.shape != other.mesh.v_pos.shape or not torch.equal(first.mesh.v_pos, other.mesh.v_pos)


@pytest.mark.parametrize("name, cutout",
                         [("broadleaf-tree", "leaves"), ("game-tree", "leaves"), ("grass-tuft", "blades"),
                          ("conifer", "needles")])
def test_the_cards_are_alpha_cut_outs_and_the_rest_opaque(default_assets, name, cutout):
    asset = default_assets[name]
    for material in asset.materials:
        if material.name != cutout:
            assert not material.uses_alpha and bool((material.kd.data[..., 3] == 1).all())
            continue
        assert material.uses_alpha and material.alpha_mode == "MASK" and material.alpha_cutoff == 0.5
        assert material.double_sided and material.kd.wrap == "clamp"
        alpha = material.kd.data[..., 3]
        assert bool(((alpha == 0) | (alpha == 1)).all())
        assert 0.1 < float((alpha == 1).float().mean()) < 0.7                 # shapes cut out, not squares
        assert float(material.kd.data[..., 1][alpha == 1].std()) > 0.01          # colour varies
    v_pos, tri = _triangles(asset, cutout)
    v_tex, t_tex_idx = asset.mesh.uv[0]
    k = [m.name for m in asset.materials].index(cutout)
    uv = v_tex[t_tex_idx[asset.mesh.t_mat_idx == k]]
    assert uv.min() >= 0 and uv.max() <= 1


@pytest.mark.parametrize("name, count", [("broadleaf-tree", CARDS), ("game-tree", GAME_CARDS)])
def test_the_tree_bark_is_one_closed_part_and_each_card_a_quad(default_assets, name, count):
    tree = default_assets[name]
    v_pos, bark = _triangles(tree, "bark")
    assert triangle_parts(v_pos, bark).max() == 0
    assert _closed_and_outward(v_pos, bark)
    v_pos, cards = _triangles(tree, "leaves")
    assert np.array_equal(np.bincount(triangle_parts(v_pos, cards)), np.full(count, 2))


@pytest.mark.parametrize("seed", range(1, 7))
def test_the_bark_stays_one_closed_part_for_other_seeds_and_sizes(seed):
    for asset in (broadleaf_tree(seed, cards=10, branches=2 + 2 * seed), game_tree(seed, cards=10, branches=1 + seed),
                  conifer(seed, whorls=3)):
        v_pos, bark = _triangles(asset, "bark")
        assert triangle_parts(v_pos, bark).max() == 0 and _closed_and_outward(v_pos, bark)


def test_the_counts_are_as_documented(default_assets):
    tree, tuft, fir = default_assets["broadleaf-tree"], default_assets["grass-tuft"], default_assets["conifer"]
    bark = int((tree.mesh.t_mat_idx == 0).sum())
    assert 1_500 <= CARDS <= 3_000 and int((tree.mesh.t_mat_idx == 1).sum()) == 2 * CARDS
    assert 5_000 <= bark <= 25_000 and 10_000 <= tree.mesh.num_triangles <= 30_000
    lo, hi = tree.mesh.bounds()
    assert float(lo[1]) == 0 and 4 < float(hi[1]) < 8 and float((hi - lo)[[0, 2]].min()) > 2   # a crown, not a pole

    game = default_assets["game-tree"]                        # a game's budget: a tenth of the bark, larger cards
    assert int((game.mesh.t_mat_idx == 1).sum()) == 2 * GAME_CARDS and game.mesh.num_triangles == 5_604
    assert int((game.mesh.t_mat_idx == 0).sum()) < bark / 4
    lo, hi = game.mesh.bounds()
    assert float(lo[1]) == 0 and 4 < float(hi[1]) < 8 and float((hi - lo)[[0, 2]].min()) > 2

    assert tuft.mesh.num_triangles == BLADES * 2 * BLADE_ROWS + SOIL_SIDES
    v_pos, blades = _triangles(tuft, "blades")
    assert triangle_parts(v_pos, blades).max() + 1 == BLADES and 0.2 < float(tuft.mesh.bounds()[1][1]) < 0.5

    v_pos, trunk = _triangles(fir, "bark")
    assert len(trunk) == 2 * CONIFER_SIDES * (CONIFER_RINGS + 1) and _closed_and_outward(v_pos, trunk)
    cards = int((fir.mesh.t_mat_idx == 1).sum()) // 2
    assert 2 * WHORLS * (WHORL_BRANCHES - 1) <= cards <= 2 * WHORLS * (WHORL_BRANCHES + 1)
    assert float(fir.mesh.bounds()[0][1]) >= 0


@pytest.mark.parametrize("name", sorted(SMALL))
def test_the_assets_survive_a_gltf_round_trip(tmp_path, name):
    asset = SMALL[name](1)
    io.save(asset, tmp_path / f"{name}.glb")
    loaded = io.load(tmp_path / f"{name}.glb")
    assert loaded.mesh.num_triangles == asset.mesh.num_triangles
    assert [m.name for m in loaded.materials] == [m.name for m in asset.materials]
    assert [m.alpha_mode for m in loaded.materials] == [m.alpha_mode for m in asset.materials]
    assert [m.double_sided for m in loaded.materials] == [m.double_sided for m in asset.materials]
    assert torch.equal(torch.bincount(loaded.mesh.t_mat_idx), torch.bincount(asset.mesh.t_mat_idx))


def test_stitch_joins_loops_of_any_sizes_into_a_closed_band():
    lower = (np.arange(4), np.array([0.1, 1.7, 3.2, 4.8]), 0.0)
    upper = (10 + np.arange(9), 2 * np.pi * np.arange(9) / 9 + 3.0, 1.0)   # starts elsewhere, wraps
    tri, uv = stitch(lower, upper)
    assert tri.shape == (13, 3) and uv.shape == (13, 3, 2)
    edges = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    edges, count = np.unique(edges, axis=0, return_counts=True)
    loops = (np.arange(4), 10 + np.arange(9))
    ring = {tuple(sorted((a, b))) for loop in loops for a, b in zip(loop, np.roll(loop, -1))}
    assert {tuple(e) for e in edges[count == 1]} == ring                  # the loops' edges are its border
    assert (count <= 2).all()
    fan, _ = stitch((np.arange(5), 2 * np.pi * np.arange(5) / 5, 0.0), (np.array([7]), np.zeros(1), 1.0))
    assert fan.shape == (5, 3) and (fan[:, 2] == 7).all()               # a tip: no degenerate triangle


@pytest.mark.parametrize("kind", sorted(FOLIAGE))
def test_simplify_suggests_cards_for_every_foliage_kind(kind):
    """The hint (``aggregate_traits``) fires on each kind the cards benchmark uses."""
    from lookalike.asset.parts import aggregate_traits

    assert aggregate_traits(FOLIAGE[kind](0)) is not None
