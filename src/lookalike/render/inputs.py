"""Input checks shared by the primitives, and nvdiffrast's instanced and range modes: which
positions and triangles each view of a batch draws."""

from __future__ import annotations

import torch


def per_view_positions(pos: torch.Tensor, tri: torch.Tensor, ranges: torch.Tensor | None) -> tuple[torch.Tensor, torch.Tensor]:
    """Normalise nvdiffrast's two batching modes.

    - Instanced mode: ``pos [B, V, 4]``, ``ranges=None``: every view draws all triangles.
    - Range mode: ``pos [V, 4]``, ``ranges [B, 2]`` int ``(first, count)``: view ``b``
      draws triangles ``first .. first+count-1`` of the shared positions.

    Returns ``(pos [B, V, 4], tri_range [B, 2] int64)``; in range mode ``pos`` is an
    expanded view of the input (gradients accumulate into it).
    """
    if pos.dim() == 3 and pos.shape[-1] == 4:
        if ranges is not None:
            raise ValueError("ranges is only allowed with pos of shape [V, 4] (range mode)")
        full = torch.tensor([[0, tri.shape[0]]], dtype=torch.int64).expand(pos.shape[0], 2)
        return pos, full
    if pos.dim() == 2 and pos.shape[-1] == 4:
        if ranges is None:
            raise ValueError("pos of shape [V, 4] needs ranges [B, 2] (range mode)")
        ranges = torch.as_tensor(ranges, dtype=torch.int64).cpu()
        if ranges.dim() != 2 or ranges.shape[1] != 2:
            raise ValueError(f"ranges must have shape [B, 2], got {tuple(ranges.shape)}")
        if (ranges < 0).any() or (ranges.sum(1) > tri.shape[0]).any():
            raise ValueError("ranges select triangles outside tri")
        return pos.expand(ranges.shape[0], -1, -1), ranges
    raise ValueError(f"pos must have shape [B, V, 4] or [V, 4], got {tuple(pos.shape)}")


def check_triangles(tri: torch.Tensor, n_verts: int) -> torch.Tensor:
    """``tri [T, 3]`` int32 or int64 -> int64, checking shape and index range."""
    if tri.dim() != 2 or tri.shape[1] != 3:
        raise ValueError(f"tri must have shape [T, 3], got {tuple(tri.shape)}")
    if tri.dtype not in (torch.int32, torch.int64):
        raise ValueError(f"tri must be int32 or int64, got {tri.dtype}")
    if tri.numel():
        low, high = torch.aminmax(tri)  # one pass over the given type, before the int64 copy
        if low < 0 or high >= n_verts:
            raise ValueError(f"tri indexes vertices outside 0..{n_verts - 1}")
    return tri.long()


def check_rast_ids(rast: torch.Tensor, n_tris: int) -> None:
    """Raise unless ``rast [B, H, W, 4]`` names only triangles ``0 .. n_tris - 1`` (ids
    ``0 .. n_tris``), so compiled kernels never index outside ``tri``."""
    if rast.dim() != 4 or rast.shape[-1] != 4:
        raise ValueError(f"rast must have shape [B, H, W, 4], got {tuple(rast.shape)}")
    ids = rast[..., 3].detach()
    if ids.numel():
        low, high = torch.aminmax(ids)  # one pass, not two
        if low < 0 or high > n_tris:
            raise ValueError(f"rast names triangles beyond the {n_tris} of tri")
