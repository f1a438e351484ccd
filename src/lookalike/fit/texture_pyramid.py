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
"""

from __future__ import annotations

import torch
import torch.nn.functional as F


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


class TexturePyramid(torch.nn.Module):
    """A trainable ``[H, W, C]`` texture as in the module docstring, kept within bounds.

    Reading it (calling the module) projects ``T`` onto ``[low, high]`` and writes the
    projection back: the excess of each texel is taken off the finest level, so the other
    levels keep their values. Projecting where the texture is read, rather than after each
    update, sums the pyramid once per optimisation step instead of twice (a 6-level 1024^2 x 4
    sum is 10-13 ms, the projection of a texture already within bounds 2 ms); the texture
    anyone reads is the projected one either way.

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
        level; the projection is a constant offset), a view of a contiguous ``[1, C, H, W]``
        image: bilinear upsampling runs 4-10x faster on that layout than on the levels' own
        (``upsample``, 1024^2 x 4: 5 against 52 ms)."""
        total = None
        for level, scale in zip(reversed(self.levels), reversed(self.scales)):
            term = (scale * level).permute(2, 0, 1).unsqueeze(0)
            if total is None:
                total = term.contiguous()
            else:
                total = F.interpolate(total, size=term.shape[-2:], mode="bilinear", align_corners=False) + term
        texture = total.squeeze(0).permute(1, 2, 0)  # a view: indexing [0] would copy in the backward
        if self.low is None and self.high is None:
            return texture
        with torch.no_grad():
            excess = texture.clamp(self.low, self.high) - texture
            self.levels[0].add_(excess / self.scales[0])
        return texture + excess
