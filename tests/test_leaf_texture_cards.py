"""The ``cards`` start that keeps an input's own leaf texture (``lookalike.init.leaf_texture_cards``)
and its latent, the mesh with its materials held and a tint per material fitted
(``lookalike.fit.tinted_mesh``)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from lookalike import io
from lookalike.asset import Asset, Material, Mesh, Texture
from lookalike.fit.textured_mesh import TexturedMesh, render_asset
from lookalike.fit.tinted_mesh import TintedMesh, surface_of
from lookalike.init.initial_guess import InitialGuess
from lookalike.init.leaf_texture_cards import LEAF_GROWTH, joined_meshes, leaf_texture_cards, spread_parts
from lookalike.jobs.cards import CARDS_DEFAULTS, cards_guess, cards_latent, keeps_input_textures
from lookalike.jobs.run import run_settings, take_best_start
from lookalike.jobs.cards import CARDS
from lookalike.samples.foliage import game_tree
from lookalike.shading import Camera, PointLight


@pytest.fixture(scope="module")
def tree() -> Asset:
    """A small game's tree: 300 leaf-cluster quads sharing one leaf texture, on low-poly bark."""
    return game_tree(seed=3, cards=300, branches=4)


def leaf_index(asset: Asset) -> int:
    return next(i for i, m in enumerate(asset.materials) if m.uses_alpha)


def test_the_start_keeps_the_input_s_leaf_texture_and_its_uvs_land_in_its_used_area(tree):
    budget = tree.mesh.num_triangles // 8
    start = leaf_texture_cards(tree, budget, np.random.default_rng(0))
    assert start is not None and start.mesh.num_triangles <= budget
    leaf = leaf_index(tree)
    # no new atlas: the start's materials are the input's, texel for texel
    assert start.materials[leaf].kd.data is tree.materials[leaf].kd.data
    assert keeps_input_textures(tree, start)
    # every UV of a kept leaf is one of the input's leaves' UVs (inside the texture's used area)
    def leaf_uvs(asset):
        v_tex, t_tex = asset.mesh.uv[0]
        mine = asset.mesh.t_mat_idx == leaf
        return v_tex[t_tex[mine].reshape(-1)].numpy()
    used = {tuple(uv) for uv in leaf_uvs(tree).round(6)}
    kept = leaf_uvs(start)
    assert len(kept) > 0 and all(tuple(uv) in used for uv in kept.round(6))
    # and each kept triangle's UVs span texels the input's leaves show (alpha above the cutoff)
    opaque = tree.materials[leaf].kd.data[..., 3].numpy() > tree.materials[leaf].alpha_cutoff
    size = np.array(opaque.shape[::-1])
    for corners in kept.reshape(-1, 3, 2):
        low, high = np.floor(corners.min(0) * size).astype(int), np.ceil(corners.max(0) * size).astype(int)
        assert opaque[low[1]:high[1], low[0]:high[0]].any()


def leaf_area(asset: Asset, material: int) -> float:
    corners = asset.mesh.v_pos[asset.mesh.t_pos_idx[asset.mesh.t_mat_idx == material]].double()
    return float(0.5 * torch.linalg.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]).norm(dim=1).sum())


