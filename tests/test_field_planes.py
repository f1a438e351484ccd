"""Faces on a field's planes, and the hold that keeps them flat through a fit (``asset.field_planes``)."""

from __future__ import annotations

import dataclasses
import math

import pytest
import torch

from field_factory import box_field, sphere_field
from io_factory import box as box_mesh
from lookalike.asset.field_planes import flat_faces, plane_hold, plane_slots, vertex_planes
from lookalike.asset.implicit import field_mesh

HALF = torch.tensor([0.4, 0.25, 0.3])


@pytest.fixture(scope="module")
def box():
    """The box field and its marching-cubes mesh (edges and corners rounded)."""
    surface = box_field(tuple(HALF.tolist()))
    return surface, field_mesh(surface, 24)


@pytest.fixture(scope="module")
def sharp_box():
    """The box field and a mesh of its very sides, each a 3 x 3 vertex grid."""
    mesh = box_mesh(3, flat_normals=False)
    mesh.v_pos = mesh.v_pos * HALF
    return box_field(tuple(HALF.tolist())), mesh


def on_plane(v_pos, t_pos_idx, normal, offset):
    """``[T]`` the largest distance of each face's corners from its plane."""
    return ((v_pos.double()[t_pos_idx] * normal[:, None]).sum(-1) - offset[:, None]).abs().amax(dim=1)


def test_a_box_has_its_sides_flat_and_its_rounded_edges_not(box):
    surface, mesh = box
    flat, normal, offset = flat_faces(surface, mesh.v_pos, mesh.t_pos_idx)
    assert 0.5 < float(flat.double().mean()) < 1.0            # marching cubes rounds every edge
    axis = normal[flat].abs().argmax(dim=1)
    assert float(normal[flat].abs().amax(dim=1).min()) > math.cos(math.radians(0.5))
    assert torch.allclose(offset[flat], HALF.double()[axis], atol=1e-4)   # each on its side, n . x = half
    sphere = sphere_field()
    sphere_mesh = field_mesh(sphere, 24)
    assert not bool(flat_faces(sphere, sphere_mesh.v_pos, sphere_mesh.t_pos_idx)[0].any())


def test_a_plate_thinner_than_a_few_pixels_is_left_free():
    plate = box_field((0.4, 0.01, 0.3))                                          # 0.02 thick: 1 % of a radius
    mesh = box_mesh(3, flat_normals=False)
    mesh.v_pos = mesh.v_pos * torch.tensor([0.4, 0.01, 0.3])
    assert not bool(flat_faces(plate, mesh.v_pos, mesh.t_pos_idx)[0].any())
    assert plane_hold(plate, mesh.v_pos, mesh.t_pos_idx).index.numel() == 0


def test_held_vertices_land_on_their_planes_and_the_others_stay(box):
    surface, mesh = box
    hold = plane_hold(surface, mesh.v_pos, mesh.t_pos_idx)
    flat, normal, offset = flat_faces(surface, mesh.v_pos, mesh.t_pos_idx)
    assert hold.faces == int(flat.sum()) and hold.index.numel() > 0.5 * mesh.v_pos.shape[0]
    shaken = mesh.v_pos + 0.01 * torch.randn(mesh.v_pos.shape, generator=torch.Generator().manual_seed(0))
    held = hold.apply(shaken)
    all_held = torch.zeros(mesh.v_pos.shape[0], dtype=torch.bool)
    all_held[hold.index] = True
    faces = flat & all_held[mesh.t_pos_idx].all(dim=1)
    assert int(faces.sum()) > 0.9 * int(flat.sum())
    assert float(on_plane(held, mesh.t_pos_idx[faces], normal[faces], offset[faces]).max()) < 1e-5
    assert float(on_plane(shaken, mesh.t_pos_idx[faces], normal[faces], offset[faces]).max()) > 1e-3
    assert torch.equal(held[~all_held], shaken[~all_held])
    assert torch.allclose(hold.apply(held), held, atol=1e-6)                   # a projection


def test_a_vertex_on_two_sides_is_held_on_their_edge_and_on_three_at_their_corner(sharp_box):
    surface, mesh = sharp_box
    hold = plane_hold(surface, mesh.v_pos, mesh.t_pos_idx)
    assert hold.faces == mesh.num_triangles and hold.index.tolist() == list(range(mesh.v_pos.shape[0]))
    shaken = mesh.v_pos + 0.01 * torch.randn(mesh.v_pos.shape, generator=torch.Generator().manual_seed(3))
    held = hold.apply(shaken)
    on_sides = ((held.abs() - HALF).abs() < 1e-5).sum(dim=1)                   # coordinates on a side
    assert torch.equal(on_sides, (mesh.v_pos.abs() == HALF).sum(dim=1))
    assert torch.bincount(on_sides).tolist() == [0, 6, 12, 8]                  # face centres, edges, corners
    free = (mesh.v_pos.abs() != HALF)                                           # along its sides, a vertex slides
    assert torch.equal(held[free], shaken[free])


