"""Carrying a mesh's surface attributes (UVs, materials, vertex colours, skin weights) over to
a new mesh that lies near its surface, such as a decimation of it.

Each new triangle first chooses one *patch* of the source surface: a UV chart of one material
(triangles joined across an edge whose two endpoints have the same UVs on both sides and that
share a material), or just a material where the source has no UVs. The choice is a vote of
four points of the new triangle (its centroid and its corners moved halfway to the centroid),
each voting for the patch of its closest source point; ties go to the centroid. Each corner then
takes the attributes of its closest source point *within that patch*. So a new triangle never
straddles a UV seam or a material border, and corners shared by triangles of the same patch
share one UV vertex.
"""

from __future__ import annotations

import numpy as np
import torch
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..asset.index_tables import patch_labels
from ..asset.mesh import Mesh
from .closest_point import SurfaceQuery
from .skin_weights import blend_influences
from .weld import weld_tolerance, weld_vertices

UV_SEAM_TOLERANCE = 1e-5           # UVs closer than this (in UV units) count as continuous
_VOTE_SHRINK = 0.5                 # corners move this fraction of the way to the centroid to vote


def surface_patches(w_idx: np.ndarray, t_mat_idx: np.ndarray, corner_uv: np.ndarray | None) -> np.ndarray:
    """Patch label of each triangle: connected components of triangles that share a material
    and an edge across which UVs are continuous (``UV_SEAM_TOLERANCE``).

    Args:
        w_idx: ``[T, 3]`` int64 welded position indices.
        t_mat_idx: ``[T]`` int64 material of each triangle.
        corner_uv: ``[T, 3, 2]`` float64 UV at each corner, or ``None`` (then a patch is a material).

    Returns:
        ``[T]`` int64 labels, ``0 .. P-1``, numbered in order of each patch's first triangle
        (compiled: ``index_tables.patch_labels``; :func:`surface_patches_python` is the twin).
    """
    if corner_uv is None:
        return np.unique(t_mat_idx, return_inverse=True)[1].astype(np.int64)
    return patch_labels(np.ascontiguousarray(w_idx, dtype=np.int64), np.ascontiguousarray(t_mat_idx, dtype=np.int64),
                        np.ascontiguousarray(corner_uv, dtype=np.float64), UV_SEAM_TOLERANCE)


def surface_patches_python(w_idx: np.ndarray, t_mat_idx: np.ndarray, corner_uv: np.ndarray | None) -> np.ndarray:
    """Twin of :func:`surface_patches` by sorting the edges and scipy's connected components."""
    if corner_uv is None:
        return np.unique(t_mat_idx, return_inverse=True)[1].astype(np.int64)
    n = len(w_idx)
    nxt = [1, 2, 0]
    ends = np.stack([w_idx, w_idx[:, nxt]], axis=-1).reshape(-1, 2)                  # [3T, 2]
    uvs = np.stack([corner_uv, corner_uv[:, nxt]], axis=2).reshape(-1, 2, 2)          # [3T, 2 ends, 2]
    swap = ends[:, 0] > ends[:, 1]
    ends[swap] = ends[swap][:, ::-1]
    uvs[swap] = uvs[swap][:, ::-1]
    owner = np.repeat(np.arange(n), 3)
    key = ends[:, 0] * (int(w_idx.max()) + 1) + ends[:, 1]
    order = np.argsort(key, kind="stable")
    a, b = order[:-1], order[1:]
    joined = (
        (key[a] == key[b])
        & (t_mat_idx[owner[a]] == t_mat_idx[owner[b]])
        & (np.abs(uvs[a] - uvs[b]).max(axis=(1, 2)) <= UV_SEAM_TOLERANCE)
    )
    graph = coo_matrix((np.ones(int(joined.sum())), (owner[a][joined], owner[b][joined])), shape=(n, n))
    return connected_components(graph, directed=False)[1].astype(np.int64)


def _vote(labels: np.ndarray) -> np.ndarray:
    """Majority of each row of ``labels [N, K]``; ties go to the earliest column."""
    agree = (labels[:, :, None] == labels[:, None, :]).sum(axis=-1)
    return labels[np.arange(len(labels)), agree.argmax(axis=1)]


