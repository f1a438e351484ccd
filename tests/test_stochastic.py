"""Stochastic simplification of aggregate detail (Cook et al. 2007), the ``cards`` baseline:
a random share lambda of the small parts kept, scaled by sqrt(1 / lambda) about their centres,
their texture contrast pulled by sqrt(lambda); large solid parts kept as they are."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from lookalike.asset import Asset, Material, Mesh, Texture
from lookalike.asset.parts import triangle_parts
from lookalike.errors import ConfigError
from lookalike.init.stochastic import stochastic_simplification
from lookalike.samples.shrub import (
    BRANCHES,
    LEAF_COLS,
    LEAF_ROWS,
    RINGS,
    SIDES,
    SUB_BRANCHES,
    shrub,
)

QUADS = 200
BOX = 12                        # triangles of the big box


def quads_and_box(quad_material: int = 0, box_material: int = 1, opaque_quads: int = 0) -> Asset:
    """``QUADS`` square quads (2 triangles, 4 vertices each, sides in [0.9, 1.1]) 3 apart in the
    plane y = 0, then a box of side 20 far away; materials: 0 alpha-tested with random colours,
    1 opaque grey; the quads use ``quad_material`` (the first ``opaque_quads`` of them 1), the
    box ``box_material``."""
    rng = np.random.default_rng(0)
    centre = 3.0 * np.stack([np.arange(QUADS) % 20, np.zeros(QUADS), np.arange(QUADS) // 20], axis=1)
    half = 0.5 * rng.uniform(0.9, 1.1, (QUADS, 1, 1))
    square = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], dtype=np.float64)
    quads = (centre[:, None] + half * square).reshape(-1, 3)
    quad_tris = (np.array([[0, 2, 1], [0, 3, 2]]) + 4 * np.arange(QUADS)[:, None, None]).reshape(-1, 3)
    box = np.array([[100 + x, y, z] for x in (-10, 10) for y in (0, 20) for z in (-10, 10)], dtype=np.float64)
    box_tris = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                         [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]) + len(quads)
    t_pos_idx = torch.from_numpy(np.concatenate([quad_tris, box_tris]))
    v_tex = torch.from_numpy(np.concatenate([np.tile([[0, 0], [1, 0], [1, 1], [0, 1]], (QUADS, 1)),
                                             np.full((len(box), 2), 0.5)])).float()
    mesh = Mesh(v_pos=torch.from_numpy(np.concatenate([quads, box])).float(), t_pos_idx=t_pos_idx,
                uv=[(v_tex, t_pos_idx.clone())],
                t_mat_idx=torch.cat([torch.full((2 * QUADS,), quad_material, dtype=torch.int64),
                                     torch.full((BOX,), box_material, dtype=torch.int64)]))
    mesh.t_mat_idx[:2 * opaque_quads] = 1
    kd = torch.from_numpy(rng.uniform(0, 1, (8, 8, 4))).float()
    kd[..., 3] = (torch.arange(8)[:, None] + torch.arange(8)[None] + 1) % 2  # a checkerboard of holes
    leaf = Material(name="leaf", kd=Texture(kd), alpha_mode="MASK", double_sided=True)
    return Asset(mesh=mesh, materials=[leaf, Material(name="bark")])


def _areas(v_pos: torch.Tensor, t_pos_idx: torch.Tensor) -> torch.Tensor:
    corners = v_pos.double()[t_pos_idx]
    return 0.5 * torch.linalg.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0], dim=-1).norm(dim=-1)


def test_a_share_of_the_small_parts_is_kept_and_scaled_to_preserve_their_area():
    asset = quads_and_box()
    out = stochastic_simplification(asset, triangles=BOX + 100, rng=np.random.default_rng(0))
    assert out.mesh.num_triangles == BOX + 100                      # 50 of 200 quads: lambda = 1/4
    share = 50 / QUADS
    before = asset.mesh.v_pos.double()[:4 * QUADS].reshape(QUADS, 4, 3)
    after = out.mesh.v_pos.double()[:4 * 50].reshape(50, 4, 3)       # kept quads in their order, then the box
    which = torch.cdist(after.mean(1), before.mean(1)).argmin(1)     # a quad's centre does not move
    assert torch.allclose(after.mean(1), before[which].mean(1), atol=1e-4)
    assert len(set(which.tolist())) == 50
    side_before, side_after = (before[:, 1] - before[:, 0]).norm(dim=-1), (after[:, 1] - after[:, 0]).norm(dim=-1)
    assert torch.allclose(side_after ** 2, side_before[which] ** 2 / share, rtol=1e-4)
    quad_area = [float(_areas(m.v_pos, m.t_pos_idx)[m.t_mat_idx == 0].sum()) for m in (asset.mesh, out.mesh)]
    assert quad_area[1] == pytest.approx(quad_area[0], rel=0.05)
    parts = triangle_parts(out.mesh.v_pos.numpy(), out.mesh.t_pos_idx.numpy())
    assert parts.max() + 1 == 50 + 1


def test_the_kept_parts_material_has_its_contrast_pulled_by_sqrt_lambda():
    asset = quads_and_box()
    out = stochastic_simplification(asset, triangles=BOX + 100, rng=np.random.default_rng(0))
    assert len(out.materials) == 2 and out.materials[1] is asset.materials[1]
    before, after = asset.materials[0].kd.data.double(), out.materials[0].kd.data.double()
    assert out.materials[0] is not asset.materials[0] and out.materials[0].alpha_mode == "MASK"
    opaque = before[..., 3] >= 0.5
    mu = before[..., :3][opaque].mean(0)
    assert torch.allclose(after[..., :3], mu + 0.5 * (before[..., :3] - mu), atol=1e-6)
    assert torch.equal(after[..., 3], before[..., 3])
    assert torch.allclose(after[..., :3][opaque].mean(0), mu, atol=1e-6)


def test_the_large_part_is_kept_intact_and_a_shared_material_is_copied_for_the_small_parts():
    asset = quads_and_box(box_material=0)
    out = stochastic_simplification(asset, triangles=BOX + 40, rng=np.random.default_rng(1))
    assert out.mesh.num_triangles == BOX + 40
    box_before = asset.mesh.v_pos[asset.mesh.t_pos_idx[-BOX:]]
    assert torch.equal(out.mesh.v_pos[out.mesh.t_pos_idx[-BOX:]], box_before)
    assert len(out.materials) == 3 and out.materials[0] is asset.materials[0]
    assert bool((out.mesh.t_mat_idx[-BOX:] == 0).all()) and bool((out.mesh.t_mat_idx[:-BOX] == 2).all())
    v_tex, t_tex_idx = out.mesh.uv[0]
    assert t_tex_idx.shape == out.mesh.t_pos_idx.shape and len(v_tex) == out.mesh.num_vertices


def test_the_result_is_deterministic_for_a_seed_and_the_input_is_unchanged():
    asset = quads_and_box()
    kept = [t.clone() for t in (asset.mesh.v_pos, asset.mesh.t_pos_idx, asset.mesh.t_mat_idx, *asset.mesh.uv[0],
                                asset.materials[0].kd.data)]
    first = stochastic_simplification(asset, triangles=BOX + 60, rng=np.random.default_rng(5))
    again = stochastic_simplification(asset, triangles=BOX + 60, rng=np.random.default_rng(5))
    other = stochastic_simplification(asset, triangles=BOX + 60, rng=np.random.default_rng(6))
    assert torch.equal(first.mesh.v_pos, again.mesh.v_pos) and torch.equal(first.mesh.t_pos_idx, again.mesh.t_pos_idx)
    assert not torch.equal(first.mesh.v_pos, other.mesh.v_pos)
    now = (asset.mesh.v_pos, asset.mesh.t_pos_idx, asset.mesh.t_mat_idx, *asset.mesh.uv[0], asset.materials[0].kd.data)
    assert all(torch.equal(a, b) for a, b in zip(kept, now))
    assert [m.name for m in asset.materials] == ["leaf", "bark"]


def test_a_budget_the_solid_parts_fill_is_refused_and_a_large_one_keeps_everything():
    asset = quads_and_box()
    with pytest.raises(ConfigError, match=r"solid parts \(1, kept whole\) alone have 12 triangles"):
        stochastic_simplification(asset, triangles=BOX, rng=np.random.default_rng(0))
    out = stochastic_simplification(asset, triangles=10 * asset.mesh.num_triangles, rng=np.random.default_rng(0))
    assert torch.equal(out.mesh.t_pos_idx, asset.mesh.t_pos_idx)
    assert torch.allclose(out.mesh.v_pos, asset.mesh.v_pos, atol=1e-6)


def test_opaque_parts_among_alpha_tested_ones_are_solid_however_small():
    asset = quads_and_box(opaque_quads=3)
    out = stochastic_simplification(asset, triangles=BOX + 6 + 20, rng=np.random.default_rng(2))
    assert out.mesh.num_triangles == BOX + 6 + 20
    opaque = asset.mesh.v_pos[asset.mesh.t_pos_idx[:6]]
    assert torch.equal(out.mesh.v_pos[out.mesh.t_pos_idx[:6]], opaque) and bool((out.mesh.t_mat_idx[:6] == 1).all())
    with pytest.raises(ConfigError, match=r"solid parts \(4, kept whole\) alone have 18 triangles"):
        stochastic_simplification(asset, triangles=BOX + 6, rng=np.random.default_rng(2))
    only_solid = quads_and_box(quad_material=1, box_material=0)   # opaque quads, and a big alpha-tested box
    out = stochastic_simplification(only_solid, triangles=1000, rng=np.random.default_rng(2))
    assert torch.equal(out.mesh.t_pos_idx, only_solid.mesh.t_pos_idx)
    assert all(a is b for a, b in zip(out.materials, only_solid.materials, strict=True))


def test_the_shrub_keeps_its_branches_within_the_smallest_cards_bench_budget():
    asset = shrub(0)
    budget = round(0.005 * asset.mesh.num_triangles)
    out = stochastic_simplification(asset, triangles=budget, rng=np.random.default_rng(0))
    branches = 1 + BRANCHES * (1 + SUB_BRANCHES)
    assert int((out.mesh.t_mat_idx == 0).sum()) == branches * 2 * RINGS * SIDES
    leaf = 2 * LEAF_ROWS * LEAF_COLS
    assert budget - leaf < out.mesh.num_triangles <= budget
    leaves = int((out.mesh.t_mat_idx == 1).sum()) // leaf
    parts = triangle_parts(out.mesh.v_pos.numpy(), out.mesh.t_pos_idx.numpy())
    assert leaves >= 5 and parts.max() + 1 == branches + leaves
    assert out.materials[1].alpha_mode == "MASK" and out.materials[1] is not asset.materials[1]
