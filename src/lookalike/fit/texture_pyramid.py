"""A trainable texture held as a sum of resolution levels, so that what the views do not pin
down stays smooth.

Why: Adam normalises each parameter's step, so a texel the training views reach rarely or at
grazing angles moves as far per step as a well-observed one, on a few noisy gradients: the
maps grow a fine grain that the reference does not have. Held as levels

    T = s_0 P_0 + up(s_1 P_1 + up(s_2 P_2 + ... up(s_{K-1} P_{K-1}))),

with ``P_k [ceil(H / 2^k), ceil(W / 2^k), C]`` the trainable tensors and ``up`` bilinear
upsampling to the next finer level's size (texel centres aligned), a coarse texel's gradient
sums the gradients of the ``4^k`` fine texels under it, so its normalised step follows their
consensus; the finest level, whose step is scaled by ``s_0 < 1``, adds only the detail the
views keep asking for. Adam moves ``P_k`` by about ``lr`` per step, hence level ``k`` of ``T``
by ``s_k lr``: the scales are per-level learning rates.

The texture starts exactly as given: ``P_0 = T_0 / s_0`` and the coarser levels at zero.

The sum and its backward (``g_{P_k} = s_k up^T(... up^T(g_T))``) are compiled
(:mod:`.pyramid_kernels`; :mod:`.pyramid_cuda` for levels on the GPU) on the levels' own ``[h,
w, C]`` layout; :func:`compose_python` is the ``F.interpolate`` twin the tests compare them
with.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F

from ..devices import uses_cuda_kernels
from . import pyramid_kernels as kernels


def level_sizes(height: int, width: int, levels: int) -> list[tuple[int, int]]:
    """``[(ceil(H / 2^k), ceil(W / 2^k)) for k < levels]``, stopping before a side would fall
    below 2 texels (so a small texture gets fewer levels)."""
    sizes = [(height, width)]
    while len(sizes) < levels and min(sizes[-1]) >= 4:
        h, w = sizes[-1]
        sizes.append(((h + 1) // 2, (w + 1) // 2))
    return sizes


def upsample(level: torch.Tensor, size: tuple[int, int]) -> torch.Tensor:
    """Bilinear upsampling of ``level [h, w, C]`` to ``[size[0], size[1], C]`` with texel
    centres aligned (``align_corners=False``), edges clamped."""
    image = level.permute(2, 0, 1).unsqueeze(0)
    return F.interpolate(image, size=size, mode="bilinear", align_corners=False)[0].permute(1, 2, 0)


def compose_python(levels: list[torch.Tensor], scales: tuple[float, ...], low=None, high=None) -> torch.Tensor:
    """The plain-torch twin of ``compose`` (same contract), with ``upsample``."""
    total = scales[-1] * levels[-1]
    for k in range(len(levels) - 2, -1, -1):
        total = scales[k] * levels[k] + upsample(total, levels[k].shape[:2])
    if low is None and high is None:
        return total
    low, high = (torch.as_tensor(default if b is None else b, dtype=total.dtype)
                 for b, default in ((low, -math.inf), (high, math.inf)))
    with torch.no_grad():
        excess = total.clamp(low, high) - total
        levels[0].add_(excess / scales[0])
    return total + excess


def compose(levels: list[torch.Tensor], scales: tuple[float, ...], low=None, high=None) -> torch.Tensor:
    """``[H, W, C]`` (contiguous) ``T = s_0 P_0 + up(s_1 P_1 + up(...))`` of ``levels [h_k,
    w_k, C]`` projected onto ``[low, high]`` (scalars, ``[C]`` tensors or ``None``):
    the excess is taken off the finest level in place (``P_0 += (clamp(T) - T) / s_0``) and
    the gradient reaches every level as that of the unprojected sum (the projection is a
    constant offset).  Compiled in one pass per level (:mod:`.pyramid_kernels`)."""
    if len(scales) != len(levels):
        raise ValueError(f"{len(levels)} levels need as many scales, got {len(scales)}")
    channels = levels[0].shape[-1]
    bounds = [torch.as_tensor(default if b is None else b, dtype=torch.float32).expand(channels).contiguous()
              for b, default in ((low, -math.inf), (high, math.inf))]
    return _Compose.apply(tuple(scales), *bounds, *levels)


class _Compose(torch.autograd.Function):
    """``(scales, low [C], high [C], *levels)`` -> ``[H, W, C]``; the backward gives level ``k``
    the gradient ``s_k G_k`` with ``G_0`` the output's and ``G_{k+1} = up^T(G_k)``."""

    @staticmethod
    def forward(ctx, scales, low, high, *levels):
        arrays = [level.detach().contiguous() for level in levels]
        if len(arrays) == 1:
            arrays.append(arrays[0].new_zeros(1, 1, arrays[0].shape[-1]))  # upsampling zero adds nothing
            scales = (*scales, 0.0)
        no_bound = torch.full_like(low, math.inf)
        total = scales[-1] * arrays[-1]
        for k in range(len(arrays) - 2, -1, -1):
            finer = torch.empty_like(arrays[k])
            bounds = (low, high) if k == 0 else (-no_bound, no_bound)
            if uses_cuda_kernels(finer):
                from . import pyramid_cuda

                pyramid_cuda.upsample_add(total, arrays[k], scales[k], *bounds, finer)
            else:
                kernels.upsample_add(total.numpy(), arrays[k].numpy(), scales[k], *(b.numpy() for b in bounds),
                                     finer.numpy())
            total = finer
        ctx.scales, ctx.sizes = scales, [tuple(level.shape[:2]) for level in levels]
        return total

    @staticmethod
    def backward(ctx, grad):
        grads = [ctx.scales[0] * grad]
        spread = grad.contiguous()
        for (height, width), scale in zip(ctx.sizes[1:], ctx.scales[1:]):
            if uses_cuda_kernels(spread):
                from . import pyramid_cuda

                spread = pyramid_cuda.upsample_adjoint(spread, height, width)
            else:
                spread = torch.from_numpy(kernels.upsample_adjoint(spread.numpy(), height, width))
            grads.append(scale * spread)
        return (None, None, None, *grads)


