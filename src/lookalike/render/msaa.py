"""Stochastic MSAA: visibility at ``f x f`` samples per pixel, shading once per pixel.

:func:`covered_sample_index` picks the sample each pixel is shaded at (uniformly among its
covered samples), :func:`pick_samples` reads those samples of an image, and
:func:`upsample_over` composites the shaded pixels over the samples, each in one compiled pass
(:mod:`.msaa_kernels`; :mod:`.msaa_cuda` for tensors on the GPU) instead of the dozen
full-size torch operations (block reshapes, random priorities, argmax, gathers, scatters,
repeats, concatenations, lerp) that do the same; ``*_python`` are their plain-torch twins.
"""

from __future__ import annotations

import torch

from ..devices import launch, uses_cuda_kernels
from . import msaa_kernels


def covered_sample_index(ids: torch.Tensor, u: torch.Tensor, factor: int) -> torch.Tensor:
    """``[B, H, W]`` int64 flat indices into ``[B, H f, W f]`` of the sample each pixel is
    shaded at (no gradient).

    Args:
        ids: ``[B, H f, W f]`` triangle ids of the samples (``rast[..., 3]``; 0 = background).
        u: ``[B, H, W]`` uniform random numbers in [0, 1).
        factor: ``f``.
    Returns:
        Of the ``k`` covered samples of each pixel's ``f x f`` block (row-major order), number
        ``min(floor(u k), k - 1)``: uniform among them; where none is covered, sample
        ``min(floor(u f^2), f^2 - 1)`` of the block.
    """
    _check_blocks(ids.shape, u.shape, factor)
    out = torch.empty(u.shape, dtype=torch.int64, device=u.device)
    ids, u = ids.detach(), u.detach().contiguous()
    if uses_cuda_kernels(u):
        from . import msaa_cuda

        launch(msaa_cuda.covered_sample_index, u.numel(), ids, u, factor, out)
    else:
        msaa_kernels.covered_sample_index(ids.numpy(), u.numpy(), factor, out.numpy())
    return out


def covered_sample_index_python(ids: torch.Tensor, u: torch.Tensor, factor: int) -> torch.Tensor:
    """Plain-torch twin of :func:`covered_sample_index` (same contract), the tests' oracle."""
    _check_blocks(ids.shape, u.shape, factor)
    batch, height, width = u.shape
    blocks = ids.detach().reshape(batch, height, factor, width, factor).permute(0, 1, 3, 2, 4)
    covered = blocks.reshape(batch, height, width, factor * factor) > 0
    count = covered.sum(-1)
    none = count == 0
    pool = torch.where(none, factor * factor, count)
    target = torch.minimum(torch.floor(u * pool).long(), pool - 1)
    eligible = covered | none[..., None]
    rank = torch.cumsum(eligible.long(), -1) - 1
    slot = (eligible & (rank == target[..., None])).long().argmax(-1)
    row = torch.arange(height)[:, None] * factor + slot // factor
    col = torch.arange(width)[None, :] * factor + slot % factor
    return (torch.arange(batch)[:, None, None] * height * factor + row) * (width * factor) + col


class _PickSamples(torch.autograd.Function):
    """``(image [M, C], index [N])`` -> ``image[index]`` ``[N, C]``; the backward scatters with the
    compiled loop (the indices are distinct)."""

    @staticmethod
    def forward(ctx, image, index):
        ctx.save_for_backward(index)
        ctx.rows = image.shape[0]
        return image.index_select(0, index)

    @staticmethod
    def backward(ctx, grad):
        index, = ctx.saved_tensors
        grad_image = grad.new_zeros(ctx.rows, grad.shape[1])
        grad = grad.contiguous()
        if uses_cuda_kernels(grad):
            from . import msaa_cuda

            launch(msaa_cuda.scatter_rows, index.shape[0], grad, index, grad_image)
        else:
            msaa_kernels.scatter_rows(grad.numpy(), index.numpy(), grad_image.numpy())
        return grad_image, None


def pick_samples(image: torch.Tensor, index: torch.Tensor) -> torch.Tensor:
    """``[B, H, W, C]``: the sample of ``image [B, H f, W f, C]`` each pixel is shaded at, for
    ``index [B, H, W]`` from :func:`covered_sample_index`. Differentiable in ``image``."""
    batch, height, width = index.shape
    flat = _PickSamples.apply(image.reshape(-1, image.shape[-1]), index.reshape(-1))
    return flat.reshape(batch, height, width, image.shape[-1])


