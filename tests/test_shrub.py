"""The generated shrub of the ``cards`` application: seeded, about 200k triangles, one part per
leaf, alpha-tested leaves, and it survives a glTF round trip."""

from __future__ import annotations

import pytest
import torch

from lookalike import io
from lookalike.asset.parts import triangle_parts
from lookalike.samples.shrub import (
    BRANCHES,
    HEIGHT,
    LEAF_COLS,
    LEAF_ROWS,
    LEAVES,
    RINGS,
    SIDES,
    SUB_BRANCHES,
    shrub,
)

BRANCH_PARTS = 1 + BRANCHES * (1 + SUB_BRANCHES)


@pytest.fixture(scope="module")
def default_shrub():
    return shrub()


def _arrays(asset):
    mesh = asset.mesh
    return [mesh.v_pos, mesh.t_pos_idx, mesh.t_mat_idx, *mesh.uv[0], *(m.kd.data for m in asset.materials)]


def test_a_seed_gives_the_same_shrub_and_another_seed_another():
    first, again, other = shrub(3, leaves=200), shrub(3, leaves=200), shrub(4, leaves=200)
    assert all(torch.equal(a, b) for a, b in zip(_arrays(first), _arrays(again)))
    assert first.mesh.v_pos.shape == other.mesh.v_pos.shape
    assert not torch.equal(first.mesh.v_pos, other.mesh.v_pos)


def test_the_default_shrub_has_hundreds_of_thousands_of_triangles_one_part_per_leaf(default_shrub):
    mesh = default_shrub.mesh
    leaf_triangles = LEAVES * 2 * LEAF_ROWS * LEAF_COLS
    branch_triangles = BRANCH_PARTS * 2 * RINGS * SIDES
    assert mesh.num_triangles == leaf_triangles + branch_triangles >= 100_000
    assert int((mesh.t_mat_idx == 1).sum()) == leaf_triangles
    parts = triangle_parts(mesh.v_pos.numpy(), mesh.t_pos_idx.numpy())
    assert parts.max() + 1 == LEAVES + BRANCH_PARTS
    lo, hi = mesh.bounds()
    assert lo[1] >= 0 and hi[1] == pytest.approx(HEIGHT)
    assert float(lo[[0, 2]].min()) > -HEIGHT and float(hi[[0, 2]].max()) < HEIGHT  # a bush, not a line
    v_tex, t_tex_idx = mesh.uv[0]
    assert t_tex_idx.shape == mesh.t_pos_idx.shape
    leaf_uv = v_tex[t_tex_idx[mesh.t_mat_idx == 1]]
    assert leaf_uv.min() >= 0 and leaf_uv.max() <= 1


def test_the_leaves_are_alpha_tested_and_double_sided_the_bark_opaque(default_shrub):
    bark, leaves = default_shrub.materials
    assert leaves.alpha_mode == "MASK" and leaves.alpha_cutoff == 0.5 and leaves.double_sided
    alpha = leaves.kd.data[..., 3]
    assert (alpha == 0).float().mean() > 0.2 and (alpha == 1).float().mean() > 0.2
    assert leaves.kd.data.shape[:2] == (512, 512) and leaves.kd.data[..., :3].std() > 0.01
    assert bark.alpha_mode == "OPAQUE" and bool((bark.kd.data[..., 3] == 1).all())
    assert float(bark.ks.data[..., 1].min()) >= 0.7  # rough


def test_the_shrub_survives_a_gltf_round_trip(tmp_path):
    asset = shrub(1, leaves=300)
    io.save(asset, tmp_path / "shrub.glb")
    loaded = io.load(tmp_path / "shrub.glb")
    assert loaded.mesh.num_triangles == asset.mesh.num_triangles
    assert [m.name for m in loaded.materials] == ["bark", "leaves"]
    assert [m.alpha_mode for m in loaded.materials] == ["OPAQUE", "MASK"]
    assert loaded.materials[1].double_sided
    assert torch.equal(torch.bincount(loaded.mesh.t_mat_idx), torch.bincount(asset.mesh.t_mat_idx))
