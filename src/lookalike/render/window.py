"""Windows: the block of an image where a depth-peeled layer has fragments, so that the work
done per layer (shading, compositing, antialiasing and their backward passes) costs the area
that layer covers rather than the whole frame's."""

from __future__ import annotations

from dataclasses import dataclass

import torch


@dataclass(frozen=True)
class Window:
    """Rows ``top .. top + height - 1`` and columns ``left .. left + width - 1`` of a
    ``frame_height x frame_width`` image (rasterizer row order)."""

    top: int
    left: int
    height: int
    width: int
    frame_height: int
    frame_width: int

    @staticmethod
    def whole(height: int, width: int) -> Window:
        """The window that is the whole ``height x width`` frame."""
        return Window(0, 0, height, width, height, width)

    def crop(self, image: torch.Tensor, within: Window | None = None) -> torch.Tensor:
        """``[B, height, width, ...]``: this window of ``image [B, h, w, ...]``, which is the
        window ``within`` of the frame (``None``: the whole frame); a view, not a copy."""
        top, left = self._offset(within)
        return image[:, top:top + self.height, left:left + self.width]

    def paste(self, image: torch.Tensor, onto: torch.Tensor, within: Window | None = None) -> torch.Tensor:
        """A copy of ``onto [B, h, w, C]`` (the window ``within`` of the frame, ``None``: the
        whole frame) with this window replaced by ``image [B, height, width, C]``;
        differentiable in both."""
        top, left = self._offset(within)
        out = onto.clone()
        out[:, top:top + self.height, left:left + self.width] = image
        return out

    def coarse(self, factor: int) -> Window:
        """The same window in the frame ``factor`` times smaller per axis (this window's bounds
        and frame must be multiples of ``factor``)."""
        return Window(self.top // factor, self.left // factor, self.height // factor, self.width // factor,
                      self.frame_height // factor, self.frame_width // factor)

    def _offset(self, within: Window | None) -> tuple[int, int]:
        if within is None:
            return self.top, self.left
        return self.top - within.top, self.left - within.left


def covered_window(ids: torch.Tensor, block: int) -> Window | None:
    """The smallest window of ``ids [B, H, W]`` (triangle ids, 0 = none; ``H``, ``W`` multiples
    of ``block``) that holds every covered pixel of every view with a margin of at least one
    pixel, its bounds on multiples of ``block``; ``None`` where nothing is covered.

    The margin keeps inside the window every pixel pair that antialiasing blends (a pair
    involves a covered pixel), so antialiasing the window equals antialiasing the frame;
    the block alignment keeps whole ``block x block`` pixels of stochastic MSAA inside it."""
    covered = ids.detach() > 0
    rows = torch.nonzero(covered.any(dim=2).any(dim=0)).reshape(-1)
    if rows.numel() == 0:
        return None
    cols = torch.nonzero(covered.any(dim=1).any(dim=0)).reshape(-1)
    frame_height, frame_width = ids.shape[1], ids.shape[2]
    top, bottom = _block_span(int(rows[0]), int(rows[-1]), block, frame_height)
    left, right = _block_span(int(cols[0]), int(cols[-1]), block, frame_width)
    return Window(top, left, bottom - top, right - left, frame_height, frame_width)


def _block_span(first: int, last: int, block: int, size: int) -> tuple[int, int]:
    """``(start, stop)``: ``first - 1 .. last + 1`` widened to multiples of ``block``, within
    ``0 .. size``."""
    start = max(first - 1, 0) // block * block
    stop = min(-(-(last + 2) // block) * block, size)
    return start, stop
