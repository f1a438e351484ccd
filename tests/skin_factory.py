"""Test characters: a textured cylinder skinned to two bones that bends at its elbow."""

from __future__ import annotations

import math

import numpy as np
import torch

from lookalike.asset import Animation, Asset, Channel, Material, Mesh, Node, Skin, Texture


def z_rotation(angle: float) -> list[float]:
    """Quaternion (x, y, z, w) of a rotation by ``angle`` radians about z."""
    return [0.0, 0.0, math.sin(angle / 2), math.cos(angle / 2)]


def two_bone_skin() -> Skin:
    """A root joint at the origin and an elbow joint 1 up its y axis; bind pose = rest pose."""
    nodes = [Node("shoulder", -1, torch.zeros(3), torch.tensor([0.0, 0, 0, 1]), torch.ones(3)),
             Node("elbow", 0, torch.tensor([0.0, 1, 0]), torch.tensor([0.0, 0, 0, 1]), torch.ones(3))]
    inverse_bind = torch.eye(4).repeat(2, 1, 1)
    inverse_bind[1, 1, 3] = -1.0
    return Skin(nodes=nodes, joints=torch.tensor([0, 1]), inverse_bind=inverse_bind)


def bending_clip(angle: float = math.radians(100), duration: float = 1.0) -> Animation:
    """The elbow bends from straight to ``angle`` about z over ``duration`` seconds."""
    times = torch.tensor([0.0, duration])
    values = torch.tensor([z_rotation(0.0), z_rotation(angle)])
    return Animation("bend", [Channel(1, "rotation", times, values)])


def checker(size: int = 64, squares: int = 8) -> torch.Tensor:
    """``[size, size, 4]`` linear RGBA: blue and orange squares."""
    cells = (np.arange(size) * squares // size)
    odd = (cells[:, None] + cells[None, :]) % 2 == 1
    rgb = np.where(odd[..., None], [0.8, 0.35, 0.05], [0.05, 0.15, 0.6])
    return torch.from_numpy(np.concatenate([rgb, np.ones((size, size, 1))], -1)).float()


def bent_cylinder(rings: int = 41, segments: int = 24, radius: float = 0.2, blend: float = 0.1) -> Asset:
    """A capped cylinder from y = 0 to 2 skinned to ``two_bone_skin``, with ``bending_clip``.

    Weights go linearly from the shoulder to the elbow joint over ``1 +- blend`` in y; the
    checker texture wraps around it (u the angle, v the height). ``2 * (rings - 1) * segments``
    side triangles plus two caps.
    """
    y = np.linspace(0.0, 2.0, rings)
    angle = np.arange(segments + 1) * 2 * np.pi / segments
    ring_pos = np.stack([radius * np.cos(angle[:-1]), np.zeros(segments), -radius * np.sin(angle[:-1])], -1)
    side = (ring_pos[None] + y[:, None, None] * np.array([0.0, 1, 0])).reshape(-1, 3)
    caps = np.array([[0.0, 0, 0], [0.0, 2, 0]])
    v_pos = np.concatenate([side, caps])
    index = np.arange(rings * segments).reshape(rings, segments)
    a, b = index[:-1], np.roll(index[:-1], -1, axis=1)
    c, d = index[1:], np.roll(index[1:], -1, axis=1)
    tris = [np.stack([a, b, d], -1).reshape(-1, 3), np.stack([a, d, c], -1).reshape(-1, 3)]
    bottom, top = len(side), len(side) + 1
    ring0, ring1 = index[0], index[-1]
    tris.append(np.stack([np.full(segments, bottom), np.roll(ring0, -1), ring0], -1))
    tris.append(np.stack([np.full(segments, top), ring1, np.roll(ring1, -1)], -1))
    t_pos_idx = np.concatenate(tris)
    # UVs: a seam column at angle 2 pi, the caps mapped to the middle of the texture.
    uv_side = np.stack(np.meshgrid(np.arange(segments + 1) / segments, y / 2.0), -1).reshape(-1, 2)
    uv_index = np.arange(rings * (segments + 1)).reshape(rings, segments + 1)
    ua, ub, uc, ud = uv_index[:-1, :-1], uv_index[:-1, 1:], uv_index[1:, :-1], uv_index[1:, 1:]
    cap_uv = len(uv_side)
    t_tex_idx = np.concatenate([np.stack([ua, ub, ud], -1).reshape(-1, 3), np.stack([ua, ud, uc], -1).reshape(-1, 3),
                                np.full((2 * segments, 3), cap_uv)])
    v_tex = np.concatenate([uv_side, [[0.5, 0.5]]])
    elbow = np.clip((v_pos[:, 1] - (1 - blend)) / (2 * blend), 0.0, 1.0)
    v_weights = np.stack([1 - elbow, elbow, np.zeros_like(elbow), np.zeros_like(elbow)], -1)
    v_joints = np.tile([0, 1, 0, 0], (len(v_pos), 1))
    mesh = Mesh(v_pos=torch.from_numpy(v_pos).float(), t_pos_idx=torch.from_numpy(t_pos_idx).long(),
                uv=[(torch.from_numpy(v_tex).float(), torch.from_numpy(t_tex_idx).long())],
                v_joints=torch.from_numpy(v_joints).long(), v_weights=torch.from_numpy(v_weights).float())
    material = Material(name="checker", kd=Texture(checker()), ks=Texture.constant([0.0, 0.5, 0.0]))
    return Asset(mesh=mesh, materials=[material], skin=two_bone_skin(), animations=[bending_clip()])