def pick_samples_python(image: torch.Tensor, index: torch.Tensor) -> torch.Tensor:
    """Plain-torch twin of :func:`pick_samples` (same contract), the tests' oracle."""
    return image.reshape(-1, image.shape[-1])[index.reshape(-1)].reshape(*index.shape, image.shape[-1])


class _UpsampleOver(torch.autograd.Function):
    """``(accum [B,Hf,Wf,4], colour [B,H,W,4], ids [B,Hf,Wf], factor)`` -> ``[B,Hf,Wf,4]``
    with the compiled kernels."""

    @staticmethod
    def forward(ctx, accum, colour, ids, factor):
        dtype = torch.promote_types(accum.dtype, colour.dtype)
        accum, colour = accum.detach().to(dtype).contiguous(), colour.detach().to(dtype).contiguous()
        ids = ids.detach()
        out = torch.empty_like(accum)
        if uses_cuda_kernels(accum):
            from . import msaa_cuda

            launch(msaa_cuda.upsample_over_forward, colour.shape[0] * colour.shape[1] * colour.shape[2], accum, colour,
                   ids, factor, out)
        else:
            msaa_kernels.upsample_over_forward(accum.numpy(), colour.numpy(), ids.numpy(), factor, out.numpy())
        ctx.save_for_backward(accum, colour, ids)
        ctx.factor = factor
        return out

    @staticmethod
    def backward(ctx, grad_out):
        accum, colour, ids = ctx.saved_tensors
        grad_accum, grad_colour = torch.empty_like(accum), torch.empty_like(colour)
        grad_out = grad_out.to(accum.dtype).contiguous()
        if uses_cuda_kernels(accum):
            from . import msaa_cuda

            launch(msaa_cuda.upsample_over_backward, colour.shape[0] * colour.shape[1] * colour.shape[2], accum, colour,
                   ids, ctx.factor, grad_out, grad_accum, grad_colour)
        else:
            msaa_kernels.upsample_over_backward(accum.numpy(), colour.numpy(), ids.numpy(), ctx.factor,
                                                grad_out.numpy(), grad_accum.numpy(), grad_colour.numpy())
        return grad_accum, grad_colour, None, None


def upsample_over(accum: torch.Tensor, colour: torch.Tensor, ids: torch.Tensor, factor: int) -> torch.Tensor:
    """Composite pixels shaded once each over their samples ("over" on straight alpha).

    Args:
        accum: ``[B, H f, W f, 4]`` what lies behind, per sample (opaque or empty).
        colour: ``[B, H, W, 4]`` straight-alpha colour of each pixel.
        ids: ``[B, H f, W f]`` triangle ids of the samples (0 = not covered by this layer).
        factor: ``f``.
    Returns:
        ``[B, H f, W f, 4]`` = ``lerp(accum, (rgb, 1), a)`` per sample, ``rgb`` and alpha from
        the sample's pixel and ``a`` = that alpha where the sample is covered, else 0.
        Differentiable in ``accum`` and ``colour``.
    """
    _check_blocks(ids.shape, colour.shape[:3], factor)
    if accum.shape != (*ids.shape, 4) or colour.shape[-1] != 4:
        raise ValueError(f"accum must be [B, H f, W f, 4] and colour [B, H, W, 4], got {tuple(accum.shape)} and {tuple(colour.shape)}")
    return _UpsampleOver.apply(accum, colour, ids, factor)


def upsample_over_python(accum: torch.Tensor, colour: torch.Tensor, ids: torch.Tensor, factor: int) -> torch.Tensor:
    """Plain-torch twin of :func:`upsample_over` (same contract), the tests' oracle."""
    _check_blocks(ids.shape, colour.shape[:3], factor)
    up = colour.repeat_interleave(factor, dim=1).repeat_interleave(factor, dim=2)
    alpha = up[..., 3:] * (ids[..., None] > 0).to(up.dtype)
    opaque = torch.cat([up[..., :3], torch.ones_like(up[..., 3:])], dim=-1)
    return torch.lerp(accum, opaque, alpha)


def _check_blocks(high_shape, low_shape, factor: int) -> None:
    batch, height, width = low_shape
    if tuple(high_shape) != (batch, height * factor, width * factor):
        raise ValueError(f"sample images {tuple(high_shape)} are not {factor}x{factor} blocks of pixels {tuple(low_shape)}")
