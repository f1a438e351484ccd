"""Linear-blend skinning, strongest influences, poses and glTF animation sampling."""

from __future__ import annotations

import math

import pytest
import torch

from lookalike.asset import Animation, Channel, Node, Skin
from lookalike.asset.skinning import (
    blended_matrices,
    dense_weights,
    joint_matrices,
    node_world_matrices,
    quaternion_to_matrix,
    sample_channel,
    slerp,
    strongest_influences,
)


def axis_angle_quaternion(axis, angle):
    axis = torch.tensor(axis, dtype=torch.float32)
    axis = axis / axis.norm()
    return torch.cat([axis * math.sin(angle / 2), torch.tensor([math.cos(angle / 2)])])


def rotation_z(angle):
    c, s = math.cos(angle), math.sin(angle)
    return torch.tensor([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def two_bone_skin() -> Skin:
    """Root at (1, 0, 0); child 2 units up the root's y axis, scaled by 2 along x."""
    nodes = [
        Node("root", -1, torch.tensor([1.0, 0, 0]), torch.tensor([0.0, 0, 0, 1]), torch.ones(3)),
        Node("child", 0, torch.tensor([0.0, 2, 0]), torch.tensor([0.0, 0, 0, 1]), torch.tensor([2.0, 1, 1])),
    ]
    rest_world = torch.stack([torch.eye(4), torch.eye(4)])
    rest_world[:, 0, 3] = 1.0
    rest_world[1, 1, 3] = 2.0
    rest_world[1, 0, 0] = 2.0
    return Skin(nodes=nodes, joints=torch.tensor([0, 1]), inverse_bind=torch.linalg.inv(rest_world))


def skin_vertices(v_pos, joints, weights, mats):
    """Linear-blend skinning ``[F, V, 3]`` through ``blended_matrices``, as ``posed`` applies it."""
    blended = blended_matrices(joints, weights, mats)
    return (blended[..., :3] @ v_pos.unsqueeze(-1)).squeeze(-1) + blended[..., 3]


def skin_vertices_loop(v_pos, joints, weights, mats):
    """The obviously-correct twin: every frame, vertex and influence in turn."""
    out = torch.zeros(mats.shape[0], v_pos.shape[0], 3, dtype=v_pos.dtype)
    for f in range(mats.shape[0]):
        for v in range(v_pos.shape[0]):
            h = torch.cat([v_pos[v], torch.ones(1, dtype=v_pos.dtype)])
            for k in range(joints.shape[1]):
                out[f, v] += weights[v, k] * (mats[f, joints[v, k]] @ h)[:3]
    return out


def test_skin_vertices_matches_a_per_vertex_loop():
    frames, num_joints, verts, influences = 2, 5, 7, 3
    v_pos = torch.randn(verts, 3, dtype=torch.float64)
    joints = torch.randint(0, num_joints, (verts, influences))
    joints[0] = torch.tensor([2, 2, 4])  # a repeated joint adds up
    weights = torch.rand(verts, influences, dtype=torch.float64)
    mats = torch.randn(frames, num_joints, 4, 4, dtype=torch.float64)
    assert torch.allclose(skin_vertices(v_pos, joints, weights, mats), skin_vertices_loop(v_pos, joints, weights, mats))
    # Dense weights are influences over every joint.
    dense = torch.rand(verts, num_joints, dtype=torch.float64)
    every = torch.arange(num_joints).expand(verts, -1)
    assert torch.allclose(skin_vertices(v_pos, every, dense, mats), skin_vertices_loop(v_pos, every, dense, mats))


def test_skin_vertices_gradients_match_finite_differences():
    v_pos = torch.randn(4, 3, dtype=torch.float64, requires_grad=True)
    joints = torch.tensor([[0, 1], [1, 0], [1, 1], [0, 1]])
    logits = torch.randn(4, 2, dtype=torch.float64, requires_grad=True)
    mats = torch.randn(2, 2, 4, 4, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda v, w, m: skin_vertices(v, joints, torch.softmax(w, 1), m),
                                    (v_pos, logits, mats))


def test_strongest_influences_merge_repeats_keep_the_largest_and_renormalise():
    joints = torch.tensor([[3, 1, 3, 0, 5, 2], [0, 0, 0, 0, 0, 0]])
    weights = torch.tensor([[0.1, 0.3, 0.2, 0.05, 0.25, 0.1], [0.2, 0.2, 0.3, 0.3, 0.0, 0.0]])
    top, share = strongest_influences(joints, weights, 4)
    assert top[0].tolist() == [1, 3, 5, 2] and torch.allclose(share[0], torch.tensor([0.3, 0.3, 0.25, 0.1]) / 0.95)
    # One joint only: it takes all the weight, the other slots are weight 0 on joint 0.
    assert top[1].tolist() == [0, 0, 0, 0] and share[1].tolist() == [1.0, 0.0, 0.0, 0.0]
    assert (share >= 0).all() and torch.allclose(share.sum(1), torch.ones(2))


def test_dense_weights_scatter_and_sum_duplicates():
    dense = dense_weights(torch.tensor([[0, 2, 2, 0]]), torch.tensor([[0.5, 0.25, 0.25, 0.0]]), 4)
    assert torch.equal(dense, torch.tensor([[0.5, 0.0, 0.5, 0.0]]))


def test_quaternion_and_slerp():
    q = axis_angle_quaternion([0, 0, 1], math.pi / 2)
    assert torch.allclose(quaternion_to_matrix(q), rotation_z(math.pi / 2), atol=1e-6)
    identity = torch.tensor([0.0, 0, 0, 1])
    half = slerp(identity[None], q[None], torch.tensor([0.5]))[0]
    assert torch.allclose(half, axis_angle_quaternion([0, 0, 1], math.pi / 4), atol=1e-6)
    # Shortest path: -q is the same rotation, slerp must not go the long way round.
    assert torch.allclose(slerp(identity[None], -q[None], torch.tensor([0.5]))[0], half, atol=1e-6)
    assert torch.allclose(slerp(q[None], q[None], torch.tensor([0.3]))[0], q, atol=1e-6)


def test_rest_pose_is_identity_skinning():
    skin = two_bone_skin()
    mats = joint_matrices(skin)
    assert mats.shape == (1, 2, 4, 4)
    assert torch.allclose(mats, torch.eye(4).expand(1, 2, 4, 4), atol=1e-6)


def test_animation_linear_and_step():
    skin = two_bone_skin()
    q90 = axis_angle_quaternion([0, 0, 1], math.pi / 2)
    animation = Animation("clip", [
        Channel(0, "translation", torch.tensor([0.0, 2.0]), torch.tensor([[1.0, 0, 0], [3.0, 0, 0]])),
        Channel(1, "rotation", torch.tensor([0.0, 1.0]), torch.stack([torch.tensor([0.0, 0, 0, 1]), q90])),
        Channel(1, "scale", torch.tensor([0.0, 1.0]), torch.tensor([[2.0, 1, 1], [4.0, 1, 1]]), "STEP"),
    ])
    times = torch.tensor([-1.0, 0.5, 1.0, 5.0])
    world = node_world_matrices(skin, animation, times)
    # Root translation: lerp, clamped outside the keys.
    assert torch.allclose(world[:, 0, 0, 3], torch.tensor([1.0, 1.5, 2.0, 3.0]))
    # Child at t = 0.5: rotation 45 degrees (slerp), scale still the first STEP key.
    expected = torch.eye(4)
    expected[:3, :3] = rotation_z(math.pi / 4) @ torch.diag(torch.tensor([2.0, 1, 1]))
    expected[:3, 3] = torch.tensor([1.5, 2.0, 0.0])
    assert torch.allclose(world[1, 1], expected, atol=1e-6)
    # At t = 1 the STEP key switches to 4.
    assert torch.allclose(world[2, 1, :3, 0].norm(), torch.tensor(4.0))
    # A vertex bound to the child at its origin follows the child's origin.
    mats = joint_matrices(skin, animation, times)
    vertex = torch.tensor([[1.0, 2.0, 0.0]])
    moved = skin_vertices(vertex, torch.tensor([[1]]), torch.tensor([[1.0]]), mats)
    assert torch.allclose(moved[:, 0], world[:, 1, :3, 3], atol=1e-6)


def test_mesh_to_world_is_undone():
    skin = two_bone_skin()
    skin.mesh_to_world = torch.diag(torch.tensor([2.0, 2.0, 2.0, 1.0]))
    # Loaded positions are mesh_to_world @ local; rest-pose skinning maps local -> local.
    local = torch.tensor([[0.5, 0.5, 0.5]])
    loaded = 2.0 * local
    skinned = skin_vertices(loaded, torch.tensor([[0]]), torch.tensor([[1.0]]), joint_matrices(skin))
    assert torch.allclose(skinned[0], local, atol=1e-6)


@pytest.mark.assets
@pytest.mark.parametrize("relative", ["cesium-man/CesiumMan.glb", "fox/Fox.glb"], ids=["cesium-man", "fox"])
def test_skins_the_shared_characters(shared_assets, relative):
    from lookalike import io

    asset = io.load(shared_assets / relative)
    skin, mesh = asset.skin, asset.mesh
    extent = (mesh.v_pos.max(0).values - mesh.v_pos.min(0).values).max()
    # The rest pose reproduces the loaded bind pose.
    rest = skin_vertices(mesh.v_pos, mesh.v_joints, mesh.v_weights, joint_matrices(skin))[0]
    assert (rest - mesh.v_pos).abs().max() < 1e-4 * extent
    # Every clip moves the character without tearing it apart.
    for animation in asset.animations:
        times = torch.linspace(0, animation.duration, 5)
        frames = skin_vertices(mesh.v_pos, mesh.v_joints, mesh.v_weights, joint_matrices(skin, animation, times))
        assert torch.isfinite(frames).all()
        assert (frames - mesh.v_pos).abs().max() > 0.01 * extent
        frame_extent = (frames.max(1).values - frames.min(1).values).max(-1).values
        assert (frame_extent < 1.5 * extent).all() and (frame_extent > 0.5 * extent).all()


def test_cubicspline_sampling_matches_hand_computed_values():
    """glTF Appendix C: between keys 0 (t=1, v=2, out-tangent 4) and 1 (t=3, v=6, in-tangent
    -2), at s = 1/4 with d = 2: h00 = 27/32, h10 = 9/64, h01 = 5/32, h11 = -3/64, so
    p = 27/32*2 + 2*9/64*4 + 5/32*6 + 2*(-3/64)*(-2) = 3.75; clamped to the end values
    outside; keys are hit exactly; rotations come out unit length."""
    values = torch.tensor([[9.0], [2.0], [4.0], [-2.0], [6.0], [7.0]])  # (in, value, out) per key
    channel = Channel(0, "translation", torch.tensor([1.0, 3.0]), values, "CUBICSPLINE")
    got = sample_channel(channel, torch.tensor([0.0, 1.0, 1.5, 3.0, 4.0]))[:, 0]
    assert torch.allclose(got, torch.tensor([2.0, 2.0, 3.9375, 6.0, 6.0]))
    q0, q1 = torch.tensor([0.0, 0, 0, 1]), axis_angle_quaternion([0, 0, 1], math.pi / 2)
    zero = torch.zeros(4)
    rotation = Channel(0, "rotation", torch.tensor([0.0, 1.0]), torch.stack([zero, q0, zero, zero, q1, zero]),
                       "CUBICSPLINE")
    halfway = sample_channel(rotation, torch.tensor([0.5]))[0]
    assert torch.allclose(halfway.norm(), torch.tensor(1.0))
    # zero tangents: the Hermite blend of the two keys is symmetric at s = 1/2, i.e. 45 degrees
    assert torch.allclose(halfway, axis_angle_quaternion([0, 0, 1], math.pi / 4), atol=1e-6)


def test_step_holds_each_key_until_the_next():
    channel = Channel(0, "scale", torch.tensor([0.0, 1.0, 2.0]), torch.tensor([[1.0] * 3, [2.0] * 3, [5.0] * 3]), "STEP")
    got = sample_channel(channel, torch.tensor([-1.0, 0.0, 0.99, 1.0, 1.5, 2.0, 9.0]))[:, 0]
    assert torch.equal(got, torch.tensor([1.0, 1.0, 1.0, 2.0, 2.0, 5.0, 5.0]))