def test_fewer_larger_leaves_and_the_bark_decimated(tree):
    leaf = leaf_index(tree)
    start = leaf_texture_cards(tree, tree.mesh.num_triangles // 8, np.random.default_rng(1))
    kept, total = (int((asset.mesh.t_mat_idx == leaf).sum()) // 2 for asset in (start, tree))
    assert 0 < kept < total
    # each kept quad grows in area by (1 / lambda)^LEAF_GROWTH (the mean over the kept ones
    # against the mean over all: within a tenth, the quads' sizes varying a little)
    growth = (total / kept) ** LEAF_GROWTH
    assert leaf_area(start, leaf) / kept == pytest.approx(growth * leaf_area(tree, leaf) / total, rel=0.1)
    bark = 1 - leaf
    assert 0 < int((start.mesh.t_mat_idx == bark).sum()) < int((tree.mesh.t_mat_idx == bark).sum())


def test_the_start_is_not_offered_where_the_leaves_are_not_one_alpha_textured_material(tree):
    leaf = leaf_index(tree)
    opaque = [dataclasses.replace(m, alpha_mode="OPAQUE") for m in tree.materials]
    assert leaf_texture_cards(dataclasses.replace(tree, materials=opaque), 200, np.random.default_rng(0)) is None
    flat = list(tree.materials)
    flat[leaf] = dataclasses.replace(flat[leaf], kd=Texture.constant([0.2, 0.5, 0.1, 0.6]))
    assert leaf_texture_cards(dataclasses.replace(tree, materials=flat), 200, np.random.default_rng(0)) is None
    # a budget that leaves the bark too few triangles for a shape: not offered either
    assert leaf_texture_cards(tree, 20, np.random.default_rng(0)) is None


def test_joined_meshes_offset_every_index_by_the_rows_before():
    quad = Mesh(v_pos=torch.rand(4, 3), t_pos_idx=torch.tensor([[0, 1, 2], [0, 2, 3]]),
                uv=[(torch.rand(4, 2), torch.tensor([[0, 1, 2], [0, 2, 3]]))], t_mat_idx=torch.tensor([1, 1]))
    tri = Mesh(v_pos=torch.rand(3, 3), t_pos_idx=torch.tensor([[0, 1, 2]]),
               uv=[(torch.rand(3, 2), torch.tensor([[0, 1, 2]]))], t_nrm_idx=torch.tensor([[0, 1, 0]]))
    out = joined_meshes([quad, tri])
    assert out.t_pos_idx.tolist() == [[0, 1, 2], [0, 2, 3], [4, 5, 6]]
    assert out.uv[0][1].tolist() == [[0, 1, 2], [0, 2, 3], [4, 5, 6]]
    assert out.t_nrm_idx.tolist() == [[0, 1, 2], [0, 2, 3], [4, 5, 4]]
    assert out.t_mat_idx.tolist() == [1, 1, 0]
    assert torch.equal(out.v_pos[out.t_pos_idx[2]], tri.v_pos)


def tinted_latent(tree: Asset, start: Asset) -> TintedMesh:
    cfg = run_settings(CARDS, None, {"texture_size": 64})
    latent = cards_latent(tree, start, cfg, False)
    assert isinstance(latent, TintedMesh)
    return latent


def test_cards_fits_a_start_of_the_input_s_textures_by_its_vertices_and_tints(tree):
    start = leaf_texture_cards(tree, tree.mesh.num_triangles // 8, np.random.default_rng(0))
    latent = tinted_latent(tree, start)
    groups = latent.parameter_groups()
    assert [p.shape for p in groups["textures"]] == [torch.Size([2, 3])]
    assert groups["positions"][0].shape[0] == start.mesh.num_vertices
    cloud = cards_guess(tree, run_settings(CARDS, None, {"texture_size": 64}), 200).start
    assert not keeps_input_textures(tree, cloud)
    assert isinstance(cards_latent(tree, cloud, run_settings(CARDS, None, {"texture_size": 64}), False), TexturedMesh)


def test_a_tint_fitted_to_a_darker_texture_darkens_by_as_much(tree):
    """Gradient through the tint: drawn against the same start whose leaf texture is 0.6 times
    as bright, a few Adam steps on the tint alone bring the leaf tint to 0.6 (within 0.05), the
    bark's staying at 1."""
    start = leaf_texture_cards(tree, tree.mesh.num_triangles // 8, np.random.default_rng(0))
    leaf = leaf_index(tree)
    darker = list(start.materials)
    kd = darker[leaf].kd.data
    darker[leaf] = dataclasses.replace(darker[leaf], kd=Texture(torch.cat([kd[..., :3] * 0.6, kd[..., 3:]], -1)))
    target_asset = dataclasses.replace(start, materials=darker)
    latent = tinted_latent(tree, start)
    centre, radius = tree.mesh.bounding_sphere()
    camera = Camera.looking_at((centre + torch.tensor([0.0, 0.3, 2.5]) * radius)[None], centre[None], fovy=0.8)
    light = PointLight((centre + torch.tensor([1.0, 2.0, 3.0]) * radius)[None], torch.full((1, 3), 14.0 * radius ** 2))
    draw = dict(resolution=64, msaa=1, layers=4)
    target = render_asset(target_asset, camera, light, **draw)
    optimiser = torch.optim.Adam([latent.tint], lr=0.05)
    for _ in range(60):
        optimiser.zero_grad()
        loss = ((render_asset(latent.as_asset(0.0), camera, light, **draw) - target) ** 2).mean()
        loss.backward()
        optimiser.step()
        latent.clamp_()
    assert latent.tint[leaf].detach().numpy() == pytest.approx([0.6, 0.6, 0.6], abs=0.05)
    assert latent.tint[1 - leaf].detach().numpy() == pytest.approx([1.0, 1.0, 1.0], abs=0.05)


def test_the_written_model_of_the_kept_start_writes_the_input_s_leaf_texture_tinted_not_a_new_atlas(tree, tmp_path):
    start = leaf_texture_cards(tree, tree.mesh.num_triangles // 8, np.random.default_rng(0))
    leaf = leaf_index(tree)
    latent = tinted_latent(tree, start)
    with torch.no_grad():
        latent.tint[leaf] = torch.tensor([0.8, 0.9, 0.7])
    io.save(latent.export(), tmp_path / "model.glb")
    written = io.load(tmp_path / "model.glb")
    textured = [m for m in written.materials if m.uses_alpha]
    assert len(textured) == 1
    source = tree.materials[leaf].kd.data
    assert textured[0].kd.data.shape == source.shape            # the input's resolution: no atlas
    visible = source[..., 3] >= tree.materials[leaf].alpha_cutoff
    expected = (source[..., :3] * torch.tensor([0.8, 0.9, 0.7]))[visible]
    assert (textured[0].kd.data[..., :3][visible] - expected).abs().max() < 0.01  # 8-bit sRGB rounding


def test_a_run_starts_from_the_start_that_scores_higher_as_written_and_says_which():
    small = Asset(mesh=Mesh(v_pos=torch.rand(3, 3), t_pos_idx=torch.tensor([[0, 1, 2]])))
    large = Asset(mesh=Mesh(v_pos=torch.rand(6, 3), t_pos_idx=torch.tensor([[0, 1, 2], [3, 4, 5]])))

    def score(asset):  # each start's score is its number of triangles
        return asset.mesh.num_triangles

    guess = InitialGuess(start=small, baseline=small, bake=None, notes=[], alternatives=[("the larger", large)])
    take_best_start(guess, score, "Billboard cloud")
    assert guess.start is large and guess.start_label == "The larger"
    assert guess.comparisons == [("usual_start", "Billboard cloud", small)]
    assert "started from the larger" in guess.notes[-1]
    kept = InitialGuess(start=large, baseline=large, bake=None, notes=[], alternatives=[("the smaller", small)])
    take_best_start(kept, score, "Billboard cloud")
    assert kept.start is large and kept.alternatives == [] and kept.start_label is None
    assert kept.notes == ["started from the billboard cloud: it scored higher on the validation views (2.00 dB) than "
                          "the smaller (1.00 dB)"]


def test_the_kept_leaves_are_spread_over_the_crown_within_the_budget():
    """Two clumps of 50 two-triangle leaves each, 4 triangles to spend: one leaf of each clump,
    each the one nearest its clump's centre (a random draw takes both from one clump half the
    time)."""
    rng = np.random.default_rng(0)
    clumps = [rng.normal(scale=0.1, size=(50, 3)) + offset for offset in ([0, 0, 0], [5, 0, 0])]
    centroid = np.concatenate(clumps)
    keep = spread_parts(centroid, np.full(100, 2), 4, np.random.default_rng(1))
    assert keep.sum() == 2 and keep[:50].sum() == 1 and keep[50:].sum() == 1
    for half, chosen in ((clumps[0], np.flatnonzero(keep[:50])[0]), (clumps[1], np.flatnonzero(keep[50:])[0])):
        assert np.linalg.norm(half[chosen] - half.mean(0)) <= np.sort(np.linalg.norm(half - half.mean(0), axis=1))[2]
    # an odd budget keeps what fits; parts larger than the budget keep one
    assert spread_parts(centroid, np.full(100, 2), 5, np.random.default_rng(1)).sum() == 2
    assert spread_parts(centroid, np.full(100, 8), 4, np.random.default_rng(1)).sum() == 1
