"""Mip levels of a trainable texture that are latent variables of their own (prefiltering,
paper Sec. 5.2): what a texture should look like when a pixel covers 2^m of its texels is
fitted to the views that see it that small, rather than taken as the box filter of the level
above.

Held as residuals over the box filter: level ``m`` is

    L_m = clamp(box(L_{m-1}) + R_m),    L_0 = T (the texture itself),

with ``box`` the 2 x 2 area average (``render.mipmap.texture_construct_mip``'s filter) and
``R_m [h_m, w_m, C]`` a ``TexturePyramid`` starting at zero. Why residuals: a level no view
reaches gets no gradient, so its residual stays zero and the level stays exactly the box
filter of the level above (never noise); a level the views do reach still follows the
texture above it as that changes, and adds only what its own views ask for. Why pyramids: the
residual keeps the texture's smoothness for what its views do not pin down
(``fit.texture_pyramid``).
"""

from __future__ import annotations

import torch
import torch.nn.functional as F

from ..render.mipmap import mip_sizes
from .texture_pyramid import TexturePyramid


def box_down(level: torch.Tensor, size: tuple[int, int]) -> torch.Tensor:
    """``level [h, w, C]`` area-averaged to ``[size[0], size[1], C]`` (the mip filter)."""
    image = level.permute(2, 0, 1).unsqueeze(0)
    return F.interpolate(image, size=size, mode="area")[0].permute(1, 2, 0)


class FittedMips(torch.nn.Module):
    """Levels ``1 ..`` of a ``[H, W, C]`` texture as in the module docstring.

    Args:
        height, width, channels: the texture's shape.
        scales: the residual pyramids' step scales (``TexturePyramid``).
        low, high: bounds every level is clamped to (scalars or ``[C]`` tensors; ``None``: none).
    """

    def __init__(self, height: int, width: int, channels: int, scales: tuple[float, ...], low=None, high=None):
        super().__init__()
        self.residuals = torch.nn.ModuleList(
            [TexturePyramid(torch.zeros(h, w, channels), scales) for h, w in mip_sizes(height, width)])
        self.set_bounds(low, high)

    def set_bounds(self, low=None, high=None) -> None:
        """Clamp every level to ``[low, high]`` from the next call on."""
        self.low = None if low is None else torch.as_tensor(low, dtype=torch.float32)
        self.high = None if high is None else torch.as_tensor(high, dtype=torch.float32)

    def forward(self, texture: torch.Tensor) -> list[torch.Tensor]:
        """``[L_1, L_2, ...]``, each ``[h_m, w_m, C]``, of ``texture [H, W, C]`` (differentiable
        in the texture and every residual)."""
        levels, level = [], texture
        for residual in self.residuals:
            level = box_down(level, residual.shape[:2]) + residual()
            if self.low is not None or self.high is not None:
                level = torch.clamp(level, self.low, self.high)
            levels.append(level)
        return levels
