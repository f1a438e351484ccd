"""CUDA form of the visibility query (:mod:`.visibility`): the same nearest-fragment k-buffer,
the same conventions and the same per-triangle arithmetic (its helpers, compiled for the GPU),
on torch's CUDA tensors; the plain-torch twin is :func:`.visibility_python.visibility_python`.

Structure, as the CPU form's tiled path: every (view, triangle) is set up once by one thread
(its pixel box and its edge and depth planes, ``_triangle_setup``), the triangles are binned
into ``TILE x TILE`` screen tiles by one thread per (view, tile) that walks the view's triangles
in ascending order (so each bin lists them in that order, as on the CPU), and one thread per
pixel draws the triangles of its tile's bin. Drawing in ascending order with the strict depth
test keeps the lower index on ties, so the layers are those the CPU form finds (to the last bit
of depth where the GPU's fused multiply-adds round as the CPU does).
"""

from __future__ import annotations

import numpy as np
import torch
from numba import cuda, float32, float64

from ..devices import device_function, launch
from . import visibility
from .visibility import TILE
from .window import Window


_triangle_bbox = device_function(visibility._triangle_bbox)
_edge_and_depth_planes = device_function(visibility._edge_and_depth_planes)
_keep_fragment = device_function(visibility.keep_fragment)


@cuda.jit
def _triangle_setup(pos, tri, tri_begin, tri_end, width, height, clip_x0, clip_x1, clip_y0, clip_y1, planes, bbox):
    """Thread ``(b, t)``: ``bbox[b, t] = (x0, x1, y0, y1)``, the inclusive pixel box of triangle
    ``t`` of view ``b`` within the clip box (empty, ``x0 > x1``, where it is culled, degenerate
    or not drawn by the view), and ``planes[b, t]`` its 12 edge and depth plane coefficients
    (``visibility._edge_and_depth_planes``)."""
    job = cuda.grid(1)
    n_tris = tri.shape[0]
    if job >= pos.shape[0] * n_tris:
        return
    b, t = job // n_tris, job % n_tris
    bbox[b, t, 0], bbox[b, t, 1] = 1, 0
    if t < tri_begin[b] or t >= tri_end[b]:
        return
    corners = cuda.local.array((1, 3, 4), float32)
    for k in range(3):
        for c in range(4):
            corners[0, k, c] = pos[b, tri[t, k], c]
    x0, x1, y0, y1 = _triangle_bbox(corners, 0, 0, 1, 2, width, height)
    x0, x1, y0, y1 = max(x0, clip_x0), min(x1, clip_x1), max(y0, clip_y0), min(y1, clip_y1)
    if x0 > x1 or y0 > y1:
        return
    local_planes = cuda.local.array(12, float64)
    if not _edge_and_depth_planes(corners, 0, 0, 1, 2, width, height, local_planes):
        return
    for k in range(12):
        planes[b, t, k] = local_planes[k]
    bbox[b, t, 0], bbox[b, t, 1], bbox[b, t, 2], bbox[b, t, 3] = x0, x1, y0, y1


@cuda.jit(device=True)
def _meets_tile(bbox, b, t, tx0, ty0):
    """Whether the pixel box of triangle ``t`` of view ``b`` (empty where ``x0 > x1``) meets the
    tile whose first pixel is ``(tx0, ty0)``."""
    x0, x1, y0, y1 = bbox[b, t, 0], bbox[b, t, 1], bbox[b, t, 2], bbox[b, t, 3]
    return x0 <= x1 and y0 <= y1 and x0 < tx0 + TILE and tx0 <= x1 and y0 < ty0 + TILE and ty0 <= y1