class TexturePyramid(torch.nn.Module):
    """A trainable ``[H, W, C]`` texture as in the module docstring, kept within bounds.

    Reading it (calling the module) projects ``T`` onto ``[low, high]`` and writes the
    projection back: the excess of each texel is taken off the finest level, so the other
    levels keep their values. Projecting where the texture is read, rather than after each
    update, sums the pyramid once per optimisation step instead of twice; the texture anyone
    reads is the projected one either way. The sum and the projection are one compiled pass
    per level (``compose``), because ``F.interpolate`` and torch's clamp make several full
    passes over every level each way.

    Args:
        texture: ``[H, W, C]`` initial texels.
        scales: ``s_k`` per level, finest first; ``len(scales)`` levels at most (fewer on a
            small texture, see ``level_sizes``: its coarsest level then takes the scales of the
            levels it lacks, so the steps still add up alike). One scale ``(1.0,)`` is a plain
            texture.
        low, high: the bounds (scalars or ``[C]`` tensors; ``None``: unbounded).
    """

    def __init__(self, texture: torch.Tensor, scales: tuple[float, ...], low=None, high=None):
        super().__init__()
        height, width, channels = texture.shape
        sizes = level_sizes(height, width, len(scales))
        kept = len(sizes) - 1
        self.scales = tuple(float(s) for s in scales[:kept]) + (float(sum(scales[kept:])),)
        self.levels = torch.nn.ParameterList(
            [torch.nn.Parameter(texture.float().clone() / self.scales[0])]
            + [torch.nn.Parameter(texture.new_zeros(h, w, channels, dtype=torch.float32)) for h, w in sizes[1:]])
        self.set_bounds(low, high)

    def set_bounds(self, low=None, high=None) -> None:
        """Bound the texture to ``[low, high]`` from its next read on."""
        self.low = None if low is None else torch.as_tensor(low, dtype=torch.float32)
        self.high = None if high is None else torch.as_tensor(high, dtype=torch.float32)

    @property
    def shape(self) -> torch.Size:
        return self.levels[0].shape

    def forward(self) -> torch.Tensor:
        """``[H, W, C]`` the texture ``T`` projected onto the bounds (differentiable in every
        level; the projection is a constant offset)."""
        return compose(list(self.levels), self.scales, self.low, self.high)
