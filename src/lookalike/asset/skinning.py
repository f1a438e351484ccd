"""Linear-blend skinning and glTF animation evaluation (paper, Sec. 5.3).

Skinned positions: ``v_i^s = sum_k w_ik M_(j_ik) v_i`` over each vertex's influences (joint
``j_ik``, weight ``w_ik``; dense weights are influences over every joint, so that any
vertex-joint association can be optimised). Joint matrices follow glTF 2.0 (Sec. 3.7.3): for
joint ``j``, ``M_j = world(joint_j, t) @ inverse_bind_j @ inverse(mesh_to_world)``; the last
factor undoes the skinned mesh node's transform that the loader applied to the bind-pose
positions. ``world`` composes local ``T @ R @ S`` matrices from the root down; animated channels
override a node's translation, rotation or scale (LINEAR: lerp, slerp for rotations; STEP: the
key at or before ``t``; CUBICSPLINE: cubic Hermite with the keys' tangents; times outside the
keys clamp to the first or last key).
"""

from __future__ import annotations

from dataclasses import replace

import torch

from .asset import Asset
from .pose import REST
from .skin import Animation, Channel, Skin


def blended_matrices(joints: torch.Tensor, weights: torch.Tensor, joint_matrices: torch.Tensor) -> torch.Tensor:
    """Each vertex's skinning matrix for F frames: ``[F, V, 3, 4]``, the top three rows of
    ``sum_k weights[v, k] * M_(joints[v, k])``.

    Args:
        joints: ``[V, K]`` int64 joint index of each influence (``arange(J)`` in every row for
            dense weights).
        weights: ``[V, K]`` float weight of each influence (rows normally sum to 1).
        joint_matrices: ``[F, J, 4, 4]`` float skinning matrices ``M_j`` per frame.
    Differentiable in ``weights`` and ``joint_matrices``. Cost: ``O(F V K)`` time, and the
    ``[F, V, 3, 4]`` result of memory (48 MB per frame at a million vertices).
    """
    rows = joint_matrices[:, :, :3, :]  # [F, J, 3, 4]
    return sum(weights[:, k, None, None] * rows[:, joints[:, k]] for k in range(joints.shape[1]))


def dense_weights(v_joints: torch.Tensor, v_weights: torch.Tensor, num_joints: int) -> torch.Tensor:
    """Dense ``[V, J]`` weights from sparse glTF influences ``v_joints [V, K]`` int64 and
    ``v_weights [V, K]`` float (repeated joints add up)."""
    dense = torch.zeros(v_joints.shape[0], num_joints, dtype=v_weights.dtype, device=v_weights.device)
    return dense.scatter_add(1, v_joints, v_weights)


def quaternion_to_matrix(q: torch.Tensor) -> torch.Tensor:
    """Rotation matrices ``[..., 3, 3]`` of quaternions ``q [..., 4]`` (x, y, z, w; normalised here)."""
    x, y, z, w = (q / q.norm(dim=-1, keepdim=True)).unbind(dim=-1)
    return torch.stack([
        1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
        2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
        2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y),
    ], dim=-1).reshape(*q.shape[:-1], 3, 3)


def trs_matrix(translation: torch.Tensor, rotation: torch.Tensor, scale: torch.Tensor) -> torch.Tensor:
    """``[..., 4, 4]`` matrices ``T @ R @ S`` from ``translation [..., 3]``, quaternion
    ``rotation [..., 4]`` (xyzw) and ``scale [..., 3]``."""
    shape = torch.broadcast_shapes(translation.shape[:-1], rotation.shape[:-1], scale.shape[:-1])
    m = torch.zeros(*shape, 4, 4, dtype=translation.dtype, device=translation.device)
    m[..., :3, :3] = quaternion_to_matrix(rotation) * scale.unsqueeze(-2)
    m[..., :3, 3] = translation
    m[..., 3, 3] = 1.0
    return m


