"""Normal slots and split smooth normals (``lookalike.asset.normals``, ``Mesh.normals``): the
vectorised operations against their loop twins, finite-difference gradients, creases on a cube
and a sphere, and authored normals kept until the positions change."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from io_factory import box
from mesh_factory import icosphere

from lookalike.asset import Mesh
from lookalike.asset.normals import (
    crease_normal_index,
    crease_normal_index_python,
    face_normals,
    safe_normalize,
    split_at_both,
    split_normals,
    split_normals_python,
    weld_normals,
    weld_normals_python,
)


def perturbed(mesh: Mesh, amount: float = 0.05, seed: int = 1) -> torch.Tensor:
    """``[V, 3]`` float64 positions of ``mesh`` moved by Gaussian noise of ``amount``."""
    g = torch.Generator().manual_seed(seed)
    return mesh.v_pos.double() + amount * torch.randn(mesh.v_pos.shape, generator=g, dtype=torch.float64)


def odd_mesh() -> Mesh:
    """Two coplanar triangles (0, 1) with a fold of 72 degrees (2), a bend of 17 degrees (3), a
    triangle wound against its neighbour (4), a zero-area triangle (5) and an edge that three
    triangles share (1, 6, 7)."""
    v_pos = torch.tensor([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0.5, -0.5, -1.5], [2, 0, 0.3],
                          [2, 1.5, 0.3], [0.5, 1.5, 0.1], [0, 2, 0], [0.5, 1.5, -0.1]])
    t_pos_idx = torch.tensor([[0, 1, 2], [1, 3, 2], [1, 0, 4], [3, 1, 5], [5, 3, 6], [0, 2, 8], [2, 3, 7],
                              [3, 2, 9]])
    return Mesh(v_pos=v_pos, t_pos_idx=t_pos_idx)


@pytest.mark.parametrize("make", [lambda: box(3, flat_normals=False), lambda: icosphere(2), odd_mesh],
                         ids=["box", "sphere", "odd"])
@pytest.mark.parametrize("angle", [30.0, 60.0, 100.0])
def test_crease_slots_match_loop(make, angle):
    mesh = make()
    fast = crease_normal_index(mesh.v_pos, mesh.t_pos_idx, angle)
    assert torch.equal(fast, crease_normal_index_python(mesh.v_pos, mesh.t_pos_idx, angle))
    # every slot is used at one position only
    pairs = torch.stack([fast.reshape(-1), mesh.t_pos_idx.reshape(-1)], 1).unique(dim=0)
    assert len(pairs) == int(fast.max()) + 1


def test_cube_splits_at_its_edges_and_a_sphere_stays_smooth():
    cube = box(3)
    assert torch.equal(crease_normal_index(cube.v_pos, cube.t_pos_idx), cube.t_nrm_idx)  # the flat faces' slots
    sphere = icosphere(2)
    slots = crease_normal_index(sphere.v_pos, sphere.t_pos_idx)
    assert int(slots.max()) + 1 == sphere.num_vertices
    assert torch.equal(crease_normal_index(sphere.v_pos, sphere.t_pos_idx, crease_angle=1.0).max() + 1,
                       torch.tensor(3 * sphere.num_triangles))


@pytest.mark.parametrize("make", [lambda: box(3, flat_normals=False), lambda: icosphere(1), odd_mesh],
                         ids=["box", "sphere", "odd"])
def test_split_normals_match_loop(make):
    mesh = make()
    v_pos = perturbed(mesh)
    slots = crease_normal_index(mesh.v_pos, mesh.t_pos_idx)
    count = int(slots.max()) + 1
    fast = split_normals(v_pos, mesh.t_pos_idx, slots, count)
    assert torch.allclose(fast, split_normals_python(v_pos, mesh.t_pos_idx, slots, count), atol=1e-12)


def test_split_normals_gradient_matches_finite_differences():
    mesh = box(2, flat_normals=False)
    slots = crease_normal_index(mesh.v_pos, mesh.t_pos_idx)
    v_pos = perturbed(mesh).requires_grad_(True)
    assert torch.autograd.gradcheck(lambda p: split_normals(p, mesh.t_pos_idx, slots, int(slots.max()) + 1),
                                    (v_pos,), eps=1e-6, atol=1e-6)


def test_split_normals_of_a_cube_are_its_face_normals():
    cube = box(3)
    derived = Mesh(v_pos=cube.v_pos, t_pos_idx=cube.t_pos_idx, t_nrm_idx=cube.t_nrm_idx)
    v_nrm, t_nrm_idx = derived.normals()
    assert torch.allclose(v_nrm[t_nrm_idx], cube.v_nrm[cube.t_nrm_idx], atol=1e-6)
    smooth = Mesh(v_pos=cube.v_pos, t_pos_idx=cube.t_pos_idx).normals()
    assert smooth[0].shape[0] == cube.num_vertices and torch.equal(smooth[1], cube.t_pos_idx)


def test_authored_normals_are_kept_until_the_positions_change():
    cube = box(2)
    cube.v_nrm = safe_normalize(cube.v_nrm + 0.1)  # authored values no position recomputes
    v_nrm, t_nrm_idx = cube.normals()
    assert torch.equal(v_nrm, cube.v_nrm) and torch.equal(t_nrm_idx, cube.t_nrm_idx)
    moved = cube.with_positions(cube.v_pos * 2)
    assert moved.v_nrm is None and torch.equal(moved.t_nrm_idx, cube.t_nrm_idx)
    faces = safe_normalize(face_normals(moved.v_pos, moved.t_pos_idx))
    v_nrm, t_nrm_idx = moved.normals()
    assert torch.allclose(v_nrm[t_nrm_idx], faces[:, None].expand(-1, 3, -1), atol=1e-6)


def test_weld_normals_shares_slots_per_position_and_normal():
    t_pos_idx = torch.tensor([[0, 1, 2], [0, 2, 3]])
    up, side = [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]
    corner = torch.tensor([[up, up, up], [[-0.0, 0.0, 1.0], side, up]])
    v_nrm, t_nrm_idx = weld_normals(t_pos_idx, corner)
    assert t_nrm_idx.tolist() == [[0, 1, 2], [0, 3, 4]]  # -0.0 == 0.0; position 2 gets two slots
    assert torch.equal(v_nrm[t_nrm_idx], corner + 0.0)


def test_weld_normals_matches_its_loop_twin():
    rng = np.random.default_rng(3)
    t_pos_idx = torch.from_numpy(rng.integers(0, 40, (300, 3)))
    palette = torch.from_numpy(rng.normal(size=(6, 3)).astype(np.float32))
    palette[5] = torch.tensor([-0.0, 0.0, 1.0])
    palette[4] = torch.tensor([0.0, -0.0, 1.0])           # bitwise different, equal as numbers
    corner = palette[torch.from_numpy(rng.integers(0, 6, (300, 3)))]
    fast, slow = weld_normals(t_pos_idx, corner), weld_normals_python(t_pos_idx, corner)
    assert torch.equal(fast[1], slow[1]) and torch.equal(fast[0], slow[0])
    assert fast[0].shape[0] < 900


def test_split_at_both_shares_a_slot_only_where_both_share_one():
    one = torch.tensor([[0, 0, 1], [1, 2, 2]])
    other = torch.tensor([[5, 5, 5], [7, 7, 3]])
    split = split_at_both(one, other)
    assert split.tolist() == [[0, 0, 1], [2, 3, 4]]
    for a in range(6):
        for b in range(6):
            same = split.reshape(-1)[a] == split.reshape(-1)[b]
            assert bool(same) == bool(one.reshape(-1)[a] == one.reshape(-1)[b] and other.reshape(-1)[a] == other.reshape(-1)[b])
    assert torch.equal(split_at_both(one, one), one)
