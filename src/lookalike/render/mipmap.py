"""Mip pyramids and the mip level (level of detail) of a texture footprint.

:func:`texture_pyramid` builds the pyramid with compiled loops (:mod:`.mip_kernels`) and a
hand-written backward; :func:`texture_construct_mip` (nvdiffrast's API, plain torch) builds
the same levels and is its twin in the tests.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F

from ..devices import launch, uses_cuda_kernels
from . import mip_kernels
from .sampling import Pyramid


def mip_sizes(height: int, width: int, max_mip_level: int | None = None) -> list[tuple[int, int]]:
    """Sizes of levels 1, 2, ...: each halves both sides (rounding down, never below 1)
    until ``1 x 1`` or ``max_mip_level`` levels."""
    sizes = []
    while (height > 1 or width > 1) and (max_mip_level is None or len(sizes) < max_mip_level):
        height, width = max(1, height // 2), max(1, width // 2)
        sizes.append((height, width))
    return sizes


def texture_construct_mip(tex: torch.Tensor, max_mip_level: int | None = None) -> list[torch.Tensor]:
    """Mip levels 1, 2, ... of ``tex [B, H, W, C]`` as a list of ``[B, h_l, w_l, C]``.

    Each level is the area average of the previous one (a 2x2 box filter for even sides;
    odd sides average the overlapping source texels proportionally), so it is linear in
    ``tex`` and gradients reach the base level.  Pass the list as ``texture(..., mip=...)``
    (nvdiffrast's ``texture_construct_mip`` returns an opaque object for the same use).
    """
    levels = []
    level = tex.permute(0, 3, 1, 2)
    for size in mip_sizes(tex.shape[1], tex.shape[2], max_mip_level):
        level = F.interpolate(level, size=size, mode="area")
        levels.append(level.permute(0, 2, 3, 1))
    return levels


def footprint_level(uv_da: torch.Tensor, height: int, width: int) -> torch.Tensor:
    """Mip level ``[...]`` of the pixel footprints ``uv_da [..., 4] = (du/dX, du/dY, dv/dX,
    dv/dY)`` on a ``height x width`` base level.

    With the footprint Jacobian in texels ``J = [[W du/dX, W du/dY], [H dv/dX, H dv/dY]]``
    the level is ``log2`` of its largest singular value, ``0.5 log2(lambda_max(J J^T))``
    where ``lambda_max = (a + c)/2 + sqrt(((a - c)/2)^2 + b^2)`` for ``J J^T = [[a, b], [b, c]]``.
    Zero footprints give a very negative level (clamped to 0 by the caller) and gradients
    stay finite.
    """
    ds = uv_da[..., 0:2] * width
    dt = uv_da[..., 2:4] * height
    a = (ds * ds).sum(-1)
    c = (dt * dt).sum(-1)
    b = (ds * dt).sum(-1)
    tiny = torch.finfo(uv_da.dtype).tiny
    root = torch.sqrt((0.25 * (a - c) ** 2 + b * b).clamp_min(tiny))
    return 0.5 * torch.log2((0.5 * (a + c) + root).clamp_min(tiny))


class _BuildPyramid(torch.autograd.Function):
    """``tex [B, H, W, C]`` -> flat table ``[N, C]`` of all levels (see :class:`Pyramid`),
    each level the area average of the previous; backward folds the gradients of the
    coarser levels down to ``tex``. The compiled kernels, or their CUDA forms on the GPU."""

    @staticmethod
    def forward(ctx, tex, sizes):
        n_views, height, width, channels = tex.shape
        layout = Pyramid(None, sizes, n_views)
        table = tex.new_empty(int((layout.heights * layout.widths).sum()) * n_views, channels)
        table[: n_views * height * width] = tex.detach().reshape(-1, channels)
        for level in range(1, len(sizes)):
            _level_kernel("downsample", table, layout, sizes, level, n_views, n_views * sizes[level][0] * sizes[level][1])
        ctx.layout, ctx.sizes, ctx.tex_shape = layout, sizes, tex.shape
        return table

    @staticmethod
    def backward(ctx, grad_table):
        grad = grad_table.contiguous().clone()
        layout, sizes, n_views = ctx.layout, ctx.sizes, ctx.tex_shape[0]
        for level in range(len(sizes) - 1, 0, -1):
            threads = n_views * sizes[level - 1][0] * sizes[level - 1][1]
            _level_kernel("downsample_adjoint", grad, layout, sizes, level, n_views, threads)
        n_base = ctx.tex_shape[0] * ctx.tex_shape[1] * ctx.tex_shape[2]
        return grad[:n_base].reshape(ctx.tex_shape), None


def _level_kernel(name: str, table: torch.Tensor, layout: Pyramid, sizes: list[tuple[int, int]], level: int,
                  n_views: int, threads: int) -> None:
    """Run the kernel ``name`` (``downsample`` or ``downsample_adjoint``) between levels
    ``level - 1`` and ``level`` of ``table [N, C]``: :mod:`.mip_kernels`'s, or :mod:`.mip_cuda`'s
    on ``threads`` GPU threads for a table on the GPU."""
    args = (int(layout.offsets[level - 1]), *sizes[level - 1], int(layout.offsets[level]), *sizes[level], n_views)
    if uses_cuda_kernels(table):
        from . import mip_cuda

        launch(getattr(mip_cuda, name), threads, table, *args)
    else:
        getattr(mip_kernels, name)(table.numpy(), *args)


def texture_pyramid(tex: torch.Tensor, max_mip_level: int | None = None) -> Pyramid:
    """:class:`Pyramid` of ``tex [B, H, W, C]`` and the levels :func:`texture_construct_mip`
    would build, computed by compiled loops straight into one table (gradients reach
    ``tex``). Pass it as ``texture(tex, ..., mip=pyramid)`` to filter several lookups of the
    same texels with one pyramid."""
    sizes = [tuple(tex.shape[1:3])] + mip_sizes(tex.shape[1], tex.shape[2], max_mip_level)
    table = _BuildPyramid.apply(tex.contiguous(), sizes)
    return Pyramid(table, sizes, tex.shape[0])
