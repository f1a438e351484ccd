"""``texture``: filtered texture lookups (nearest, bilinear, mipmapped) with gradients to
texels, texture coordinates and their derivatives.  The lookups are compiled
(:mod:`.texture_kernels`) with a hand-written backward; :func:`texture_python` is the
plain-torch twin."""

from __future__ import annotations

import numba
import torch

from ..devices import launch, uses_cuda_kernels
from . import texture_kernels as kernels
from .mipmap import footprint_level, texture_construct_mip, texture_pyramid
from .sampling import Pyramid, sample_bilinear, sample_nearest

FILTER_MODES = {
    "nearest": kernels.NEAREST,
    "linear": kernels.LINEAR,
    "linear-mipmap-nearest": kernels.MIP_NEAREST,
    "linear-mipmap-linear": kernels.MIP_LINEAR,
}
BOUNDARY_MODES = {"wrap": kernels.WRAP, "clamp": kernels.CLAMP, "zero": kernels.ZERO}


class _Texture(torch.autograd.Function):
    """Compiled lookups (their CUDA forms for tensors on the GPU): ``(table [N,C], uv [P,2],
    uv_da [P,4]|None, bias [P]|None, pyramid, per_view, pixels_per_view, mode, boundary)`` ->
    ``[P, C]``."""

    @staticmethod
    def forward(ctx, table, uv, uv_da, bias, pyramid, per_view, pixels_per_view, mode, boundary):
        dtype = torch.promote_types(table.dtype, uv.dtype)
        arrays = [
            table.detach().to(dtype).contiguous(),
            uv.detach().to(dtype).contiguous(),
            (uv_da.detach().to(dtype) if uv_da is not None else uv.new_zeros(0, 4, dtype=dtype)).contiguous(),
            (bias.detach().to(dtype) if bias is not None else uv.new_zeros(0, dtype=dtype)).contiguous(),
        ]
        sizes = tuple(t.to(table.device) for t in (pyramid.heights, pyramid.widths, pyramid.offsets))
        geometry = (*sizes, per_view, pixels_per_view)
        out = arrays[0].new_zeros(uv.shape[0], table.shape[1])
        if uses_cuda_kernels(table):
            from . import texture_cuda

            launch(texture_cuda.texture_forward, uv.shape[0], arrays[0], *geometry, *arrays[1:], mode, boundary, out)
        else:
            kernels.texture_forward(arrays[0].numpy(), *(g.numpy() for g in sizes), per_view, pixels_per_view,
                                    *(a.numpy() for a in arrays[1:]), mode, boundary, out.numpy())
        ctx.save_for_backward(*arrays)
        ctx.geometry, ctx.mode, ctx.boundary = geometry, mode, boundary
        ctx.present = (uv_da is not None, bias is not None)
        return out

    @staticmethod
    def backward(ctx, grad_out):
        table, uv, uv_da, bias = ctx.saved_tensors
        grads = [torch.zeros_like(t) for t in (table, uv, uv_da, bias)]
        grad_out = grad_out.to(table.dtype).contiguous()
        if uses_cuda_kernels(table):
            from . import texture_cuda

            launch(texture_cuda.texture_backward, uv.shape[0], table, *ctx.geometry, uv, uv_da, bias, ctx.mode,
                   ctx.boundary, grad_out, *grads)
        else:
            sizes, flags = (g.numpy() for g in ctx.geometry[:3]), ctx.geometry[3:]
            kernels.texture_backward(
                table.numpy(), *sizes, *flags, uv.numpy(), uv_da.numpy(), bias.numpy(), ctx.mode, ctx.boundary,
                grad_out.numpy(), *(g.numpy() for g in grads), numba.get_num_threads(),
            )
        grad_table, grad_uv, grad_uv_da, grad_bias = grads
        return (
            grad_table, grad_uv,
            grad_uv_da if ctx.present[0] else None, grad_bias if ctx.present[1] else None,
            None, None, None, None, None,
        )


