"""Depth peeling: successive layers of a scene, nearest first."""

from __future__ import annotations

import torch

from .context import RasterizeContext
from .rasterize import rasterize_layer


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
        self._active = False

    def __enter__(self) -> DepthPeeler:
        self._active = True
        self._min_depth = None
        return self

    def __exit__(self, *exc) -> None:
        self._active = False
        self._min_depth = None

    def rasterize_next_layer(self) -> tuple[torch.Tensor, torch.Tensor]:
        """``(rast [B,H,W,4], rast_db [B,H,W,4])`` of the next-nearest layer."""
        if not self._active:
            raise RuntimeError("DepthPeeler.rasterize_next_layer() must be called inside its 'with' block")
        rast, rast_db, depth = rasterize_layer(*self._args, self._min_depth)
        # pixels with no fragment left keep depth +inf, so they find nothing further
        self._min_depth = depth
        return rast, rast_db