def slerp(q0: torch.Tensor, q1: torch.Tensor, s: torch.Tensor) -> torch.Tensor:
    """Shortest-path spherical interpolation of unit quaternions ``q0, q1 [..., 4]`` at
    ``s [...]`` in [0, 1]; falls back to normalised lerp for nearly equal quaternions."""
    dot = (q0 * q1).sum(dim=-1, keepdim=True)
    q1 = torch.where(dot < 0, -q1, q1)
    dot = dot.abs().clamp(max=1.0)
    s = s.unsqueeze(-1)
    theta = torch.acos(dot)
    sin_theta = torch.sin(theta)
    close = sin_theta < 1e-6
    safe_sin = torch.where(close, torch.ones_like(sin_theta), sin_theta)
    w0 = torch.where(close, 1 - s, torch.sin((1 - s) * theta) / safe_sin)
    w1 = torch.where(close, s, torch.sin(s * theta) / safe_sin)
    q = w0 * q0 + w1 * q1
    return q / q.norm(dim=-1, keepdim=True)


def sample_channel(channel: Channel, times: torch.Tensor) -> torch.Tensor:
    """Values ``[F, C]`` of ``channel`` at ``times [F]``, with glTF's sampler semantics: times
    outside the keys clamp to the first or last key; between keys ``k`` and ``k + 1``, at
    ``s = (t - t_k) / (t_{k+1} - t_k)``, STEP holds ``v_k``, LINEAR lerps (slerps rotations),
    and CUBICSPLINE is the cubic Hermite spline ``(2s^3 - 3s^2 + 1) v_k + d (s^3 - 2s^2 + s)
    b_k + (-2s^3 + 3s^2) v_{k+1} + d (s^3 - s^2) a_{k+1}`` with ``d = t_{k+1} - t_k``, ``b_k``
    the out-tangent of key ``k`` and ``a_{k+1}`` the in-tangent of key ``k + 1`` (rotations
    normalised after)."""
    keys = channel.times.to(times)
    values = channel.values.to(times)
    if channel.interpolation not in ("LINEAR", "STEP", "CUBICSPLINE"):
        raise ValueError(f"unsupported animation interpolation {channel.interpolation!r}")
    cubic = channel.interpolation == "CUBICSPLINE"
    if cubic:
        in_tangent, values, out_tangent = values.reshape(keys.numel(), 3, -1).unbind(1)
    if keys.numel() == 1:
        return values[:1].expand(times.shape[0], -1)
    t = times.clamp(keys[0], keys[-1])
    k = (torch.searchsorted(keys, t, right=True) - 1).clamp(0, keys.numel() - 2)
    span = keys[k + 1] - keys[k]
    s = ((t - keys[k]) / span.clamp(min=1e-12)).clamp(0, 1)
    if channel.interpolation == "STEP":
        return torch.where((s >= 1).unsqueeze(-1), values[k + 1], values[k])
    if cubic:
        s, d = s.unsqueeze(-1), span.unsqueeze(-1)
        s2, s3 = s * s, s * s * s
        out = ((2 * s3 - 3 * s2 + 1) * values[k] + d * (s3 - 2 * s2 + s) * out_tangent[k]
               + (-2 * s3 + 3 * s2) * values[k + 1] + d * (s3 - s2) * in_tangent[k + 1])
        return out / out.norm(dim=-1, keepdim=True) if channel.path == "rotation" else out
    if channel.path == "rotation":
        return slerp(values[k], values[k + 1], s)
    return torch.lerp(values[k], values[k + 1], s.unsqueeze(-1))


def node_world_matrices(skin: Skin, animation: Animation | None, times: torch.Tensor) -> torch.Tensor:
    """World matrices ``[F, N, 4, 4]`` of every node of ``skin`` at ``times [F]`` (rest pose
    where ``animation`` is ``None`` or does not animate a property)."""
    frames = times.shape[0]
    trs = {
        "translation": torch.stack([n.translation for n in skin.nodes]).to(times).expand(frames, -1, -1).clone(),
        "rotation": torch.stack([n.rotation for n in skin.nodes]).to(times).expand(frames, -1, -1).clone(),
        "scale": torch.stack([n.scale for n in skin.nodes]).to(times).expand(frames, -1, -1).clone(),
    }
    for channel in (animation.channels if animation is not None else []):
        trs[channel.path][:, channel.node] = sample_channel(channel, times)
    local = trs_matrix(trs["translation"], trs["rotation"], trs["scale"])  # [F, N, 4, 4]
    world: list[torch.Tensor | None] = [None] * len(skin.nodes)

    def resolve(i: int) -> torch.Tensor:
        if world[i] is None:
            parent = skin.nodes[i].parent
            world[i] = local[:, i] if parent < 0 else resolve(parent) @ local[:, i]
        return world[i]

    return torch.stack([resolve(i) for i in range(len(skin.nodes))], dim=1)


