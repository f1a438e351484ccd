"""``vertex_tangents``: frames on a plane and a sphere, mirrored UVs, degenerate UVs, hard edges,
and gradients against finite differences."""

from __future__ import annotations

import torch

from io_factory import box, mirrored_plane, plane, uv_sphere
from lookalike.asset.normals import vertex_normals
from lookalike.asset.tangents import vertex_tangents


def corner_frames(mesh):
    v_nrm, t_nrm_idx = mesh.normals()
    v_tng, t_tng_idx = vertex_tangents(mesh.v_pos, mesh.t_pos_idx, mesh.uv[0][0], mesh.uv[0][1], v_nrm, t_nrm_idx)
    return v_nrm[t_nrm_idx], v_tng[t_tng_idx]


def test_plane_tangent_is_plus_x_and_bitangent_points_up_the_image():
    n, t = corner_frames(plane(5))
    assert torch.allclose(t[..., :3], torch.tensor([1.0, 0, 0]).expand_as(t[..., :3]), atol=1e-6)
    assert (t[..., 3] == 1).all()
    b = t[..., 3:] * torch.linalg.cross(n, t[..., :3], dim=-1)
    # v = 1 - y: up the image (decreasing v) is +y.
    assert torch.allclose(b, torch.tensor([0.0, 1, 0]).expand_as(b), atol=1e-6)


def test_flipped_v_flips_handedness_only():
    mesh = plane(4)
    mesh.uv[0] = (torch.stack([mesh.uv[0][0][:, 0], 1 - mesh.uv[0][0][:, 1]], -1), mesh.uv[0][1])
    _, t = corner_frames(mesh)
    assert torch.allclose(t[..., :3], torch.tensor([1.0, 0, 0]).expand_as(t[..., :3]), atol=1e-6)
    assert (t[..., 3] == -1).all()


def test_sphere_tangents_point_east_and_are_orthonormal():
    mesh = uv_sphere(16, 32, dtype=torch.float64)
    n, t = corner_frames(mesh)
    p = mesh.v_pos[mesh.t_pos_idx]
    east = torch.stack([-p[..., 1], p[..., 0], torch.zeros_like(p[..., 0])], -1)
    away_from_poles = east.norm(dim=-1) > 0.5
    east = east / east.norm(dim=-1, keepdim=True).clamp_min(1e-12)
    assert (t[..., :3] * east).sum(-1)[away_from_poles].min() > 0.99
    assert (t[..., :3] * n).sum(-1).abs().max() < 1e-9
    assert torch.allclose(t[..., :3].norm(dim=-1), torch.ones_like(t[..., 0]))
    assert (t[..., 3] == 1).all()


def test_uv_seam_splits_tangents_but_not_positions():
    mesh = uv_sphere(6, 8)
    v_nrm = vertex_normals(mesh.v_pos, mesh.t_pos_idx)
    v_tng, t_tng_idx = vertex_tangents(mesh.v_pos, mesh.t_pos_idx, mesh.uv[0][0], mesh.uv[0][1], v_nrm,
                                       mesh.t_pos_idx)
    pairs = torch.stack([mesh.t_pos_idx.reshape(-1), mesh.uv[0][1].reshape(-1)], -1).unique(dim=0)
    assert v_tng.shape[0] == pairs.shape[0]
    assert t_tng_idx.shape == mesh.t_pos_idx.shape


def test_hard_edges_split_tangents_which_follow_the_split_normals():
    """On a cube with flat normals every corner's tangent lies in its own face (orthogonal to
    that face's normal), though the faces share positions and their UVs meet nowhere."""
    mesh = box(3)
    n, t = corner_frames(mesh)
    face = mesh.v_nrm[mesh.t_nrm_idx]
    assert torch.equal(n, face)
    assert (t[..., :3] * face).sum(-1).abs().max() < 1e-6
    _, smooth = corner_frames(box(3, flat_normals=False))
    assert (smooth[..., :3] * face).sum(-1).abs().max() > 0.3  # with one normal per position they leave it


def test_mirrored_uvs_give_opposite_handedness_on_each_side():
    mesh = mirrored_plane(5)
    _, t = corner_frames(mesh)
    centre_x = mesh.v_pos[mesh.t_pos_idx].mean(1)[:, 0]
    assert (t[centre_x < 0.5][..., 3] == 1).all() and (t[centre_x > 0.5][..., 3] == -1).all()
    assert torch.allclose(t[centre_x < 0.5][..., :3], torch.tensor([1.0, 0, 0]), atol=1e-6)
    assert torch.allclose(t[centre_x > 0.5][..., :3], torch.tensor([-1.0, 0, 0]), atol=1e-6)


def test_degenerate_uvs_give_finite_unit_tangents_and_gradients():
    mesh = plane(4, dtype=torch.float64)
    v_tex = mesh.uv[0][0].clone()
    v_tex[:] = 0.5  # every triangle has zero UV area
    v_pos = mesh.v_pos.clone().requires_grad_(True)
    v_tex.requires_grad_(True)
    v_nrm = vertex_normals(v_pos, mesh.t_pos_idx)
    v_tng, _ = vertex_tangents(v_pos, mesh.t_pos_idx, v_tex, mesh.uv[0][1], v_nrm, mesh.t_pos_idx)
    assert torch.isfinite(v_tng).all() and (v_tng[:, 3] == 1).all()  # zero UV area counts as unmirrored
    assert torch.allclose(v_tng[:, :3].norm(dim=-1), torch.ones(len(v_tng), dtype=torch.float64))
    assert (v_tng[:, :3] * v_nrm[0]).sum(-1).abs().max() < 1e-9
    v_tng.sum().backward()
    assert torch.isfinite(v_pos.grad).all() and torch.isfinite(v_tex.grad).all()


def test_gradient_matches_finite_differences():
    mesh = uv_sphere(4, 6, dtype=torch.float64)
    g = torch.Generator().manual_seed(1)
    v_pos = (mesh.v_pos + 0.05 * torch.randn(mesh.v_pos.shape, generator=g, dtype=torch.float64)).requires_grad_(True)
    v_tex = (mesh.uv[0][0].double() + 0.01 * torch.randn(mesh.uv[0][0].shape, generator=g,
                                                         dtype=torch.float64)).requires_grad_(True)

    def tangents(p, uv):
        v_tng, _ = vertex_tangents(p, mesh.t_pos_idx, uv, mesh.uv[0][1], vertex_normals(p, mesh.t_pos_idx),
                                   mesh.t_pos_idx)
        return v_tng[:, :3]

    assert torch.autograd.gradcheck(tangents, (v_pos, v_tex), eps=1e-6, atol=1e-5)
