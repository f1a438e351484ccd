"""Depth peeling: successive layers of a scene, nearest first."""

from __future__ import annotations

import torch

from .context import RasterizeContext
from .rasterize import rasterize_layer
from .window import Window


class DepthPeeler:
    """nvdiffrast's ``DepthPeeler``: a context manager whose :meth:`rasterize_next_layer`
    returns, per pixel, the nearest fragment strictly behind the previous layer's.

    Usage::

        with dr.DepthPeeler(ctx, pos, tri, (H, W)) as peeler:
            for _ in range(8):
                rast, rast_db = peeler.rasterize_next_layer()

    The first call equals :func:`lookalike.render.rasterize`.  The previous layer's depth
    is kept as the exact float32 z/w the visibility kernel computed, so the strict
    comparison never re-finds the same fragment.  Once a pixel runs out of fragments it
    stays background (``rast == 0``).  Arguments as for ``rasterize``.

    :meth:`rasterize_next_window` (an extension of nvdiffrast's) returns each layer only
    within the window that holds its fragments, and draws the next one only within that
    window (a pixel with no fragment in a layer has none deeper): the cost of a deep layer
    of foliage follows the few pixels it covers, not the frame.
    """

    def __init__(
        self,
        glctx: RasterizeContext | None,
        pos: torch.Tensor,
        tri: torch.Tensor,
        resolution: tuple[int, int],
        ranges: torch.Tensor | None = None,
        grad_db: bool = True,
    ):
        self._args = (pos, tri, resolution, ranges, grad_db)
        self._min_depth: torch.Tensor | None = None
        self._window: Window | None = None
        self._active = False

    def __enter__(self) -> DepthPeeler:
        self._active = True
        self._min_depth = None
        self._window = None
        return self

    def __exit__(self, *exc) -> None:
        self._active = False
        self._min_depth = None
        self._window = None

    def rasterize_next_layer(self) -> tuple[torch.Tensor, torch.Tensor]:
        """``(rast [B,H,W,4], rast_db [B,H,W,4])`` of the next-nearest layer."""
        self._check_active()
        rast, rast_db, depth, _ = rasterize_layer(*self._args, self._min_depth)
        # pixels with no fragment left keep depth +inf, so they find nothing further
        self._min_depth = depth
        return rast, rast_db

    def rasterize_next_window(self, block: int = 1) -> tuple[Window | None, torch.Tensor, torch.Tensor]:
        """``(window, rast [B,h,w,4], rast_db [B,h,w,4])``: the next-nearest layer within
        ``window``, ``covered_window(ids, block)`` of the frame's ids (``None``, with empty
        images, once no fragment is left); equal to that window of
        :meth:`rasterize_next_layer`'s images."""
        self._check_active()
        rast, rast_db, depth, window = rasterize_layer(*self._args, self._min_depth, self._window, block)
        self._min_depth = depth
        self._window = window
        return window, rast, rast_db

    def _check_active(self) -> None:
        if not self._active:
            raise RuntimeError("DepthPeeler layers must be rasterized inside its 'with' block")
