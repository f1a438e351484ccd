"""Skinning weights for a new mesh near a skinned one's surface (a decimation of it), in the
bind pose.

- ``blend_influences``: a point's weights are the barycentric blend of the weights of the
  corners of its closest source triangle, cut to the strongest few (what glTF holds).
- ``transfer_skin``: a whole asset's weights blended so, and the source's skeleton and clips.
- ``skin_candidates``: the joints a vertex of the fit may use: those that weigh most on the
  source surface within the vertex's reach (the mean length of its edges), the blend's
  strongest first; where fewer than asked weigh anything there, the joints whose bind-pose
  origins lie nearest fill the list.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import torch
from scipy.spatial import cKDTree

from ..asset import Asset, Mesh, Skin
from ..asset.skinning import dense_weights, strongest_influences
from .closest_point import SurfaceQuery

BLEND_PRIORITY = 1e6
"""Added to the score of the joints the closest point's blend gives weight, so they rank first."""


def blend_influences(source: Mesh, triangle: np.ndarray, barycentric: np.ndarray,
                     count: int) -> tuple[torch.Tensor, torch.Tensor]:
    """The skinning influences at points of ``source``'s surface: ``sum_c b_c w(corner_c)``
    over the corners of each point's triangle, cut to the ``count`` strongest, renormalised
    (``lookalike.asset.skinning.strongest_influences``).

    Args:
        source: a mesh with influences ``v_joints``, ``v_weights`` ``[Vs, K]``.
        triangle: ``[N]`` int64 triangle of ``source`` holding each point.
        barycentric: ``[N, 3]`` float barycentric coordinates of each point in it.
    Returns:
        ``(joints [N, count] int64, weights [N, count] float32)``.
    """
    device = source.t_pos_idx.device
    corners = source.t_pos_idx[torch.as_tensor(triangle, dtype=torch.int64, device=device)]  # [N, 3]
    joints = source.v_joints[corners].reshape(len(corners), -1)                              # [N, 3K]
    bary = torch.as_tensor(barycentric, dtype=torch.float32, device=device)
    weights = (bary[:, :, None] * source.v_weights.detach().float()[corners]).reshape(len(corners), -1)
    return strongest_influences(joints, weights, count)


def transfer_skin(source: Asset, target: Asset, influences: int = 4) -> Asset:
    """``target`` skinned like ``source``: each of its vertices' weights blended at the closest
    point of ``source``'s surface (``blend_influences``, the ``influences`` strongest), with
    ``source``'s skeleton and clips. Both meshes are in the bind pose, in one frame."""
    points = target.mesh.v_pos.detach().double().cpu().numpy()
    src = source.mesh
    closest = SurfaceQuery(src.v_pos.detach().double().cpu().numpy(), src.t_pos_idx.cpu().numpy()).closest(points)
    joints, weights = blend_influences(src, closest.triangle, closest.barycentric, influences)
    mesh = replace(target.mesh, v_joints=joints, v_weights=weights)
    return replace(target, mesh=mesh, skin=source.skin, animations=source.animations)


def joint_origins(skin: Skin) -> torch.Tensor:
    """``[J, 3]`` bind-pose origins of the joints in the frame of the loaded positions:
    ``mesh_to_world @ inverse(inverse_bind_j) @ (0, 0, 0, 1)``."""
    bind = skin.mesh_to_world.double() @ torch.linalg.inv(skin.inverse_bind.double())
    return bind[:, :3, 3].float()


def skin_candidates(source: Mesh, skin: Skin, mesh: Mesh, count: int = 8,
                    influences: int = 4) -> tuple[torch.Tensor, torch.Tensor]:
    """Candidate joints and starting weights for each vertex of ``mesh`` (see the module
    docstring).

    Args:
        source: the skinned input in its bind pose (``v_joints``, ``v_weights``).
        skin: its skeleton.
        mesh: the new mesh, near ``source``'s surface, in the same frame.
        count: candidates per vertex (at most the skeleton's joint count).
        influences: how many of the closest point's blended weights start non-zero.
    Returns:
        ``(joints [V, count] int64, weights [V, count] float32)``: distinct joints per row,
        the blend's ``influences`` strongest first with their renormalised weights, the other
        candidates at weight 0.
    """
    num_joints = len(skin.joints)
    count = min(count, num_joints)
    points = mesh.v_pos.detach().double().numpy()
    src_pos = source.v_pos.detach().double().numpy()
    closest = SurfaceQuery(src_pos, source.t_pos_idx.numpy()).closest(points)
    blend_joints, blend_weights = blend_influences(source, closest.triangle, closest.barycentric, influences)
    score = dense_weights(blend_joints, blend_weights, num_joints).double() * BLEND_PRIORITY
    score += _nearby_weight(source, src_pos, points, _edge_reach(mesh), num_joints)
    distance = torch.cdist(mesh.v_pos.detach().double(), joint_origins(skin).double())      # [V, J]
    order = np.lexsort((distance.numpy(), -score.numpy()), axis=1)[:, :count]
    joints = torch.from_numpy(np.ascontiguousarray(order)).long()
    weights = dense_weights(blend_joints, blend_weights, num_joints).gather(1, joints)
    return joints, weights.float()


def _edge_reach(mesh: Mesh) -> np.ndarray:
    """``[V]`` float64 mean length of each vertex's edges (0 for a vertex on none)."""
    v_pos = mesh.v_pos.detach().double().numpy()
    tri = mesh.t_pos_idx.numpy()
    ends = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    length = np.linalg.norm(v_pos[ends[:, 0]] - v_pos[ends[:, 1]], axis=1)
    total = np.bincount(ends.reshape(-1), np.repeat(length, 2), minlength=len(v_pos))
    edges = np.bincount(ends.reshape(-1), minlength=len(v_pos))
    return total / np.maximum(edges, 1)


def _nearby_weight(source: Mesh, src_pos: np.ndarray, points: np.ndarray, reach: np.ndarray,
                   num_joints: int) -> torch.Tensor:
    """``[N, J]`` float64: for each point, the summed weights of the source vertices within
    ``reach [N]`` of it."""
    dense = dense_weights(source.v_joints, source.v_weights.detach().double(), num_joints)
    near = cKDTree(src_pos).query_ball_point(points, r=reach)
    rows = np.repeat(np.arange(len(points)), [len(n) for n in near])
    columns = np.concatenate([np.asarray(n, dtype=np.int64) for n in near]) if len(rows) else np.zeros(0, np.int64)
    out = torch.zeros(len(points), num_joints, dtype=torch.float64)
    return out.index_add_(0, torch.from_numpy(rows), dense[torch.from_numpy(columns)])
