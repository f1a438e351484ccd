"""Undirected edges of a triangle list, found once (vectorised) for topology-based operators."""

from __future__ import annotations

import torch


def edge_index(t_idx: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Unique undirected edges of triangles and which edge each triangle side is.

    Args:
        t_idx: ``[T, 3]`` int64 triangle indices.
    Returns:
        ``(edges [E, 2], side_edge [T, 3])`` int64: ``edges`` sorted lexicographically with
        ``edges[:, 0] <= edges[:, 1]`` (degenerate sides ``(a, a)`` included); side ``k`` of
        triangle ``t`` joins corners ``k`` and ``(k + 1) % 3`` and is ``edges[side_edge[t, k]]``.
    """
    ends = torch.stack([t_idx, t_idx.roll(-1, dims=1)], dim=-1)  # [T, 3, 2]
    low, high = ends.min(dim=-1).values, ends.max(dim=-1).values
    base = int(t_idx.max()) + 1 if t_idx.numel() else 1
    keys, side_edge = torch.unique(low * base + high, return_inverse=True)
    return torch.stack([keys // base, keys % base], dim=1), side_edge.reshape(t_idx.shape)
