"""Tangent frames of a surface point, interpolated from per-corner frames as a renderer does, and
re-expressing tangent-space normals from one frame into another.

Our frame is ``lookalike.asset.tangents.vertex_tangents`` on the mesh's shading normals
(``lookalike.asset.mesh.Mesh.normals``: authored, or split smooth normals of the positions); files
use others (``lookalike.io.normal_frames``).

A frame is given per triangle corner: normals ``[T, 3, 3]`` and tangents ``[T, 3, 4]`` (xyz, w).
At a point of triangle ``f`` with barycentrics ``l``, a renderer interpolates
``n = normalize(sum l_k n_k)``, ``t = normalize(T - n (n . T))`` with ``T = sum l_k t_k``,
``b = sign(w) cross(n, t)``; a normal-map value ``m`` means ``m.x t + m.y b + m.z n``.
Re-expressing maps ``m_src`` to ``m_dst = (s . t_dst, s . b_dst, s . n_dst)`` with ``s`` that
surface normal in the source frame, then normalises.
"""

from __future__ import annotations

import numpy as np
import torch
from numba import njit

from ..kernel_cache import CACHE
from .mesh import Mesh
from .tangents import vertex_tangents


def unit(x: np.ndarray) -> np.ndarray:
    """``x / max(|x|, 1e-30)`` along the last axis."""
    return x / np.maximum(np.linalg.norm(x, axis=-1, keepdims=True), 1e-30)


def texel_frames(normals: np.ndarray, tangents: np.ndarray, tri: np.ndarray, bary: np.ndarray):
    """Per-point orthonormal ``(t, b, n)``, each ``[K, 3]``, interpolated as a renderer does (module
    docstring) at triangles ``tri [K]`` with barycentrics ``bary [K, 3]`` from corner frames
    ``normals [T, 3, 3]``, ``tangents [T, 3, 4]``; a tangent that vanishes after Gram-Schmidt falls
    back to ``cross(axis, n)`` with ``axis = x``, or ``y`` where ``n`` is close to ``x``."""
    n = unit(np.einsum("kc,kcd->kd", bary, normals[tri]))
    t4 = np.einsum("kc,kcd->kd", bary, tangents[tri])
    t = t4[:, :3] - n * (n * t4[:, :3]).sum(-1, keepdims=True)
    axis = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    weak = np.linalg.norm(t, axis=-1) < 1e-6
    t = np.where(weak[:, None], np.cross(axis, n), t)
    t = unit(t)
    b = np.where(t4[:, 3:] < 0, -1.0, 1.0) * np.cross(n, t)
    return t, b, n


@njit(cache=CACHE, inline="always")
def frame_at(normals, tangents, f, l0, l1, l2):
    """Orthonormal frame ``(t, b, n)`` of triangle ``f`` at barycentrics ``(l0, l1, l2)`` as nine
    scalars ``tx, ty, tz, bx, by, bz, nx, ny, nz`` (the same computation as ``texel_frames``, for
    compiled kernels)."""
    nx = l0 * normals[f, 0, 0] + l1 * normals[f, 1, 0] + l2 * normals[f, 2, 0]
    ny = l0 * normals[f, 0, 1] + l1 * normals[f, 1, 1] + l2 * normals[f, 2, 1]
    nz = l0 * normals[f, 0, 2] + l1 * normals[f, 1, 2] + l2 * normals[f, 2, 2]
    length = max(np.sqrt(nx * nx + ny * ny + nz * nz), 1e-30)
    nx, ny, nz = nx / length, ny / length, nz / length
    tx = l0 * tangents[f, 0, 0] + l1 * tangents[f, 1, 0] + l2 * tangents[f, 2, 0]
    ty = l0 * tangents[f, 0, 1] + l1 * tangents[f, 1, 1] + l2 * tangents[f, 2, 1]
    tz = l0 * tangents[f, 0, 2] + l1 * tangents[f, 1, 2] + l2 * tangents[f, 2, 2]
    tw = l0 * tangents[f, 0, 3] + l1 * tangents[f, 1, 3] + l2 * tangents[f, 2, 3]
    d = nx * tx + ny * ty + nz * tz
    tx, ty, tz = tx - d * nx, ty - d * ny, tz - d * nz
    length = np.sqrt(tx * tx + ty * ty + tz * tz)
    if length < 1e-6:  # fallback: cross(axis, n) with axis = x, or y where n is close to x
        if abs(nx) < 0.9:
            tx, ty, tz = 0.0, -nz, ny
        else:
            tx, ty, tz = nz, 0.0, -nx
        length = np.sqrt(tx * tx + ty * ty + tz * tz)
    tx, ty, tz = tx / length, ty / length, tz / length
    sign = -1.0 if tw < 0 else 1.0
    bx, by, bz = sign * (ny * tz - nz * ty), sign * (nz * tx - nx * tz), sign * (nx * ty - ny * tx)
    return tx, ty, tz, bx, by, bz, nx, ny, nz


def reexpress_texels(values: np.ndarray, src: tuple[np.ndarray, np.ndarray], dst: tuple[np.ndarray, np.ndarray],
                     tri: np.ndarray, bary: np.ndarray) -> np.ndarray:
    """Normal-map ``values [K, 3]`` in corner frame ``src`` -> ``[K, 3]`` float64 unit normals in
    corner frame ``dst`` (module docstring), at triangles ``tri [K]`` with barycentrics
    ``bary [K, 3]``; ``src`` and ``dst`` are ``(normals [T, 3, 3], tangents [T, 3, 4])``."""
    t1, b1, n1 = texel_frames(*src, tri, bary)
    surface = values[:, :1] * t1 + values[:, 1:2] * b1 + values[:, 2:] * n1
    t2, b2, n2 = texel_frames(*dst, tri, bary)
    return unit(np.stack([(surface * t2).sum(-1), (surface * b2).sum(-1), (surface * n2).sum(-1)], axis=-1))


def _float_normals(mesh: Mesh) -> tuple[torch.Tensor, torch.Tensor]:
    """``Mesh.normals`` of the detached mesh as float32 ``([VN, 3], [T, 3])``, as renderers and
    writers use them."""
    v_nrm, t_nrm_idx = mesh.detach().normals()
    return v_nrm.float(), t_nrm_idx


def corner_normals(mesh: Mesh) -> np.ndarray:
    """``[T, 3, 3]`` float64 shading normals (``Mesh.normals``, float32) at each corner."""
    v_nrm, t_nrm_idx = _float_normals(mesh)
    return v_nrm[t_nrm_idx].numpy().astype(np.float64)


def our_corner_frame(mesh: Mesh, uv_set: int) -> tuple[np.ndarray, np.ndarray]:
    """Our frame per corner: shading normals ``[T, 3, 3]`` and ``vertex_tangents`` ``[T, 3, 4]``
    of UV set ``uv_set``, float64."""
    v_nrm, t_nrm_idx = _float_normals(mesh)
    v_tex, t_tex_idx = mesh.uv[uv_set]
    v_tng, t_tng_idx = vertex_tangents(mesh.v_pos.detach().float(), mesh.t_pos_idx, v_tex.detach().float(), t_tex_idx,
                                       v_nrm, t_nrm_idx)
    return v_nrm[t_nrm_idx].numpy().astype(np.float64), v_tng[t_tng_idx].numpy().astype(np.float64)


def corner_uvs(mesh: Mesh, uv_set: int) -> np.ndarray:
    """``[T, 3, 2]`` float32 corner UVs of a UV set."""
    v_tex, t_tex_idx = mesh.uv[uv_set]
    return v_tex.detach().float()[t_tex_idx].numpy()