def joint_matrices(skin: Skin, animation: Animation | None = None,
                   times: torch.Tensor | float = 0.0) -> torch.Tensor:
    """Skinning matrices ``[F, J, 4, 4]`` (float32) of ``skin`` at ``times`` (``[F]`` seconds or
    one number), for ``blended_matrices`` applied to the loaded bind-pose positions:
    ``world(joint_j) @ inverse_bind_j @ inverse(mesh_to_world)``."""
    times = torch.as_tensor(times, dtype=torch.float32).reshape(-1)
    world = node_world_matrices(skin, animation, times)[:, skin.joints]
    undo_mesh = torch.linalg.inv(skin.mesh_to_world.to(torch.float64)).to(torch.float32)
    return world @ skin.inverse_bind.to(torch.float32) @ undo_mesh


def pose_matrices(skin: Skin, animations: list[Animation], clip: int, time: float) -> torch.Tensor:
    """Skinning matrices ``[J, 4, 4]`` of one pose: clip ``clip`` of ``animations`` at ``time``
    seconds, or the rest pose where ``clip`` is ``REST`` (``lookalike.asset.pose``)."""
    return joint_matrices(skin, None if clip == REST else animations[clip], time)[0]


def posed(asset: Asset, clip: int, time: float) -> Asset:
    """``asset`` in one pose (see ``pose_matrices``): its mesh skinned by its own influences
    (``Mesh.v_joints``, ``v_weights``), its bind-pose normals (``Mesh.normals``: the file's, or
    split normals of the bind-pose positions) skinned too, by the linear part of each vertex's
    blended matrix and renormalised, as real-time engines and web viewers skin a glTF's NORMAL
    (Blender turns its custom normals with the faces, much the same); everything else shared.
    Differentiable in the positions and the weights."""
    mesh = asset.mesh
    v_nrm, t_nrm_idx = mesh.normals()
    matrices = pose_matrices(asset.skin, asset.animations, clip, time).to(mesh.v_pos)
    blended = blended_matrices(mesh.v_joints, mesh.v_weights, matrices[None])[0]  # [V, 3, 4]
    v_pos = (blended[:, :, :3] @ mesh.v_pos.unsqueeze(-1)).squeeze(-1) + blended[:, :, 3]
    slot_position = torch.zeros(v_nrm.shape[0], dtype=torch.int64, device=v_pos.device)
    slot_position.scatter_(0, t_nrm_idx.reshape(-1), mesh.t_pos_idx.reshape(-1))
    v_nrm = torch.nn.functional.normalize((blended[slot_position, :, :3] @ v_nrm.unsqueeze(-1)).squeeze(-1), dim=-1)
    return replace(asset, mesh=replace(mesh, v_pos=v_pos, v_nrm=v_nrm, t_nrm_idx=t_nrm_idx))


def strongest_influences(joints: torch.Tensor, weights: torch.Tensor, count: int = 4) -> tuple[torch.Tensor, torch.Tensor]:
    """The ``count`` largest influences of each vertex, renormalised to sum to 1 (what a glTF
    JOINTS_0 / WEIGHTS_0 pair holds for ``count`` 4).

    Args:
        joints: ``[V, K]`` int64 joint indices (repeats add up); weights: ``[V, K]`` float,
            non-negative.
    Returns:
        ``(joints [V, count] int64, weights [V, count])``, strongest first; a vertex with fewer
        influences gets weight-0 entries on joint 0.
    """
    dense = dense_weights(joints, weights.detach(), int(joints.max()) + 1 if joints.numel() else 1)
    if dense.shape[1] < count:
        dense = torch.nn.functional.pad(dense, (0, count - dense.shape[1]))
    top, index = dense.topk(count, dim=1)
    index = torch.where(top > 0, index, torch.zeros_like(index))
    return index, top / top.sum(dim=1, keepdim=True).clamp(min=1e-30)
