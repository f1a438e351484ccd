"""Depth peeling: successive layers of a scene, nearest first."""

from __future__ import annotations

import torch

from .context import RasterizeContext
from .rasterize import layer_images, rasterize_layer, rasterize_layers
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

    ``layers`` (another extension): the most layers the caller will take. The first call then
    finds them all in one pass over the triangles (a k-buffer,
    :func:`.visibility.visible_layers`) and each call reads its own, bit for bit the layer a
    pass of its own finds, at about the cost of one pass; calls beyond ``layers`` peel on.
    """

    def __init__(
        self,
        glctx: RasterizeContext | None,
        pos: torch.Tensor,
        tri: torch.Tensor,
        resolution: tuple[int, int],
        ranges: torch.Tensor | None = None,
        grad_db: bool = True,
        layers: int | None = None,
    ):
        self._args = (pos, tri, resolution, ranges, grad_db)
        self._layers = layers
        self._found: tuple[torch.Tensor, torch.Tensor] | None = None
        self._taken = 0
        self._min_depth: torch.Tensor | None = None
        self._window: Window | None = None
        self._active = False

    def __enter__(self) -> DepthPeeler:
        self._active = True
        self._min_depth = None
        self._window = None
        self._found = None
        self._taken = 0
        return self

    def __exit__(self, *exc) -> None:
        self._active = False
        self._min_depth = None
        self._window = None
        self._found = None

    def rasterize_next_layer(self) -> tuple[torch.Tensor, torch.Tensor]:
        """``(rast [B,H,W,4], rast_db [B,H,W,4])`` of the next-nearest layer."""
        _, rast, rast_db = self._next(None)
        return rast, rast_db

    def rasterize_next_window(self, block: int = 1) -> tuple[Window | None, torch.Tensor, torch.Tensor]:
        """``(window, rast [B,h,w,4], rast_db [B,h,w,4])``: the next-nearest layer within
        ``window``, ``covered_window(ids, block)`` of the frame's ids (``None``, with empty
        images, once no fragment is left); equal to that window of
        :meth:`rasterize_next_layer`'s images."""
        return self._next(block)

    def _next(self, block: int | None) -> tuple[Window | None, torch.Tensor, torch.Tensor]:
        self._check_active()
        pos, tri, resolution, ranges, grad_db = self._args
        if self._layers is not None and self._taken < self._layers:
            if self._found is None:
                self._found = rasterize_layers(pos, tri, resolution, ranges, self._layers)
            tri_id, depth = self._found[0][self._taken], self._found[1][self._taken]
            rast, rast_db, window = layer_images(pos, tri, ranges, grad_db, tri_id, depth, block)
        else:
            rast, rast_db, depth, window = rasterize_layer(*self._args, self._min_depth, self._window, block)
        # pixels with no fragment left keep depth +inf, so they find nothing further
        self._min_depth = depth
        self._window = window
        self._taken += 1
        return window, rast, rast_db

    def _check_active(self) -> None:
        if not self._active:
            raise RuntimeError("DepthPeeler layers must be rasterized inside its 'with' block")
