"""Per-vertex tangent frames from UVs: lookalike's own tangent space for normal maps.

Convention (glTF's TANGENT attribute, with UVs in glTF's convention, v pointing DOWN the image):
a tangent is ``(t, w)`` with ``t`` the unit direction of increasing u, orthogonal to the shading
normal ``n`` (``lookalike.asset.mesh.Mesh.normals``), and ``w = +-1``. The bitangent is
``b = w * cross(n, t)``, and ``w`` is chosen so that ``b`` points towards DEcreasing v, i.e. up
the image: a normal-map texel ``(x, y, z)`` means ``x`` along ``t`` (right in the image), ``y``
along ``b`` (up in the image, the "OpenGL"/+Y convention of glTF and MikkTSpace) and ``z`` along
``n``.

Per triangle with edges ``e1 = p1 - p0``, ``e2 = p2 - p0`` and UV edges ``d1 = uv1 - uv0``,
``d2 = uv2 - uv0``, ``det = d1.u * d2.v - d2.u * d1.v`` and the UV gradient
``dP/du = (e1 * d2.v - e2 * d1.v) / det``. Since ``n . (dP/du x dP/dv) = |e1 x e2| / det``,
the bitangent ``cross(n, dP/du)`` points along ``+dP/dv`` (down the image) exactly when
``det > 0``; hence ``w = -sign(det)`` (``det = 0`` counts as negative, so ``w = +1``, the
unmirrored case).

Corners are grouped by (normal slot, UV index, w): a UV seam, a hard edge (a change of normal
slot) or a mirror line (a change of ``w``) splits the tangent, so tangent frames follow split
normals. Each group's tangent is the sum over its corners of the triangle's unit ``dP/du``
direction weighted by the triangle area, made orthogonal to ``n`` (Gram-Schmidt) and normalised.
Triangles with degenerate UVs contribute nothing; a group whose sum is (nearly) parallel to ``n``
or zero falls back to ``normalize(cross(n, a))`` with ``a`` the coordinate axis least aligned
with ``n``, so every output is a finite unit vector orthogonal to ``n`` and gradients are finite
everywhere.
"""

from __future__ import annotations

import torch

from .normals import safe_normalize


def _fallback_tangent(n: torch.Tensor) -> torch.Tensor:
    """``[N, 3]`` unit vectors orthogonal to unit normals ``n [N, 3]``: ``cross(n, a)`` with ``a``
    the x axis where ``|n.x| < 0.9``, else the y axis (``|cross|`` is then at least ~0.43)."""
    x_axis = torch.zeros_like(n)
    x_axis[:, 0] = 1.0
    y_axis = torch.zeros_like(n)
    y_axis[:, 1] = 1.0
    axis = torch.where(n[:, :1].abs() < 0.9, x_axis, y_axis)
    return safe_normalize(torch.linalg.cross(axis, n, dim=-1))


def vertex_tangents(v_pos: torch.Tensor, t_pos_idx: torch.Tensor, v_tex: torch.Tensor, t_tex_idx: torch.Tensor,
                    v_nrm: torch.Tensor, t_nrm_idx: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Smooth tangent frames (see the module docstring for the convention and the formula).

    Differentiable pure torch with respect to ``v_pos``, ``v_tex`` and ``v_nrm``.

    Args:
        v_pos: ``[V, 3]`` float positions.
        t_pos_idx: ``[T, 3]`` int64 counter-clockwise triangles.
        v_tex: ``[VT, 2]`` float UVs (glTF convention, v down the image).
        t_tex_idx: ``[T, 3]`` int64 UV indices.
        v_nrm: ``[VN, 3]`` float unit shading normals.
        t_nrm_idx: ``[T, 3]`` int64 normal slot of each corner (each slot used at one position).
    Returns:
        ``v_tng [N, 4]`` (dtype of ``v_pos``): unit tangent ``xyz`` orthogonal to the normal and
        handedness ``w = +-1``; ``t_tng_idx [T, 3]`` int64 indices into ``v_tng``.
    """
    p0, p1, p2 = (v_pos[t_pos_idx[:, k]] for k in range(3))
    uv0, uv1, uv2 = (v_tex[t_tex_idx[:, k]] for k in range(3))
    e1, e2 = p1 - p0, p2 - p0
    d1, d2 = uv1 - uv0, uv2 - uv0
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    sign = torch.where(det > 0, 1.0, -1.0).to(v_pos.dtype)
    # (e1 * d2.v - e2 * d1.v) = det * dP/du; times sign(det) it points along +dP/du.
    face_dir = safe_normalize((e1 * d2[:, 1:] - e2 * d1[:, 1:]) * sign[:, None])
    area2 = torch.linalg.cross(e1, e2, dim=-1).norm(dim=-1, keepdim=True)
    handedness = -sign

    # One int64 key per corner: (normal slot, UV index, w > 0), unique keys = tangent groups.
    n_tex = max(int(v_tex.shape[0]), 1)
    keys = (t_nrm_idx * n_tex + t_tex_idx) * 2 + (handedness > 0).to(torch.int64)[:, None]
    unique_keys, group = torch.unique(keys.reshape(-1), return_inverse=True)
    contribution = (face_dir * area2).repeat_interleave(3, dim=0)
    summed = torch.zeros(unique_keys.shape[0], 3, dtype=v_pos.dtype, device=v_pos.device)
    summed = summed.index_add(0, group, contribution)

    n = safe_normalize(v_nrm[unique_keys // (2 * n_tex)])
    orthogonal = summed - n * (n * summed).sum(dim=-1, keepdim=True)
    usable = (orthogonal * orthogonal).sum(-1, keepdim=True) > 1e-10 * (summed * summed).sum(-1, keepdim=True) + 1e-30
    tangent = torch.where(usable, safe_normalize(orthogonal), _fallback_tangent(n))
    w = torch.where(unique_keys % 2 == 1, 1.0, -1.0).to(v_pos.dtype)[:, None]
    return torch.cat([tangent, w], dim=-1), group.reshape(-1, 3)
