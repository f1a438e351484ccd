"""Area-weighted smooth vertex normals, differentiable with respect to positions."""

from __future__ import annotations

import torch

FALLBACK_NORMAL = (0.0, 0.0, 1.0)
"""Normal given to vertices whose adjacent triangles all have zero area (or no triangles)."""


def safe_normalize(x: torch.Tensor, eps: float = 1e-20) -> torch.Tensor:
    """``x / |x|`` along the last axis, with ``|x|^2`` clamped below by ``eps`` so that a zero
    vector stays zero (finite value and gradient) instead of becoming NaN.

    Args:
        x: ``[..., C]`` float tensor.
    Returns:
        ``[..., C]``, same dtype.
    """
    return x * torch.rsqrt(torch.clamp((x * x).sum(dim=-1, keepdim=True), min=eps))


def face_normals(v_pos: torch.Tensor, t_pos_idx: torch.Tensor) -> torch.Tensor:
    """Unnormalised face normals ``(v1 - v0) x (v2 - v0)``; the length is twice the area.

    Args:
        v_pos: ``[V, 3]`` float positions.
        t_pos_idx: ``[T, 3]`` int64 counter-clockwise triangles.
    Returns:
        ``[T, 3]`` float, same dtype as ``v_pos``.
    """
    v0, v1, v2 = (v_pos[t_pos_idx[:, k]] for k in range(3))
    return torch.linalg.cross(v1 - v0, v2 - v0, dim=-1)


def vertex_normals(v_pos: torch.Tensor, t_pos_idx: torch.Tensor) -> torch.Tensor:
    """Smooth unit vertex normals, each the normalised sum of the area-weighted normals
    ``(v1 - v0) x (v2 - v0)`` of the triangles around the vertex.

    Degenerate (zero-area) triangles contribute nothing; a vertex whose accumulated normal is
    zero gets ``FALLBACK_NORMAL``. Values and gradients are finite for any input.

    Args:
        v_pos: ``[V, 3]`` float positions (float32 or float64).
        t_pos_idx: ``[T, 3]`` int64 counter-clockwise triangles.
    Returns:
        ``[V, 3]`` unit normals, dtype and device of ``v_pos``.
    """
    fn = face_normals(v_pos, t_pos_idx)
    summed = torch.zeros_like(v_pos).index_add(0, t_pos_idx.reshape(-1), fn.repeat_interleave(3, dim=0))
    length2 = (summed * summed).sum(dim=-1, keepdim=True)
    fallback = torch.tensor(FALLBACK_NORMAL, dtype=v_pos.dtype, device=v_pos.device)
    tiny = torch.finfo(v_pos.dtype).tiny
    return torch.where(length2 > tiny, safe_normalize(summed, eps=tiny), fallback)