def transfer_attributes(source: Mesh, v_pos: np.ndarray, t_pos_idx: np.ndarray,
                        welded_idx: np.ndarray | None = None) -> Mesh:
    """A mesh with the given geometry and the attributes of ``source`` at its closest points.

    Args:
        source: the mesh whose UV sets, ``t_mat_idx``, ``v_color``, ``v_joints``/``v_weights``
            are carried over (authored normals are not: ``decimate`` gives the new mesh normal
            slots split at creases, whose normals follow its positions).
        v_pos: ``[V, 3]`` float positions of the new mesh, near the surface of ``source``.
        t_pos_idx: ``[T, 3]`` int64 triangles of the new mesh.
        welded_idx: ``[Ts, 3]`` the triangles of ``source`` over its welded positions
            (``weld_vertices`` at ``weld_tolerance``), where the caller has them; else welded here.

    Returns:
        A ``Mesh`` on ``source``'s device: ``v_pos`` float32, ``t_pos_idx``, one UV set per UV
        set of ``source`` (set 0 decides the patches; the others are read at the same closest
        points), ``t_mat_idx``; ``v_color`` interpolated at each vertex's closest point;
        ``v_joints``/``v_weights`` blended at that point as many per vertex as the source has
        (``lookalike.init.skin_weights.blend_influences``).
    """
    device = source.v_pos.device
    src_pos = source.v_pos.detach().cpu().numpy().astype(np.float64)
    src_idx = source.t_pos_idx.cpu().numpy()
    src_mat = source.t_mat_idx.cpu().numpy()
    v_pos = np.asarray(v_pos, dtype=np.float64)
    t_pos_idx = np.asarray(t_pos_idx, dtype=np.int64)

    src_uv = [(v.detach().cpu().numpy().astype(np.float64), i.cpu().numpy()) for v, i in source.uv]
    if welded_idx is None:
        welded_idx = weld_vertices(src_pos, src_idx, weld_tolerance(src_pos))[1]
    patch = surface_patches(welded_idx, src_mat, src_uv[0][0][src_uv[0][1]] if src_uv else None)
    query = SurfaceQuery(src_pos, src_idx, patch)

    corners = v_pos[t_pos_idx]                                                  # [T, 3, 3]
    centroid = corners.mean(axis=1, keepdims=True)
    voters = np.concatenate([centroid, corners + _VOTE_SHRINK * (centroid - corners)], axis=1)
    voted = patch[query.closest(voters.reshape(-1, 3)).triangle].reshape(-1, 4)
    t_patch = _vote(voted)
    t_mat_idx = src_mat[np.unique(patch, return_index=True)[1]][t_patch]

    uv = []
    if src_uv:
        pairs, t_corner = np.unique(np.stack([t_pos_idx, np.repeat(t_patch[:, None], 3, 1)], -1).reshape(-1, 2),
                                    axis=0, return_inverse=True)
        on_patch = query.closest(v_pos[pairs[:, 0]], labels=pairs[:, 1])
        uv = [(_interpolate(tex, idx[on_patch.triangle], on_patch.barycentric), t_corner.reshape(-1, 3))
              for tex, idx in src_uv]

    v_color = v_joints = v_weights = None
    if source.v_color is not None or source.v_joints is not None:
        nearest = query.closest(v_pos)
        src_corner = src_idx[nearest.triangle]                                  # [V, 3]
        if source.v_color is not None:
            v_color = _interpolate(source.v_color.detach().cpu().numpy(), src_corner, nearest.barycentric)
        if source.v_joints is not None:
            v_joints, v_weights = blend_influences(source, nearest.triangle, nearest.barycentric,
                                                   source.v_joints.shape[1])

    def tensor(x, dtype):
        if x is None:
            return None
        return torch.as_tensor(x if torch.is_tensor(x) else np.ascontiguousarray(x), dtype=dtype, device=device)

    return Mesh(
        v_pos=tensor(v_pos, torch.float32),
        t_pos_idx=tensor(t_pos_idx, torch.int64),
        uv=[(tensor(tex, torch.float32), tensor(idx, torch.int64)) for tex, idx in uv],
        v_color=tensor(v_color, torch.float32),
        t_mat_idx=tensor(t_mat_idx, torch.int64),
        v_joints=tensor(v_joints, torch.int64),
        v_weights=tensor(v_weights, torch.float32),
    )


def corner_materials(source: Mesh, mesh: Mesh) -> torch.Tensor:
    """``[T]`` int64: for each triangle of ``mesh`` (near the surface of ``source``), the material
    that most of its corners' closest points on ``source`` have, where all three differ the one at
    its centroid's closest point. A triangle whose colours are its corners' (``v_color``) is then
    drawn in the material those colours came from: a vote by area can give a large triangle the
    material of a patch that none of its corners touches, and its corners' colours lit as another
    material draw pale or dark smears."""
    query = SurfaceQuery(source.v_pos.detach().cpu().numpy().astype(np.float64), source.t_pos_idx.cpu().numpy())
    material = source.t_mat_idx.cpu().numpy()
    v_pos, t_pos_idx = mesh.v_pos.detach().cpu().numpy().astype(np.float64), mesh.t_pos_idx.cpu().numpy()
    at_vertex = material[query.closest(v_pos).triangle]                                              # [V]
    at_centroid = material[query.closest(v_pos[t_pos_idx].mean(axis=1)).triangle]                     # [T]
    labels = np.concatenate([at_vertex[t_pos_idx], at_centroid[:, None]], axis=1)                     # [T, 4]
    return torch.as_tensor(_vote(labels), dtype=torch.int64, device=mesh.t_pos_idx.device)


def _interpolate(values: np.ndarray, corner_idx: np.ndarray, bary: np.ndarray) -> np.ndarray:
    """``sum_j bary[:, j] * values[corner_idx[:, j]]``: ``values [M, C]``, ``corner_idx [N, 3]``,
    ``bary [N, 3]`` -> ``[N, C]`` float64."""
    return (bary[:, :, None] * values[corner_idx].astype(np.float64)).sum(axis=1)
