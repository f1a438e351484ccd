"""Texel gathers with flat index arithmetic over a whole mip pyramid.

All levels are concatenated into one ``[texels, C]`` table (:class:`Pyramid`, also the layout
the compiled :mod:`.texture_kernels` read), so a per-pixel level index selects the level by
offset arithmetic and every lookup is a single ``index_select``.  The plain-torch gathers
:func:`sample_nearest` and :func:`sample_bilinear` are what the twin
:func:`.texture.texture_python` is built on.
"""

from __future__ import annotations

import torch


class Pyramid:
    """Mip levels ``[B, h_l, w_l, C]`` (all with the same ``B`` and ``C``) as one flat table.

    Attributes:
        table: ``[sum_l B h_l w_l, C]``, level after level, each in ``[B, h, w]`` order.
        heights, widths, offsets: ``[L]`` int64 per-level size and first row in ``table``.
    """

    def __init__(self, table: torch.Tensor, sizes: list[tuple[int, int]], n_views: int):
        self.table = table
        self.heights = torch.tensor([h for h, _ in sizes], dtype=torch.int64)
        self.widths = torch.tensor([w for _, w in sizes], dtype=torch.int64)
        counts = self.heights * self.widths * n_views
        self.offsets = torch.cumsum(counts, 0) - counts

    @classmethod
    def from_levels(cls, levels: list[torch.Tensor]) -> Pyramid:
        """Concatenate given levels (gradients flow back to each)."""
        channels = levels[0].shape[-1]
        n_views = levels[0].shape[0]
        for level in levels:
            if level.dim() != 4 or level.shape[0] != n_views or level.shape[-1] != channels:
                raise ValueError(f"mip levels must all be [{n_views}, h, w, {channels}], got {tuple(level.shape)}")
        table = levels[0].reshape(-1, channels) if len(levels) == 1 else torch.cat(
            [level.reshape(-1, channels) for level in levels]
        )
        return cls(table, [tuple(level.shape[1:3]) for level in levels], n_views)

    def geometry(self, level: torch.Tensor | None, view: torch.Tensor | None):
        """``(height, width, base)`` per pixel (``[P]`` int64 each, or 0-d for one level and
        view): the level's size and the table row of its texel ``(0, 0)`` in the pixel's view."""
        if level is None:
            height, width, base = self.heights[0], self.widths[0], self.offsets[0]
        else:
            height, width, base = self.heights[level], self.widths[level], self.offsets[level]
        if view is not None:
            base = base + view * height * width
        return height, width, base


def _resolve(index: torch.Tensor, size: torch.Tensor, boundary_mode: str) -> tuple[torch.Tensor, torch.Tensor | None]:
    """Texel index along one axis after the boundary rule, and (``"zero"`` mode) a mask of
    indices that were inside (None otherwise)."""
    if boundary_mode == "wrap":
        return torch.remainder(index, size), None
    if boundary_mode == "clamp":
        return torch.minimum(index.clamp_min(0), size - 1), None
    inside = (index >= 0) & (index < size)
    return torch.minimum(index.clamp_min(0), size - 1), inside


def sample_nearest(pyramid: Pyramid, level, view, uv: torch.Tensor, boundary_mode: str) -> torch.Tensor:
    """``[P, C]``: the texel containing ``uv [P, 2]``, i.e. column ``floor(u w)``, row
    ``floor(v h)``; no gradient to ``uv``."""
    height, width, base = pyramid.geometry(level, view)
    uv = uv.detach()
    col, col_in = _resolve(torch.floor(uv[:, 0] * width).long(), width, boundary_mode)
    row, row_in = _resolve(torch.floor(uv[:, 1] * height).long(), height, boundary_mode)
    out = pyramid.table.index_select(0, base + row * width + col)
    if col_in is not None:
        out = out * (col_in & row_in)[:, None].to(out.dtype)
    return out


def sample_bilinear(pyramid: Pyramid, level, view, uv: torch.Tensor, boundary_mode: str) -> torch.Tensor:
    """``[P, C]``: bilinear interpolation of the four texels around ``uv [P, 2]``.

    With ``x = u w - 1/2``, ``y = v h - 1/2``, ``x0 = floor(x)``, ``fx = x - x0`` (same for
    ``y``) the result is ``sum (1-fx|fx)(1-fy|fy) T[y0|y0+1, x0|x0+1]``; differentiable in
    the texels and in ``uv`` (through ``fx, fy``).
    """
    height, width, base = pyramid.geometry(level, view)
    x = uv[:, 0] * width - 0.5
    y = uv[:, 1] * height - 0.5
    x0 = torch.floor(x.detach())
    y0 = torch.floor(y.detach())
    fx = (x - x0)[:, None]
    fy = (y - y0)[:, None]
    x0, y0 = x0.long(), y0.long()
    col0, col0_in = _resolve(x0, width, boundary_mode)
    col1, col1_in = _resolve(x0 + 1, width, boundary_mode)
    row0, row0_in = _resolve(y0, height, boundary_mode)
    row1, row1_in = _resolve(y0 + 1, height, boundary_mode)
    row0, row1 = base + row0 * width, base + row1 * width
    index = torch.cat([row0 + col0, row0 + col1, row1 + col0, row1 + col1])
    texels = pyramid.table.index_select(0, index).reshape(4, -1, pyramid.table.shape[1])
    if col0_in is not None:
        inside = torch.stack([row0_in & col0_in, row0_in & col1_in, row1_in & col0_in, row1_in & col1_in])
        texels = texels * inside[..., None].to(texels.dtype)
    top = texels[0] + fx * (texels[1] - texels[0])
    bottom = texels[2] + fx * (texels[3] - texels[2])
    return top + fy * (bottom - top)
