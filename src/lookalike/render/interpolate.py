"""``interpolate``: vertex attributes at pixels, with their screen-space derivatives.  The
per-pixel loops are compiled (:mod:`.interpolate_kernels`) with a hand-written backward;
:func:`interpolate_python` is the plain-torch twin."""

from __future__ import annotations

import numba
import torch

from ..devices import launch, uses_cuda_kernels
from . import interpolate_kernels
from .inputs import check_rast_ids, check_triangles
from .pixels import covered_pixels, scatter_to_image


class _Interpolate(torch.autograd.Function):
    """``(attr [Ba,V,C], rast [B,H,W,4], rast_db or None, tri [T,3] int64, channels [D] int64,
    pixels [N] int64 or None)`` -> ``(out [N, C], out_da [N, 2D])`` at the listed pixels (every
    pixel, ``N = B H W``, for None) with the compiled kernels, or their CUDA forms for tensors on
    the GPU."""

    @staticmethod
    def forward(ctx, attr, rast, rast_db, tri, channels, pixels):
        n_views, height, width = rast.shape[:3]
        dtype = torch.promote_types(attr.dtype, rast.dtype)
        attr, rast = attr.detach().to(dtype).contiguous(), rast.detach().to(dtype).contiguous()
        db = rast if rast_db is None else rast_db.detach().to(dtype).contiguous()
        every = pixels is None
        pixels = tri.new_empty(0) if every else pixels.contiguous()
        count = n_views * height * width if every else pixels.shape[0]
        out = attr.new_empty(count, attr.shape[2])
        out_da = attr.new_empty(count, 2 * channels.shape[0])
        arrays = (attr, tri, rast.reshape(-1, 4), db.reshape(-1, 4), channels, pixels)
        if uses_cuda_kernels(attr):
            from . import interpolate_cuda

            launch(interpolate_cuda.interpolate_forward, count, *arrays, every, height * width, out, out_da)
        else:
            interpolate_kernels.interpolate_forward(*(a.numpy() for a in arrays), every, height * width, out.numpy(),
                                                    out_da.numpy())
        ctx.save_for_backward(attr, rast, db, tri, channels, pixels)
        ctx.has_db, ctx.every = rast_db is not None, every
        return out, out_da

    @staticmethod
    def backward(ctx, grad_out, grad_da):
        attr, rast, db, tri, channels, pixels = ctx.saved_tensors
        count = rast.shape[0] * rast.shape[1] * rast.shape[2] if ctx.every else pixels.shape[0]
        grad_out = attr.new_zeros(count, attr.shape[2]) if grad_out is None else grad_out
        if grad_da is None or channels.numel() == 0:
            grad_da, channels = grad_out[:, :0], channels[:0]
        grad_attr = torch.zeros_like(attr)
        grad_rast = torch.zeros_like(rast)
        grad_db = torch.zeros_like(rast) if ctx.has_db else rast.new_empty(0, 4)
        arrays = (attr, tri, rast.reshape(-1, 4), db.reshape(-1, 4), channels, pixels)
        grads = (grad_out.to(attr.dtype).contiguous(), grad_da.to(attr.dtype).contiguous(), grad_attr,
                 grad_rast.reshape(-1, 4), grad_db.reshape(-1, 4))
        if uses_cuda_kernels(attr):
            from . import interpolate_cuda

            launch(interpolate_cuda.interpolate_backward, count, *arrays, ctx.every, rast.shape[1] * rast.shape[2],
                   *grads)
        else:
            interpolate_kernels.interpolate_backward(*(a.numpy() for a in arrays), ctx.every,
                                                     rast.shape[1] * rast.shape[2], *(g.numpy() for g in grads),
                                                     numba.get_num_threads())
        return grad_attr, grad_rast, grad_db if ctx.has_db else None, None, None, None


