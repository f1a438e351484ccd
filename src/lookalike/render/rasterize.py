"""``rasterize``: nvdiffrast's rasterization primitive on the CPU: the compiled visibility
kernel (:mod:`.visibility`) finds each pixel's triangle, then the compiled barycentrics
(:mod:`.barycentrics`) give ``rast`` and ``rast_db`` with gradients to the positions."""

from __future__ import annotations

import torch

from ..devices import uses_cuda_kernels
from .barycentrics import pixel_barycentrics
from .context import RasterizeContext
from .inputs import check_triangles, per_view_positions
from .visibility import visible_layers
from .window import Window, covered_window


def rasterize(
    glctx: RasterizeContext | None,
    pos: torch.Tensor,
    tri: torch.Tensor,
    resolution: tuple[int, int],
    ranges: torch.Tensor | None = None,
    grad_db: bool = True,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Rasterize triangles into ``B`` images (nvdiffrast's ``dr.rasterize``).

    Args:
        glctx: a :class:`RasterizeContext` or None (ignored).
        pos: ``[B, V, 4]`` clip-space positions (instanced mode), or ``[V, 4]`` with
            ``ranges`` (range mode).  float32 or float64.
        tri: ``[T, 3]`` int32 or int64 vertex indices.
        resolution: ``(H, W)`` in pixels.
        ranges: ``[B, 2]`` int ``(first triangle, count)`` per view, range mode only.
        grad_db: when False, no gradient flows through ``rast_db`` (values still returned).

    Returns:
        ``rast [B, H, W, 4]``: ``(u, v, z/w, triangle_id + 1)`` per pixel, all zero where no
        triangle covers the pixel centre.  ``u``, ``v`` are the perspective-correct
        barycentric weights of vertices 0 and 1 (vertex 2 gets ``1 - u - v``); the id is
        a float holding the (global) triangle index + 1.  ``rast_db [B, H, W, 4]``:
        ``(du/dX, du/dY, dv/dX, dv/dY)`` in pixel units (zero on background).

    Conventions (nvdiffrast's): pixel ``(ix, iy)`` samples NDC ``((2 ix + 1)/W - 1,
    (2 iy + 1)/H - 1)``; row 0 of the image is ``y = -1`` (OpenGL order: displayed images
    must be flipped vertically).  Only points with ``w > 0`` and ``-1 <= z/w <= 1`` are
    drawn (near- and far-plane clipping per pixel), both faces are drawn, the nearest
    depth wins (lower triangle index on ties).  Gradients of ``u, v`` and ``rast_db`` flow
    to ``x, y, w`` of ``pos``; depth and id carry no gradient.
    """
    rast, rast_db, _, _ = rasterize_layer(pos, tri, resolution, ranges, grad_db, None)
    return rast, rast_db


def rasterize_layer(
    pos: torch.Tensor,
    tri: torch.Tensor,
    resolution: tuple[int, int],
    ranges: torch.Tensor | None,
    grad_db: bool,
    min_depth: torch.Tensor | None,
    within: Window | None = None,
    block: int | None = None,
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, Window | None]:
    """:func:`rasterize` keeping only fragments deeper than ``min_depth [B,H,W] float32``
    (None: no limit) and drawing only the pixels of the window ``within`` (None: all; outside
    it ``min_depth`` must be ``+inf``).

    Returns ``(rast, rast_db, depth, window)``: ``depth [B,H,W] float32`` is the layer's
    (+inf = none), bit-exact, to pass as the next layer's ``min_depth``. With ``block``,
    ``window`` is ``covered_window(ids, block)`` (``None`` where nothing is covered, with
    ``rast`` and ``rast_db`` then ``[B, 0, 0, 4]``) and ``rast``, ``rast_db`` are that window
    of the frame's, computed there only; without, the whole frame's."""
    tri_id, depth = rasterize_layers(pos, tri, resolution, ranges, 1, min_depth, within)
    rast, rast_db, window = layer_images(pos, tri, ranges, grad_db, tri_id[0], depth[0], block)
    return rast, rast_db, depth[0], window


def rasterize_layers(
    pos: torch.Tensor,
    tri: torch.Tensor,
    resolution: tuple[int, int],
    ranges: torch.Tensor | None,
    layers: int,
    min_depth: torch.Tensor | None = None,
    within: Window | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """The triangle ids and depths of the ``layers`` nearest layers of every pixel deeper than
    ``min_depth`` (within ``within``; see ``rasterize_layer``), found in one pass
    (:func:`.visibility.visible_layers`, or its CUDA form where ``pos`` is on the GPU):
    ``(tri_id [L,B,H,W] int32, depth [L,B,H,W] float32)`` on ``pos``'s device, layer ``k`` bit
    for bit what the ``k``-th pass of depth peeling finds. ``layer_images`` turns one into
    ``rast`` and ``rast_db``."""
    height, width = _checked_size(resolution, pos)
    views, tri_range = per_view_positions(pos, tri, ranges)
    tri = check_triangles(tri, views.shape[1])
    if uses_cuda_kernels(pos):
        from . import visibility_cuda

        return visibility_cuda.visible_layers(views, tri, tri_range, height, width, layers, min_depth, within)
    tri_id, depth = visible_layers(views.detach().float().numpy(), tri.numpy(), tri_range.numpy(), height, width,
                                   layers, None if min_depth is None else min_depth.numpy(), within)
    return torch.from_numpy(tri_id), torch.from_numpy(depth)


def layer_images(
    pos: torch.Tensor,
    tri: torch.Tensor,
    ranges: torch.Tensor | None,
    grad_db: bool,
    tri_id: torch.Tensor,
    depth: torch.Tensor,
    block: int | None = None,
) -> tuple[torch.Tensor, torch.Tensor, Window | None]:
    """``(rast, rast_db, window)`` of the layer whose visible triangles are ``tri_id [B,H,W]``
    int32 at ``depth [B,H,W]`` float32 (on ``pos``'s device; arguments as ``rasterize_layer``'s): the whole frame's without
    ``block``; with it, ``covered_window(ids, block)`` and that window of the frame's images
    (``None``, with ``[B, 0, 0, 4]`` images, where nothing is covered)."""
    views, _ = per_view_positions(pos, tri, ranges)
    tri = check_triangles(tri, views.shape[1])
    height, width = tri_id.shape[1:]
    window = Window.whole(height, width) if block is None else covered_window(tri_id, block)
    if window is None:
        empty = views.new_zeros(views.shape[0], 0, 0, 4)
        return empty, empty.clone(), None
    rast, rast_db = pixel_barycentrics(views, tri, window.crop(tri_id).contiguous(), window.crop(depth).contiguous(),
                                       grad_db, window)
    return rast, rast_db, window


def _checked_size(resolution: tuple[int, int], pos: torch.Tensor) -> tuple[int, int]:
    """``(H, W)`` of ``resolution``; ``ValueError`` for a size that is not positive or
    positions that are not floating point."""
    height, width = int(resolution[0]), int(resolution[1])
    if height <= 0 or width <= 0:
        raise ValueError(f"resolution must be positive, got {resolution}")
    if not pos.is_floating_point():
        raise ValueError(f"pos must be a floating-point tensor, got {pos.dtype}")
    return height, width
