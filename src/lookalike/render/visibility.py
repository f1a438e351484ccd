"""Compiled visibility query: which triangle is nearest at each pixel centre.

It answers a discrete question (triangle id and depth per pixel) through which no gradient
flows, so unlike the other compiled kernels of the renderer it has no backward pass; the
differentiable barycentrics of the found triangles are computed afterwards (see
:mod:`.barycentrics`).  The plain-torch twin is :func:`.visibility_python.visibility_python`.

Conventions (nvdiffrast's / OpenGL's):

- Pixel ``(ix, iy)`` of an ``H x W`` image has its centre at normalised device coordinates
  ``px = (2 ix + 1) / W - 1``, ``py = (2 iy + 1) / H - 1``; row ``iy = 0`` is ``y = -1``.
- A clip-space point ``(x, y, z, w)`` is inside the view volume when ``w > 0`` and
  ``-w <= x, y, z <= w``; its depth is ``z / w`` in ``[-1, 1]``, smaller is nearer.
- Both faces of a triangle are rasterized (no culling).

Method: homogeneous 2D rasterization (Olano & Greer 1997).  With the clip-space vertices
``v_i = (x_i, y_i, w_i)`` as columns of ``M`` and ``p = (px, py, 1)``, the edge functions
are ``e_i(p) = (v_j x v_k) . p`` for ``(i, j, k)`` cyclic, i.e. ``e = adj(M) p``.  The pixel
centre lies on the triangle, in front of the eye (``w > 0``), exactly when
``sign(det M) * e_i >= 0`` for all ``i`` (and not all are zero).  Its depth is
``z/w = sum_i e_i z_i / det M``, an affine function of ``(px, py)``.  Triangles crossing the
near plane need no clipping: points behind the eye fail the edge test, points between eye
and near plane fail the depth test ``z/w >= -1``.  Depths are float32 and compared in
float32 throughout, so a depth written by one pass compares bit-exactly in the next
(depth peeling).

Parallelism: with at least as many views as threads, ``prange`` runs over views, each
walking its triangles once.  With fewer views (a single one, typically) the triangles are
first binned into ``TILE x TILE`` pixel tiles and ``prange`` runs over (view, tile) pairs,
so every core stays busy.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import njit, prange

from ..kernel_cache import CACHE
from .window import Window

TILE = 32
"""Side of a screen tile in pixels."""

_CHUNKS = 16
"""Triangle chunks binned in parallel (per view)."""


@njit(cache=CACHE, inline="always")
def _edge_and_depth_planes(pos, b, i0, i1, i2, width, height, planes):
    """Edge functions and depth of one triangle as affine functions of the pixel index.

    Writes ``planes[0:3] = (A, B, C)`` of edge 0, ``[3:6]`` edge 1, ``[6:9]`` edge 2, with
    ``e_i(ix, iy) = A ix + B iy + C`` scaled so that inside is ``e_i >= 0``, and
    ``planes[9:12]`` the depth plane ``z/w = A ix + B iy + C``.  Returns False for a
    degenerate triangle (``det M == 0``).
    """
    x0, y0, z0, w0 = pos[b, i0, 0], pos[b, i0, 1], pos[b, i0, 2], pos[b, i0, 3]
    x1, y1, z1, w1 = pos[b, i1, 0], pos[b, i1, 1], pos[b, i1, 2], pos[b, i1, 3]
    x2, y2, z2, w2 = pos[b, i2, 0], pos[b, i2, 1], pos[b, i2, 2], pos[b, i2, 3]
    x0, y0, z0, w0 = np.float64(x0), np.float64(y0), np.float64(z0), np.float64(w0)
    x1, y1, z1, w1 = np.float64(x1), np.float64(y1), np.float64(z1), np.float64(w1)
    x2, y2, z2, w2 = np.float64(x2), np.float64(y2), np.float64(z2), np.float64(w2)
    # c_i = v_j x v_k with v = (x, y, w)
    c0x, c0y, c0w = y1 * w2 - w1 * y2, w1 * x2 - x1 * w2, x1 * y2 - y1 * x2
    c1x, c1y, c1w = y2 * w0 - w2 * y0, w2 * x0 - x2 * w0, x2 * y0 - y2 * x0
    c2x, c2y, c2w = y0 * w1 - w0 * y1, w0 * x1 - x0 * w1, x0 * y1 - y0 * x1
    det = x0 * c0x + y0 * c0y + w0 * c0w
    if det == 0.0:
        return False
    s = 1.0 if det > 0.0 else -1.0
    sx = 2.0 / width
    sy = 2.0 / height
    ox = 1.0 / width - 1.0
    oy = 1.0 / height - 1.0
    planes[0] = s * c0x * sx
    planes[1] = s * c0y * sy
    planes[2] = s * (c0w + c0x * ox + c0y * oy)
    planes[3] = s * c1x * sx
    planes[4] = s * c1y * sy
    planes[5] = s * (c1w + c1x * ox + c1y * oy)
    planes[6] = s * c2x * sx
    planes[7] = s * c2y * sy
    planes[8] = s * (c2w + c2x * ox + c2y * oy)
    dx = (c0x * z0 + c1x * z1 + c2x * z2) / det
    dy = (c0y * z0 + c1y * z1 + c2y * z2) / det
    dw = (c0w * z0 + c1w * z1 + c2w * z2) / det
    planes[9] = dx * sx
    planes[10] = dy * sy
    planes[11] = dw + dx * ox + dy * oy
    return True


@njit(cache=CACHE, inline="always")
def _outside_one_plane(pos, b, i0, i1, i2):
    """True when all three vertices lie outside the same clip plane (``x > w``, ``x < -w``,
    ``y > w``, ``y < -w``, ``z > w``, ``z < -w``): then no point of the triangle is visible."""
    for axis in range(3):
        above = True
        below = True
        for i in (i0, i1, i2):
            c = pos[b, i, axis]
            w = pos[b, i, 3]
            above = above and c > w
            below = below and c < -w
        if above or below:
            return True
    return False


@njit(cache=CACHE, inline="always")
def _pixel_range(xmin, xmax, ymin, ymax, width, height):
    """Inclusive pixel-index box ``(x0, x1, y0, y1)`` of the pixels whose centre (pixel
    coordinate ``ix``) lies in ``[xmin, xmax] x [ymin, ymax]``, clipped to the image."""
    return (
        max(0, int(math.ceil(max(xmin, -1.0)))),
        min(width - 1, int(math.floor(min(xmax, float(width))))),
        max(0, int(math.ceil(max(ymin, -1.0)))),
        min(height - 1, int(math.floor(min(ymax, float(height))))),
    )


@njit(cache=CACHE)
def _triangle_bbox(pos, b, i0, i1, i2, width, height):
    """Inclusive pixel-index bounding box ``(x0, x1, y0, y1)`` of the visible part of a
    triangle; empty (``x0 > x1``) when culled.

    Pixel coordinates are ``X = (x/w + 1) W/2 - 1/2`` (pixel ``ix`` has its centre at
    ``X = ix``).  When the triangle crosses the near plane ``z + w = 0`` it is first clipped
    against it (Sutherland-Hodgman, at most 4 vertices).  If a remaining vertex still has
    ``w <= 0`` (unusual projections) the box is the whole screen, which is conservative:
    the per-pixel test decides.
    """
    if _outside_one_plane(pos, b, i0, i1, i2):
        return 1, 0, 1, 0
    half_w, half_h = 0.5 * width, 0.5 * height
    w0, w1, w2 = pos[b, i0, 3], pos[b, i1, 3], pos[b, i2, 3]
    if (
        w0 > 0.0 and w1 > 0.0 and w2 > 0.0
        and pos[b, i0, 2] + w0 >= 0.0 and pos[b, i1, 2] + w1 >= 0.0 and pos[b, i2, 2] + w2 >= 0.0
    ):  # common case: entirely in front of the near plane
        r0, r1, r2 = 1.0 / np.float64(w0), 1.0 / np.float64(w1), 1.0 / np.float64(w2)
        X0 = (pos[b, i0, 0] * r0 + 1.0) * half_w - 0.5
        X1 = (pos[b, i1, 0] * r1 + 1.0) * half_w - 0.5
        X2 = (pos[b, i2, 0] * r2 + 1.0) * half_w - 0.5
        Y0 = (pos[b, i0, 1] * r0 + 1.0) * half_h - 0.5
        Y1 = (pos[b, i1, 1] * r1 + 1.0) * half_h - 0.5
        Y2 = (pos[b, i2, 1] * r2 + 1.0) * half_h - 0.5
        return _pixel_range(min(X0, X1, X2), max(X0, X1, X2), min(Y0, Y1, Y2), max(Y0, Y1, Y2), width, height)
    xmin, xmax, ymin, ymax = np.inf, -np.inf, np.inf, -np.inf
    for k in range(3):
        a = i0 if k == 0 else (i1 if k == 1 else i2)
        c = i1 if k == 0 else (i2 if k == 1 else i0)
        da = np.float64(pos[b, a, 2]) + np.float64(pos[b, a, 3])
        dc = np.float64(pos[b, c, 2]) + np.float64(pos[b, c, 3])
        # emit a if inside, and the crossing point if the edge a->c crosses the plane
        for emit in range(2):
            if emit == 0:
                if da < 0.0:
                    continue
                s = 0.0
            else:
                if (da >= 0.0) == (dc >= 0.0):
                    continue
                s = da / (da - dc)
            x = pos[b, a, 0] + s * (np.float64(pos[b, c, 0]) - pos[b, a, 0])
            y = pos[b, a, 1] + s * (np.float64(pos[b, c, 1]) - pos[b, a, 1])
            w = pos[b, a, 3] + s * (np.float64(pos[b, c, 3]) - pos[b, a, 3])
            if w <= 0.0:
                return 0, width - 1, 0, height - 1
            X = (x / w + 1.0) * half_w - 0.5
            Y = (y / w + 1.0) * half_h - 0.5
            xmin, xmax = min(xmin, X), max(xmax, X)
            ymin, ymax = min(ymin, Y), max(ymax, Y)
    if xmin > xmax:
        return 1, 0, 1, 0
    return _pixel_range(xmin, xmax, ymin, ymax, width, height)


_FRONT = 64
"""Bit of ``project_vertices``'s codes: the vertex is in front of the eye and the near plane."""