def interpolate(
    attr: torch.Tensor,
    rast: torch.Tensor,
    tri: torch.Tensor,
    rast_db: torch.Tensor | None = None,
    diff_attrs: str | list[int] | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Interpolate per-vertex attributes (nvdiffrast's ``dr.interpolate``).

    Args:
        attr: ``[B, V, C]`` (one set per view), ``[1, V, C]`` or ``[V, C]`` (shared).
        rast: ``[B, H, W, 4]`` output of :func:`rasterize`.
        tri: ``[T, 3]`` int32/int64, the triangles given to ``rasterize`` (its own
            attribute index buffer may differ, e.g. UV seams, as long as ``T`` agrees).
        rast_db: ``[B, H, W, 4]`` derivatives from ``rasterize``; needed with ``diff_attrs``.
        diff_attrs: ``"all"`` or a list of channel indices whose derivatives to return.

    Returns:
        ``out [B, H, W, C] = u a_0 + v a_1 + (1 - u - v) a_2`` with ``a_k`` the attribute of
        vertex ``k`` of the pixel's triangle, zero on background; and ``out_da [B, H, W, 2D]``
        = ``(dA/dX, dA/dY)`` in pixel units for each of the ``D`` selected channels in order
        (``dA/dX = (a_0 - a_2) du/dX + (a_1 - a_2) dv/dX``), or ``[B, H, W, 0]`` when
        ``diff_attrs`` is None.  Gradients flow to ``attr``, ``rast[..., 0:2]`` and ``rast_db``.

    The per-pixel loops are compiled (:mod:`.interpolate_kernels`) with a hand-written backward;
    :func:`interpolate_python` is the plain-torch twin.
    """
    out, out_da = interpolate_at(attr, rast, tri, None, rast_db, diff_attrs)
    return out.reshape(*rast.shape[:3], -1), out_da.reshape(*rast.shape[:3], -1)


def interpolate_at(
    attr: torch.Tensor,
    rast: torch.Tensor,
    tri: torch.Tensor,
    pixels: torch.Tensor | None,
    rast_db: torch.Tensor | None = None,
    diff_attrs: str | list[int] | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """:func:`interpolate` at a list of pixels only, e.g. the covered ones of a G-buffer: the
    images are never written.

    Args:
        pixels: ``[N]`` int64 distinct flat indices into ``[B, H, W]``, or None for every pixel.
        attr, rast, tri, rast_db, diff_attrs: as :func:`interpolate`.

    Returns:
        ``(out [N, C], out_da [N, 2D])``: rows ``pixels`` of ``interpolate``'s images flattened
        to ``[B H W, C]`` and ``[B H W, 2D]``, with the same gradients.
    """
    attr, channels = _check_inputs(attr, rast, rast_db, diff_attrs)
    tri = check_triangles(tri, attr.shape[1])
    check_rast_ids(rast, tri.shape[0])
    if pixels is not None:
        pixels = pixels.long()
        if pixels.numel():
            low, high = torch.aminmax(pixels)  # one pass, not two
            if low < 0 or high >= rast.shape[0] * rast.shape[1] * rast.shape[2]:
                raise ValueError(f"pixels index outside the {tuple(rast.shape[:3])} images")
    return _Interpolate.apply(
        attr, rast, rast_db if channels else None, tri.contiguous(),
        torch.tensor(channels, dtype=torch.int64, device=attr.device), pixels
    )


def interpolate_python(
    attr: torch.Tensor,
    rast: torch.Tensor,
    tri: torch.Tensor,
    rast_db: torch.Tensor | None = None,
    diff_attrs: str | list[int] | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Plain-torch twin of :func:`interpolate` (same contract), the tests' oracle."""
    attr, channels = _check_inputs(attr, rast, rast_db, diff_attrs)
    n_views, height, width = rast.shape[:3]
    n_attr_views, n_verts, n_channels = attr.shape
    tri = tri.long()
    flat_pixel, tri_idx = covered_pixels(rast)
    view = flat_pixel // (height * width)
    vertex = tri.index_select(0, tri_idx)  # [N, 3]
    if n_attr_views > 1:
        vertex = vertex + (view * n_verts)[:, None]
    a = attr.reshape(-1, n_channels).index_select(0, vertex.reshape(-1)).reshape(-1, 3, n_channels)
    uv = rast.reshape(-1, 4)[:, :2].index_select(0, flat_pixel)
    da_du = a[:, 0] - a[:, 2]
    da_dv = a[:, 1] - a[:, 2]
    out = a[:, 2] + uv[:, :1] * da_du + uv[:, 1:] * da_dv
    image_shape = (n_views, height, width)
    out_image = scatter_to_image(out, flat_pixel, image_shape)
    if not channels:
        return out_image, out_image.new_zeros(*image_shape, 0)
    db = rast_db.reshape(-1, 4).index_select(0, flat_pixel)  # du/dX, du/dY, dv/dX, dv/dY
    du, dv = da_du[:, channels], da_dv[:, channels]
    d_dx = du * db[:, 0:1] + dv * db[:, 2:3]
    d_dy = du * db[:, 1:2] + dv * db[:, 3:4]
    out_da = torch.stack([d_dx, d_dy], -1).reshape(-1, 2 * len(channels))
    return out_image, scatter_to_image(out_da, flat_pixel, image_shape)


def _check_inputs(attr, rast, rast_db, diff_attrs) -> tuple[torch.Tensor, list[int]]:
    """Validate the arguments of :func:`interpolate`; returns ``attr`` as ``[Ba, V, C]``
    and the list of differentiated channels (empty for None)."""
    if attr.dim() == 2:
        attr = attr[None]
    if attr.dim() != 3:
        raise ValueError(f"attr must have shape [B, V, C] or [V, C], got {tuple(attr.shape)}")
    if rast.dim() != 4 or rast.shape[-1] != 4:
        raise ValueError(f"rast must have shape [B, H, W, 4], got {tuple(rast.shape)}")
    n_views = rast.shape[0]
    if attr.shape[0] not in (1, n_views):
        raise ValueError(f"attr has {attr.shape[0]} views, rast has {n_views}")
    if diff_attrs is None:
        return attr, []
    if rast_db is None:
        raise ValueError("diff_attrs needs rast_db")
    n_channels = attr.shape[2]
    channels = list(range(n_channels)) if diff_attrs == "all" else [int(c) for c in diff_attrs]
    if any(c < 0 or c >= n_channels for c in channels):
        raise ValueError(f"diff_attrs {diff_attrs} names channels outside 0..{n_channels - 1}")
    return attr, channels