def test_the_hold_in_the_unit_frame_is_the_same_hold(box):
    surface, mesh = box
    hold = plane_hold(surface, mesh.v_pos, mesh.t_pos_idx)
    centre, radius = torch.tensor([0.1, -0.2, 0.05]), 0.7
    shaken = mesh.v_pos + 0.01 * torch.randn(mesh.v_pos.shape, generator=torch.Generator().manual_seed(1))
    unit = hold.in_frame(centre, radius).apply((shaken - centre) / radius)
    assert torch.allclose(centre + radius * unit, hold.apply(shaken), atol=1e-5)


def test_a_vertex_on_both_sides_of_a_thin_plate_is_not_held_and_near_planes_merge():
    up, down = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64), torch.tensor([0.0, 0.0, -1.0], dtype=torch.float64)
    assert vertex_planes([up, down], [0.01, 0.01]) is None
    tilted = torch.tensor([0.0, math.sin(math.radians(0.5)), math.cos(math.radians(0.5))], dtype=torch.float64)
    a, b = vertex_planes([up, tilted, torch.tensor([1.0, 0.0, 0.0], dtype=torch.float64)], [1.0, 1.0, 2.0])
    assert a.shape == (2, 3) and b.tolist() == [1.0, 2.0]


def test_the_latent_keeps_its_held_faces_flat_after_a_step(sharp_box):
    from lookalike.fit.textured_mesh import TexturedMesh

    surface, mesh = sharp_box
    start = mesh.v_pos * 1.02                                                   # a start off the field's sides
    hold = plane_hold(surface, start, mesh.t_pos_idx)
    textures = (torch.full((4, 4, 3), 0.5), torch.full((4, 4, 3), 0.5), torch.tensor([0.0, 0.0, 1.0]).expand(4, 4, 3))
    latent = TexturedMesh(dataclasses.replace(mesh, v_pos=start), *textures, torch.tensor([0.05, 0.0, 0.0]), 0.8,
                          position_steps=torch.full((mesh.v_pos.shape[0], 1), 0.5))
    latent.hold_on_planes(hold)
    assert torch.allclose(latent.world_positions().detach(), mesh.v_pos, atol=1e-5)
    assert float(latent.regularizers()["laplacian"].detach()) < 1e-12          # the held start is the rest shape
    with torch.no_grad():
        latent.v_pos.add_(0.02 * torch.randn(latent.v_pos.shape, generator=torch.Generator().manual_seed(2)))
    latent.clamp_()
    held = latent.world_positions().detach()
    assert torch.allclose(held[mesh.v_pos.abs() == HALF], mesh.v_pos[mesh.v_pos.abs() == HALF], atol=1e-5)


def test_normal_slots_part_each_plane_from_the_faces_beside_it(box, sharp_box):
    surface, mesh = sharp_box
    slots = plane_slots(surface, mesh.v_pos, mesh.t_pos_idx)
    assert int(slots.max()) + 1 == 6 * 9                                        # each side its own 3 x 3 slots
    centre = (mesh.v_pos[mesh.t_pos_idx].mean(dim=1) / HALF)                     # [T, 3]
    axis = centre.abs().argmax(dim=1)
    side = 2 * axis + (centre.gather(1, axis[:, None])[:, 0] > 0).long()         # which of the six sides
    for s in range(int(slots.max()) + 1):                                        # a slot never spans two
        assert side[(slots == s).any(dim=1)].unique().numel() == 1
    surface, rounded = box
    flat = flat_faces(surface, rounded.v_pos, rounded.t_pos_idx)[0]
    slots = plane_slots(surface, rounded.v_pos, rounded.t_pos_idx)
    for k in range(3):                                                           # a flat and a rounded face never share
        shared = slots[flat][:, k].unique()
        assert not bool(torch.isin(slots[~flat].reshape(-1), shared).any())


def test_a_box_written_on_its_planes_shades_with_its_sides_normals(sharp_box):
    from lookalike.asset import Asset, Material, Texture
    from lookalike.asset.normals import split_normals
    from lookalike.io.normal_frames import on_crease_normals

    surface, mesh = sharp_box
    smooth = dataclasses.replace(mesh, t_nrm_idx=mesh.t_pos_idx.clone())        # one normal per vertex: corners bent
    asset = Asset(mesh=smooth, materials=[Material(normal=Texture(torch.tensor([0.0, 0.0, 1.0]).expand(16, 16, 3).clone()))])
    written = on_crease_normals(asset, crease_angle=179.0, apart=plane_slots(surface, mesh.v_pos, mesh.t_pos_idx))
    v_nrm = split_normals(written.mesh.v_pos, written.mesh.t_pos_idx, written.mesh.t_nrm_idx,
                          int(written.mesh.t_nrm_idx.max()) + 1)
    face = torch.linalg.cross(*(mesh.v_pos[mesh.t_pos_idx[:, k]] - mesh.v_pos[mesh.t_pos_idx[:, 0]] for k in (1, 2)))
    face = face / face.norm(dim=-1, keepdim=True)
    assert torch.allclose(v_nrm[written.mesh.t_nrm_idx], face[:, None].expand(-1, 3, 3), atol=1e-5)