def texture(
    tex: torch.Tensor,
    uv: torch.Tensor,
    uv_da: torch.Tensor | None = None,
    mip_level_bias: torch.Tensor | None = None,
    mip: list[torch.Tensor] | Pyramid | None = None,
    filter_mode: str = "auto",
    boundary_mode: str = "wrap",
    max_mip_level: int | None = None,
) -> torch.Tensor:
    """Sample a 2D texture at every pixel (nvdiffrast's ``dr.texture``).

    Args:
        tex: ``[B, Ht, Wt, C]`` (or ``[1, Ht, Wt, C]`` shared by all views) texels, level 0.
        uv: ``[B, H, W, 2]`` texture coordinates.  Texel ``(row r, column c)`` has its centre
            at ``uv = ((c + 0.5) / Wt, (r + 0.5) / Ht)``: ``u`` runs along columns, ``v`` along
            rows, row 0 at ``v = 0``.
        uv_da: ``[B, H, W, 4]`` ``(du/dX, du/dY, dv/dX, dv/dY)`` in pixel units (from
            :func:`interpolate` with ``diff_attrs``), which pick the mip level.
        mip_level_bias: ``[B, H, W]`` added to the mip level.
        mip: mip levels 1, 2, ... as a list of ``[B, h_l, w_l, C]`` tensors, each its own
            variable (gradients go to each level); or a ``Pyramid`` from
            :func:`.mipmap.texture_pyramid` of ``tex`` (nvdiffrast's opaque mip object: built
            once, it serves every lookup of the same texels; ``max_mip_level`` is the
            pyramid's); None builds the same levels as :func:`texture_construct_mip` with
            compiled loops (faster than a list; gradients reach ``tex``).
        filter_mode: ``"nearest"``, ``"linear"`` (bilinear), ``"linear-mipmap-nearest"``
            (bilinear in the nearest level), ``"linear-mipmap-linear"`` (trilinear), or
            ``"auto"``: trilinear when ``uv_da`` or ``mip_level_bias`` is given, else bilinear.
        boundary_mode: ``"wrap"`` (repeat), ``"clamp"`` (edge texels) or ``"zero"`` (texels
            outside are zero).
        max_mip_level: use at most this many levels above level 0.

    Returns:
        ``[B, H, W, C]`` filtered values.  The mip level is
        ``clamp(log2(sigma_max) + bias, 0, L)`` with ``sigma_max`` the largest singular
        value of the footprint in level-0 texels (see :func:`.mipmap.footprint_level`);
        trilinear blends the bilinear lookups of levels ``floor`` and ``floor + 1`` by the
        fraction.  Gradients flow to texels (all levels), ``uv`` (not in nearest mode),
        ``uv_da`` and ``mip_level_bias`` (trilinear only).

    The per-pixel work is compiled (:mod:`.texture_kernels`) with a hand-written backward;
    :func:`texture_python` is the plain-torch twin.
    """
    filter_mode, levels = _prepare(tex, uv, uv_da, mip_level_bias, mip, filter_mode, boundary_mode, max_mip_level)
    n_views, height, width = uv.shape[:3]
    mipmapped = filter_mode in ("linear-mipmap-nearest", "linear-mipmap-linear")
    pyramid = texture_pyramid(tex, max_mip_level) if levels is None else _as_pyramid(levels)
    out = _Texture.apply(
        pyramid.table,
        uv.reshape(-1, 2),
        uv_da.reshape(-1, 4) if mipmapped and uv_da is not None else None,
        mip_level_bias.reshape(-1) if mipmapped and mip_level_bias is not None else None,
        pyramid,
        tex.shape[0] > 1,
        height * width,
        FILTER_MODES[filter_mode],
        BOUNDARY_MODES[boundary_mode],
    )
    return out.reshape(n_views, height, width, -1)


def _as_pyramid(levels: list[torch.Tensor] | Pyramid) -> Pyramid:
    """The ``Pyramid`` of ``_prepare``'s levels (a given one as it is)."""
    return levels if isinstance(levels, Pyramid) else Pyramid.from_levels(levels)