@njit(cache=CACHE, parallel=True)
def project_vertices(pos, width, height):
    """Per view and vertex, what ``_triangle_bbox`` needs, computed once instead of once per
    triangle (a vertex is shared by about six): ``(screen [B, V, 2] float64, code [B, V]
    uint8)``, the pixel coordinates ``X = (x/w + 1) W/2 - 1/2``, ``Y`` alike (valid where the
    vertex is in front), and the outcode (bit ``2 axis``: ``c > w``, bit ``2 axis + 1``: ``c <
    -w`` for ``c = x, y, z``; ``_FRONT``: ``w > 0`` and ``z + w >= 0``)."""
    n_views, n_vertices = pos.shape[0], pos.shape[1]
    screen = np.empty((n_views, n_vertices, 2), np.float64)
    code = np.zeros((n_views, n_vertices), np.uint8)
    half_w, half_h = 0.5 * width, 0.5 * height
    for job in prange(n_views * _CHUNKS):
        b, chunk = job // _CHUNKS, job % _CHUNKS
        for v in range(chunk * n_vertices // _CHUNKS, (chunk + 1) * n_vertices // _CHUNKS):
            w = pos[b, v, 3]
            bits = 0
            for axis in range(3):
                c = pos[b, v, axis]
                if c > w:
                    bits |= 1 << (2 * axis)
                if c < -w:
                    bits |= 1 << (2 * axis + 1)
            if w > 0.0 and pos[b, v, 2] + w >= 0.0:
                bits |= _FRONT
                r = 1.0 / np.float64(w)
                screen[b, v, 0] = (pos[b, v, 0] * r + 1.0) * half_w - 0.5
                screen[b, v, 1] = (pos[b, v, 1] * r + 1.0) * half_h - 0.5
            code[b, v] = bits
    return screen, code


@njit(cache=CACHE, inline="always")
def _projected_bbox(pos, screen, code, b, i0, i1, i2, width, height):
    """``_triangle_bbox`` from ``project_vertices``'s output: the same box, bit for bit (the
    general clipping path where a vertex is not in front)."""
    c0, c1, c2 = code[b, i0], code[b, i1], code[b, i2]
    if (c0 & c1 & c2) & (_FRONT - 1):
        return 1, 0, 1, 0
    if c0 & c1 & c2 & _FRONT:
        X0, X1, X2 = screen[b, i0, 0], screen[b, i1, 0], screen[b, i2, 0]
        Y0, Y1, Y2 = screen[b, i0, 1], screen[b, i1, 1], screen[b, i2, 1]
        return _pixel_range(min(X0, X1, X2), max(X0, X1, X2), min(Y0, Y1, Y2), max(Y0, Y1, Y2), width, height)
    return _triangle_bbox(pos, b, i0, i1, i2, width, height)


@njit(cache=CACHE, inline="always")
def _clip_box(x0, x1, y0, y1, clip):
    """The inclusive box ``x0..x1, y0..y1`` within ``clip = [x0, x1, y0, y1]`` (empty, ``x0 >
    x1`` or ``y0 > y1``, where they do not meet)."""
    return max(x0, clip[0]), min(x1, clip[1]), max(y0, clip[2]), min(y1, clip[3])


@njit(cache=CACHE, inline="always")
def _draw_triangle(pos, tri, b, t, x0, x1, y0, y1, width, height, planes, min_depth, tri_id, depth):
    """Depth-test triangle ``t`` of view ``b`` at the pixel centres of the inclusive box
    ``x0..x1, y0..y1`` and keep it among the ``L`` nearest: ``depth [B, H, W, L]`` (float32
    z/w, ascending, ``+inf`` for none; a pixel's layers side by side, so that an insertion
    touches one cache line) and ``tri_id [B, H, W, L]`` (``t + 1``) get the fragment
    inserted in depth order where ``min_depth < d``, ``-1 <= d <= 1``, every edge function is
    ``>= 0``, ``d`` is below the ``L``-th depth and no kept fragment has depth ``d`` (the one
    drawn first, the lower index, wins ties, as when peeling).  ``planes`` is float64 scratch
    of 12."""
    if not _edge_and_depth_planes(pos, b, tri[t, 0], tri[t, 1], tri[t, 2], width, height, planes):
        return
    dA = np.float32(planes[9])
    dB = np.float32(planes[10])
    dC = np.float32(planes[11])
    for iy in range(y0, y1 + 1):
        e0 = planes[1] * iy + planes[2]
        e1 = planes[4] * iy + planes[5]
        e2 = planes[7] * iy + planes[8]
        for ix in range(x0, x1 + 1):
            keep_fragment(planes[0] * ix + e0, planes[3] * ix + e1, planes[6] * ix + e2, dA, dB, dC, b, iy, ix, t,
                          min_depth, tri_id, depth)


@njit(cache=CACHE, inline="always")
def keep_fragment(a0, a1, a2, dA, dB, dC, b, iy, ix, t, min_depth, tri_id, depth):
    """The fragment of triangle ``t`` at pixel ``(b, iy, ix)``, whose edge functions there are
    ``a0, a1, a2`` and whose float32 depth plane is ``d = dA ix + dB iy + dC``, kept among the
    pixel's nearest as ``_draw_triangle`` says (both the CPU's and the CUDA form's test and
    insertion)."""
    if a0 < 0.0 or a1 < 0.0 or a2 < 0.0 or a0 + a1 + a2 <= 0.0:
        return
    d = dA * np.float32(ix) + dB * np.float32(iy) + dC
    if d < np.float32(-1.0) or d > np.float32(1.0) or d <= min_depth[b, iy, ix]:
        return
    layers = depth.shape[3]
    if not d < depth[b, iy, ix, layers - 1]:
        return
    slot = 0
    while depth[b, iy, ix, slot] < d:
        slot += 1
    if depth[b, iy, ix, slot] == d:
        return
    for k in range(layers - 1, slot, -1):
        depth[b, iy, ix, k] = depth[b, iy, ix, k - 1]
        tri_id[b, iy, ix, k] = tri_id[b, iy, ix, k - 1]
    depth[b, iy, ix, slot] = d
    tri_id[b, iy, ix, slot] = t + 1


@njit(cache=CACHE, parallel=True)
def _rasterize_views(pos, screen, code, tri, tri_begin, tri_end, width, height, clip, min_depth, tri_id, depth):
    """One view per parallel job: each walks its triangles in ascending order (so with the
    strict depth test the lower index wins ties), drawing within ``clip`` (see
    ``_clip_box``).  Used when there are at least as many views as threads."""
    for b in prange(pos.shape[0]):
        planes = np.empty(12, np.float64)
        for t in range(tri_begin[b], tri_end[b]):
            x0, x1, y0, y1 = _projected_bbox(pos, screen, code, b, tri[t, 0], tri[t, 1], tri[t, 2], width, height)
            x0, x1, y0, y1 = _clip_box(x0, x1, y0, y1, clip)
            if x0 <= x1 and y0 <= y1:
                _draw_triangle(pos, tri, b, t, x0, x1, y0, y1, width, height, planes, min_depth, tri_id, depth)


@njit(cache=CACHE, parallel=True)
def _bin_triangles(pos, screen, code, tri, tri_begin, tri_end, width, height, clip):
    """Bound each view's triangles and bin them into screen tiles.

    ``screen``, ``code``: from :func:`project_vertices`; ``clip``: see ``_clip_box``.
    Returns ``(bbox [B, T, 4] int32, bin_start [B, tiles+1] int64, bin_tris [N] int32)``:
    the boxes of :func:`_triangle_bbox` within ``clip`` (only for the view's triangle range), and the
    triangles of tile ``k`` of view ``b`` are ``bin_tris[bin_start[b, k]:bin_start[b,
    k + 1]]``, in ascending order.
    """
    n_views = pos.shape[0]
    tiles_x = (width + TILE - 1) // TILE
    tiles_y = (height + TILE - 1) // TILE
    n_tiles = tiles_x * tiles_y
    bbox = np.empty((n_views, tri.shape[0], 4), np.int32)
    counts = np.zeros((n_views, _CHUNKS, n_tiles), np.int64)
    for job in prange(n_views * _CHUNKS):
        b, chunk = job // _CHUNKS, job % _CHUNKS
        n = tri_end[b] - tri_begin[b]
        for t in range(tri_begin[b] + chunk * n // _CHUNKS, tri_begin[b] + (chunk + 1) * n // _CHUNKS):
            x0, x1, y0, y1 = _projected_bbox(pos, screen, code, b, tri[t, 0], tri[t, 1], tri[t, 2], width, height)
            x0, x1, y0, y1 = _clip_box(x0, x1, y0, y1, clip)
            bbox[b, t, 0], bbox[b, t, 1], bbox[b, t, 2], bbox[b, t, 3] = x0, x1, y0, y1
            if x0 > x1 or y0 > y1:
                continue
            for ty in range(y0 // TILE, y1 // TILE + 1):
                for tx in range(x0 // TILE, x1 // TILE + 1):
                    counts[b, chunk, ty * tiles_x + tx] += 1
    # offsets in (view, tile, chunk) order, so each bin lists triangles in ascending order
    bin_start = np.zeros((n_views, n_tiles + 1), np.int64)
    offsets = np.empty((n_views, _CHUNKS, n_tiles), np.int64)
    total = 0
    for b in range(n_views):
        for k in range(n_tiles):
            bin_start[b, k] = total
            for chunk in range(_CHUNKS):
                offsets[b, chunk, k] = total
                total += counts[b, chunk, k]
        bin_start[b, n_tiles] = total
    bin_tris = np.empty(total, np.int32)
    for job in prange(n_views * _CHUNKS):
        b, chunk = job // _CHUNKS, job % _CHUNKS
        n = tri_end[b] - tri_begin[b]
        for t in range(tri_begin[b] + chunk * n // _CHUNKS, tri_begin[b] + (chunk + 1) * n // _CHUNKS):
            if bbox[b, t, 0] > bbox[b, t, 1] or bbox[b, t, 2] > bbox[b, t, 3]:
                continue
            for ty in range(bbox[b, t, 2] // TILE, bbox[b, t, 3] // TILE + 1):
                for tx in range(bbox[b, t, 0] // TILE, bbox[b, t, 1] // TILE + 1):
                    k = ty * tiles_x + tx
                    bin_tris[offsets[b, chunk, k]] = t
                    offsets[b, chunk, k] += 1
    return bbox, bin_start, bin_tris


@njit(cache=CACHE, parallel=True)
def _rasterize_tiles(pos, tri, bbox, bin_start, bin_tris, width, height, min_depth, tri_id, depth):
    """One screen tile of one view per parallel job, drawing the triangles binned to it
    (ascending order, so the lower index wins ties).  Used for fewer views than threads."""
    n_views = pos.shape[0]
    tiles_x = (width + TILE - 1) // TILE
    n_tiles = bin_start.shape[1] - 1
    for job in prange(n_views * n_tiles):
        b, k = job // n_tiles, job % n_tiles
        tx0 = (k % tiles_x) * TILE
        ty0 = (k // tiles_x) * TILE
        tx1 = min(tx0 + TILE, width) - 1
        ty1 = min(ty0 + TILE, height) - 1
        planes = np.empty(12, np.float64)
        for n in range(bin_start[b, k], bin_start[b, k + 1]):
            t = bin_tris[n]
            x0, x1 = max(bbox[b, t, 0], tx0), min(bbox[b, t, 1], tx1)
            y0, y1 = max(bbox[b, t, 2], ty0), min(bbox[b, t, 3], ty1)
            _draw_triangle(pos, tri, b, t, x0, x1, y0, y1, width, height, planes, min_depth, tri_id, depth)


def visible_triangles(
    pos: np.ndarray,
    tri: np.ndarray,
    tri_range: np.ndarray,
    height: int,
    width: int,
    min_depth: np.ndarray | None = None,
    window: Window | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Nearest triangle at every pixel centre of every view.

    Args:
        pos: ``[B, V, 4]`` float32, clip-space vertex positions of each view.
        tri: ``[T, 3]`` int32 vertex indices.
        tri_range: ``[B, 2]`` int64 ``(first, count)``: view ``b`` draws triangles
            ``first .. first+count-1`` (all views: ``(0, T)``).
        height, width: image size in pixels.
        min_depth: ``[B, H, W]`` float32 or None; only fragments with depth ``z/w``
            strictly greater are kept (the previous layer's depth, for depth peeling).
        window: where given, only its pixels are drawn (the others stay background): the
            window that holds the previous layer's fragments, outside which ``min_depth`` is
            ``+inf``, so the result is the same at the cost of the window's tiles.

    Returns:
        ``(tri_id [B,H,W] int32, depth [B,H,W] float32)``: triangle index + 1 (0 where no
        triangle) and its depth z/w (``+inf`` where none).
    """
    tri_id, depth = visible_layers(pos, tri, tri_range, height, width, 1, min_depth, window)
    return tri_id[0], depth[0]


def visible_layers(
    pos: np.ndarray,
    tri: np.ndarray,
    tri_range: np.ndarray,
    height: int,
    width: int,
    layers: int,
    min_depth: np.ndarray | None = None,
    window: Window | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The ``layers`` nearest fragments of distinct depth at every pixel centre of every view,
    in one pass over the triangles (a k-buffer): layer ``k`` is what depth peeling finds on its
    ``k``-th pass, bit for bit, at the cost of about one pass.

    Arguments as for :func:`visible_triangles`, plus ``layers`` (``L``). Returns ``(tri_id
    [L,B,H,W] int32, depth [L,B,H,W] float32)``: per layer, nearest first, triangle index + 1
    (0 where no fragment is left) and depth z/w (``+inf`` where none); views of arrays that
    keep a pixel's layers side by side (one layer is contiguous where ``L = 1``).
    """
    pos = np.ascontiguousarray(pos, dtype=np.float32)
    tri = np.ascontiguousarray(tri, dtype=np.int32)
    n_views = pos.shape[0]
    begin = np.ascontiguousarray(tri_range[:, 0], dtype=np.int64)
    end = begin + np.ascontiguousarray(tri_range[:, 1], dtype=np.int64)
    if min_depth is None:
        min_depth = np.full((n_views, height, width), -np.inf, np.float32)
    min_depth = np.ascontiguousarray(min_depth, dtype=np.float32)
    tri_id = np.zeros((n_views, height, width, layers), np.int32)
    depth = np.full((n_views, height, width, layers), np.inf, np.float32)
    window = Window.whole(height, width) if window is None else window
    clip = np.array([window.left, window.left + window.width - 1, window.top, window.top + window.height - 1], np.int64)
    screen, code = project_vertices(pos, width, height)
    if n_views >= numba.get_num_threads():
        _rasterize_views(pos, screen, code, tri, begin, end, width, height, clip, min_depth, tri_id, depth)
    else:
        bbox, bin_start, bin_tris = _bin_triangles(pos, screen, code, tri, begin, end, width, height, clip)
        _rasterize_tiles(pos, tri, bbox, bin_start, bin_tris, width, height, min_depth, tri_id, depth)
    return np.moveaxis(tri_id, 3, 0), np.moveaxis(depth, 3, 0)