@cuda.jit
def _bin_count(bbox, tri_begin, tri_end, tiles_x, n_tiles, counts):
    """Thread ``(b, k)``: ``counts[b n_tiles + k]`` = the triangles of view ``b`` whose box
    meets tile ``k``."""
    job = cuda.grid(1)
    if job >= counts.shape[0]:
        return
    b, k = job // n_tiles, job % n_tiles
    tx0, ty0 = (k % tiles_x) * TILE, (k // tiles_x) * TILE
    n = 0
    for t in range(tri_begin[b], tri_end[b]):
        if _meets_tile(bbox, b, t, tx0, ty0):
            n += 1
    counts[job] = n


@cuda.jit
def _bin_fill(bbox, tri_begin, tri_end, tiles_x, n_tiles, bin_start, bin_tris):
    """Thread ``(b, k)``: ``bin_tris[bin_start[j] : bin_start[j + 1]]``, ``j = b n_tiles + k``,
    = the triangles of ``_bin_count``'s count, ascending."""
    job = cuda.grid(1)
    if job >= bin_start.shape[0] - 1:
        return
    b, k = job // n_tiles, job % n_tiles
    tx0, ty0 = (k % tiles_x) * TILE, (k // tiles_x) * TILE
    n = bin_start[job]
    for t in range(tri_begin[b], tri_end[b]):
        if _meets_tile(bbox, b, t, tx0, ty0):
            bin_tris[n] = t
            n += 1


@cuda.jit
def _draw_pixels(planes, bbox, bin_start, bin_tris, tiles_x, n_tiles, min_depth, tri_id, depth):
    """Thread ``(b, iy, ix)``: the triangles of the pixel's tile bin in ascending order, each kept
    among the pixel's ``L`` nearest fragments of distinct depth where its edge functions are
    ``>= 0`` (not all zero) and its float32 depth ``d`` has ``min_depth < d``, ``-1 <= d <= 1``
    (``visibility.keep_fragment``, the CPU form's test and insertion): ``depth [B, H, W, L]``
    (``+inf``: none) and ``tri_id [B, H, W, L]`` (``t + 1``, 0: none)."""
    n_views, height, width, _ = depth.shape
    job = cuda.grid(1)
    if job >= n_views * height * width:
        return
    b, iy, ix = job // (height * width), (job // width) % height, job % width
    j = b * n_tiles + (iy // TILE) * tiles_x + ix // TILE
    for n in range(bin_start[j], bin_start[j + 1]):
        t = bin_tris[n]
        if ix < bbox[b, t, 0] or ix > bbox[b, t, 1] or iy < bbox[b, t, 2] or iy > bbox[b, t, 3]:
            continue
        _keep_fragment(planes[b, t, 0] * ix + (planes[b, t, 1] * iy + planes[b, t, 2]),
                       planes[b, t, 3] * ix + (planes[b, t, 4] * iy + planes[b, t, 5]),
                       planes[b, t, 6] * ix + (planes[b, t, 7] * iy + planes[b, t, 8]),
                       float32(planes[b, t, 9]), float32(planes[b, t, 10]), float32(planes[b, t, 11]), b, iy, ix, t,
                       min_depth, tri_id, depth)


def visible_layers(pos: torch.Tensor, tri: torch.Tensor, tri_range: torch.Tensor, height: int, width: int,
                   layers: int, min_depth: torch.Tensor | None = None,
                   window: Window | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """:func:`.visibility.visible_layers` on the tensors' GPU: ``pos [B, V, 4]`` float32,
    ``tri [T, 3]`` int, ``tri_range [B, 2]`` int64 (any device), ``min_depth [B, H, W]``
    float32 or None, ``window`` as there. Returns ``(tri_id [L, B, H, W] int32, depth [L, B,
    H, W] float32)``, views of arrays that keep a pixel's layers side by side."""
    device = pos.device
    pos = pos.detach().float().contiguous()
    tri = tri.to(device=device, dtype=torch.int32).contiguous()
    begin = tri_range[:, 0].to(device=device, dtype=torch.int64).contiguous()
    end = begin + tri_range[:, 1].to(device=device, dtype=torch.int64)
    n_views, n_tris = pos.shape[0], tri.shape[0]
    if min_depth is None:
        min_depth = torch.full((n_views, height, width), -np.inf, dtype=torch.float32, device=device)
    min_depth = min_depth.to(device=device, dtype=torch.float32).contiguous()
    window = Window.whole(height, width) if window is None else window
    planes = torch.empty(n_views, n_tris, 12, dtype=torch.float64, device=device)
    bbox = torch.empty(n_views, n_tris, 4, dtype=torch.int32, device=device)
    launch(_triangle_setup, n_views * n_tris, pos, tri, begin, end, width, height, window.left,
           window.left + window.width - 1, window.top, window.top + window.height - 1, planes, bbox)
    tiles_x, tiles_y = (width + TILE - 1) // TILE, (height + TILE - 1) // TILE
    n_tiles = tiles_x * tiles_y
    counts = torch.empty(n_views * n_tiles, dtype=torch.int64, device=device)
    launch(_bin_count, counts.shape[0], bbox, begin, end, tiles_x, n_tiles, counts)
    bin_start = torch.cat([counts.new_zeros(1), torch.cumsum(counts, 0)])
    bin_tris = torch.empty(max(int(bin_start[-1]), 1), dtype=torch.int32, device=device)  # never empty
    launch(_bin_fill, counts.shape[0], bbox, begin, end, tiles_x, n_tiles, bin_start, bin_tris)
    tri_id = torch.zeros(n_views, height, width, layers, dtype=torch.int32, device=device)
    depth = torch.full((n_views, height, width, layers), np.inf, dtype=torch.float32, device=device)
    launch(_draw_pixels, n_views * height * width, planes, bbox, bin_start, bin_tris, tiles_x, n_tiles, min_depth,
           tri_id, depth)
    return tri_id.permute(3, 0, 1, 2), depth.permute(3, 0, 1, 2)