def _prepare(tex, uv, uv_da, mip_level_bias, mip, filter_mode, boundary_mode, max_mip_level):
    """Validate the arguments of :func:`texture`; returns the concrete filter mode and the
    levels to sample: ``[tex]`` without mipmapping, ``[tex, *mip]`` with user mips, the given
    ``Pyramid``, or None when the mips are to be built from ``tex``."""
    if filter_mode != "auto" and filter_mode not in FILTER_MODES:
        raise ValueError(f"filter_mode must be 'auto' or one of {tuple(FILTER_MODES)}, got {filter_mode!r}")
    if boundary_mode not in BOUNDARY_MODES:
        raise ValueError(f"boundary_mode must be one of {tuple(BOUNDARY_MODES)}, got {boundary_mode!r}")
    if tex.dim() != 4:
        raise ValueError(f"tex must have shape [B, Ht, Wt, C], got {tuple(tex.shape)}")
    if uv.dim() != 4 or uv.shape[-1] != 2:
        raise ValueError(f"uv must have shape [B, H, W, 2], got {tuple(uv.shape)}")
    if tex.shape[0] not in (1, uv.shape[0]):
        raise ValueError(f"tex has {tex.shape[0]} views, uv has {uv.shape[0]}")
    if filter_mode == "auto":
        mipmapped = uv_da is not None or mip_level_bias is not None
        filter_mode = "linear-mipmap-linear" if mipmapped else "linear"
    if filter_mode in ("nearest", "linear"):
        return filter_mode, [tex]
    if uv_da is None and mip_level_bias is None:
        raise ValueError(f"filter_mode {filter_mode!r} needs uv_da or mip_level_bias")
    if mip is None:
        return filter_mode, None
    if isinstance(mip, Pyramid):
        if mip.table.shape[1] != tex.shape[3] or (int(mip.heights[0]), int(mip.widths[0])) != tuple(tex.shape[1:3]):
            raise ValueError(f"the mip pyramid is not one of a texture shaped like tex {tuple(tex.shape)}")
        return filter_mode, mip
    levels = [tex, *mip]
    return filter_mode, levels if max_mip_level is None else levels[: max_mip_level + 1]


def texture_python(
    tex: torch.Tensor,
    uv: torch.Tensor,
    uv_da: torch.Tensor | None = None,
    mip_level_bias: torch.Tensor | None = None,
    mip: list[torch.Tensor] | Pyramid | None = None,
    filter_mode: str = "auto",
    boundary_mode: str = "wrap",
    max_mip_level: int | None = None,
) -> torch.Tensor:
    """Plain-torch twin of :func:`texture` (same contract), the tests' oracle."""
    filter_mode, levels = _prepare(tex, uv, uv_da, mip_level_bias, mip, filter_mode, boundary_mode, max_mip_level)
    n_views, height, width = uv.shape[:3]
    flat_uv = uv.reshape(-1, 2)
    view = torch.arange(n_views, device=uv.device).repeat_interleave(height * width) if tex.shape[0] > 1 else None
    if levels is None:
        levels = [tex, *texture_construct_mip(tex, max_mip_level)]
    pyramid = _as_pyramid(levels)
    if filter_mode in ("nearest", "linear"):
        sample = sample_nearest if filter_mode == "nearest" else sample_bilinear
        out = sample(pyramid, None, view, flat_uv, boundary_mode)
        return out.reshape(n_views, height, width, -1)
    top = float(pyramid.heights.shape[0] - 1)
    level = uv.new_zeros(n_views * height * width)
    if uv_da is not None:
        level = level + footprint_level(uv_da.reshape(-1, 4), tex.shape[1], tex.shape[2])
    if mip_level_bias is not None:
        level = level + mip_level_bias.reshape(-1)
    level = level.clamp(0.0, top)
    if filter_mode == "linear-mipmap-nearest":
        nearest = torch.floor(level.detach() + 0.5).long()
        out = sample_bilinear(pyramid, nearest, view, flat_uv, boundary_mode)
        return out.reshape(n_views, height, width, -1)
    lower = torch.floor(level.detach()).clamp(max=max(top - 1.0, 0.0))
    frac = (level - lower)[:, None]
    lower = lower.long()
    fine = sample_bilinear(pyramid, lower, view, flat_uv, boundary_mode)
    if top == 0:
        return fine.reshape(n_views, height, width, -1)
    coarse = sample_bilinear(pyramid, lower + 1, view, flat_uv, boundary_mode)
    out = fine + frac * (coarse - fine)
    return out.reshape(n_views, height, width, -1)
