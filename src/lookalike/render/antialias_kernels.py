"""Compiled search for the adjacent pixel pairs that an outline runs between, and the
silhouette edge it runs along.

Twin of :func:`.antialias.neighbour_pairs_python` followed by
:func:`.antialias.outline_walk_python` (plain torch); tests compare them. Each pass runs a
per-row (per-pair) body that the CUDA forms (:mod:`.antialias_cuda`) run too, one thread per row
(pair).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..kernel_cache import CACHE
from .window import Window

MAX_WALK = 16
"""Most triangles a pixel-pair segment is followed through before it is given up."""


@njit(cache=CACHE, inline="always")
def _front_side(rast, b, ya, xa, yb, xb):
    """+1 when pixel a is the front of a pair showing different triangles (nearer; any
    triangle is in front of background), -1 when pixel b is, 0 when both show the same."""
    id_a = int(rast[b, ya, xa, 3])
    id_b = int(rast[b, yb, xb, 3])
    if id_a == id_b:
        return 0
    a_in_front = id_a > 0 and (id_b == 0 or rast[b, ya, xa, 2] < rast[b, yb, xb, 2])
    return 1 if a_in_front else -1


@njit(cache=CACHE, parallel=True)
def _count_pairs(rast, counts):
    for row in prange(rast.shape[0] * rast.shape[1]):
        count_row_pairs(rast, counts, row)


@njit(cache=CACHE, inline="always")
def count_row_pairs(rast, counts, row):
    """Row ``row`` (of the ``B H`` rows of ``rast [B, H, W, 4]``) of :func:`_count_pairs` (both
    its CPU and its CUDA form): ``counts[row]``, the pairs its pixels start (with the pixel to
    the right and the one below)."""
    height, width = rast.shape[1], rast.shape[2]
    b, y = row // height, row % height
    n = 0
    for x in range(width):
        if x + 1 < width and _front_side(rast, b, y, x, y, x + 1) != 0:
            n += 1
        if y + 1 < height and _front_side(rast, b, y, x, y + 1, x) != 0:
            n += 1
    counts[row] = n


@njit(cache=CACHE, parallel=True)
def _fill_pairs(rast, starts, front, other, horizontal):
    for row in prange(rast.shape[0] * rast.shape[1]):
        fill_row_pairs(rast, starts, front, other, horizontal, row)


@njit(cache=CACHE, inline="always")
def fill_row_pairs(rast, starts, front, other, horizontal, row):
    """Row ``row`` of :func:`_fill_pairs` (both its CPU and its CUDA form): the pairs it starts,
    at ``starts[row] ..`` of ``front``, ``other`` and ``horizontal``."""
    height, width = rast.shape[1], rast.shape[2]
    b, y = row // height, row % height
    k = starts[row]
    base = row * width
    for x in range(width):
        for is_horizontal in (True, False):
            yb, xb = (y, x + 1) if is_horizontal else (y + 1, x)
            if yb >= height or xb >= width:
                continue
            side = _front_side(rast, b, y, x, yb, xb)
            if side == 0:
                continue
            pa, pb = base + x, (b * height + yb) * width + xb
            front[k] = pa if side > 0 else pb
            other[k] = pb if side > 0 else pa
            horizontal[k] = is_horizontal
            k += 1


@njit(cache=CACHE, inline="always")
def _line_crossing(xyw, tri, b, t, k, fx, fy, ox, oy):
    """Parameter ``s`` at which the segment ``F + s (O - F)`` crosses the line of edge ``k``
    of triangle ``t``: ``e(F) / (e(F) - e(O))`` with ``e(p) = (v_i x v_j) . (p, 1)``; inf
    when the segment runs parallel to it."""
    i, j = tri[t, (k + 1) % 3], tri[t, (k + 2) % 3]
    xi, yi, wi = xyw[b, i, 0], xyw[b, i, 1], xyw[b, i, 2]
    xj, yj, wj = xyw[b, j, 0], xyw[b, j, 1], xyw[b, j, 2]
    cx = yi * wj - wi * yj
    cy = wi * xj - xi * wj
    cw = xi * yj - yi * xj
    e_f = cx * fx + cy * fy + cw
    e_o = cx * ox + cy * oy + cw
    if e_f == e_o:
        return math.inf
    return e_f / (e_f - e_o)


@njit(cache=CACHE, parallel=True)
def _walk(xyw, tri, neighbour, opposite, front, other, start_tri, height, width, window, hit_tri, hit_edge):
    """``window = (top, left, frame_height, frame_width)``: the images are rows ``top ..`` and
    columns ``left ..`` of a frame of that size, whose pixel centres the segments join."""
    top, left, frame_height, frame_width = window
    for m in prange(front.shape[0]):
        walk_pair(xyw, tri, neighbour, opposite, front, other, start_tri, height, width, top, left, frame_height,
                  frame_width, hit_tri, hit_edge, m)


@njit(cache=CACHE, inline="always")
def walk_pair(xyw, tri, neighbour, opposite, front, other, start_tri, height, width, top, left, frame_height,
              frame_width, hit_tri, hit_edge, m):
    """Pair ``m`` of :func:`_walk` (both its CPU and its CUDA form): ``hit_tri[m]`` and
    ``hit_edge[m]``, the silhouette edge its segment crosses (-1 where none); ``(top, left,
    frame_height, frame_width)`` is ``_walk``'s ``window``."""
    hit_tri[m] = -1
    hit_edge[m] = -1
    b = front[m] // (height * width)
    fx = (2.0 * (left + front[m] % width) + 1.0) / frame_width - 1.0
    fy = (2.0 * (top + (front[m] // width) % height) + 1.0) / frame_height - 1.0
    ox = (2.0 * (left + other[m] % width) + 1.0) / frame_width - 1.0
    oy = (2.0 * (top + (other[m] // width) % height) + 1.0) / frame_height - 1.0
    t, entry, s_in = start_tri[m], -1, 0.0
    for _ in range(MAX_WALK):
        best_s, best_k = math.inf, -1
        for k in range(3):
            if k == entry:
                continue
            s = _line_crossing(xyw, tri, b, t, k, fx, fy, ox, oy)
            if s > s_in and s < best_s:
                best_s, best_k = s, k
        if best_k < 0 or best_s > 1.0:
            break  # the segment ends inside t: no outline between the pixels
        if _is_silhouette(xyw[b], tri, opposite, t, best_k):
            hit_tri[m], hit_edge[m] = t, best_k
            break
        shared_a, shared_b = tri[t, (best_k + 1) % 3], tri[t, (best_k + 2) % 3]
        t = neighbour[t, best_k]  # interior edge: the walk goes on in the neighbour
        for k in range(3):
            if tri[t, k] != shared_a and tri[t, k] != shared_b:
                entry = k  # the neighbour's far vertex: the shared edge is opposite it
                break
        s_in = best_s


def outline_crossings(
    rast: np.ndarray, xyw: np.ndarray, tri: np.ndarray, neighbour: np.ndarray, opposite: np.ndarray,
    window: Window | None = None,
):
    """Adjacent pixel pairs with an outline between them, and the silhouette edge it runs along.

    Every horizontally or vertically adjacent pair whose triangle ids differ is followed from
    the front pixel's centre ``F`` (inside its triangle) towards the other's, ``O``: the
    segment leaves a triangle through the edge whose line it crosses first past the entry;
    across an interior edge it goes on in the neighbour, at a silhouette edge it stops
    there.  So an outline is found even when its triangles are slivers that cover no pixel
    centre.  A segment that ends inside a triangle, or crosses more than :data:`MAX_WALK`
    of them, has no outline.

    Args:
        rast: ``[B, H, W, 4]`` float (channel 2 depth z/w, channel 3 triangle id + 1).
        xyw: ``[B, V, 3]`` float64 clip-space ``(x, y, w)``.
        tri: ``[T, 3]`` int64.
        neighbour: ``[T, 3]`` int64 triangle across each edge (see ``EdgeTopology``).
        opposite: ``[T, 3]`` int64 far vertex of the triangle across each edge (-1: none; see
            ``EdgeTopology``), for the silhouette test of the edges the walk crosses
            (``_is_silhouette``; only those, because a large view's walks cross a small share
            of its edges).
        window: the window of a larger frame that ``rast`` is (``None``: the whole frame);
            the segments join that frame's pixel centres.

    Returns:
        ``(front [M], other [M], horizontal [M], edge_tri [M], edge [M])``: flat pixel
        indices into ``[B, H, W]``, whether the pair is horizontal, and the silhouette edge
        ``edge`` of triangle ``edge_tri`` that the segment crosses.  Pairs come in row-major
        order of their first pixel, horizontal before vertical.
    """
    n_views, height, width = rast.shape[0], rast.shape[1], rast.shape[2]
    counts = np.empty(n_views * height, np.int64)
    _count_pairs(rast, counts)
    starts = np.zeros_like(counts)
    np.cumsum(counts[:-1], out=starts[1:])
    total = int(counts.sum())
    front = np.empty(total, np.int64)
    other = np.empty(total, np.int64)
    horizontal = np.empty(total, np.bool_)
    _fill_pairs(rast, starts, front, other, horizontal)
    start_tri = rast.reshape(-1, 4)[front, 3].astype(np.int64) - 1
    hit_tri = np.empty(total, np.int64)
    hit_edge = np.empty(total, np.int64)
    frame = Window.whole(height, width) if window is None else window
    _walk(xyw, tri, neighbour, opposite, front, other, start_tri, height, width,
          (frame.top, frame.left, frame.frame_height, frame.frame_width), hit_tri, hit_edge)
    hit = hit_edge >= 0
    return front[hit], other[hit], horizontal[hit], hit_tri[hit], hit_edge[hit]


@njit(cache=CACHE, inline="always")
def _is_silhouette(xyw, tri, opposite, t, k):
    """Is edge ``k`` of triangle ``t`` (opposite vertex ``k``) a silhouette edge in a view with
    clip-space ``xyw [V, 3]`` ``(x, y, w)``? It is when it has no neighbour (``opposite [T, 3]``
    int64 is -1) or the neighbour's far vertex ``d`` lies on the same side of it as vertex
    ``k``: ``(c_k . d > 0) == (c_k . v_k > 0)`` with ``c_k = v_i x v_j`` over the edge's
    vertices. Twin of :func:`.antialias.silhouette_edges_python`."""
    d = opposite[t, k]
    if d < 0:
        return True
    own = _edge_side(xyw[tri[t, 1]], xyw[tri[t, 2]], xyw[tri[t, 0]])     # det M
    other = _edge_side(xyw[tri[t, (k + 1) % 3]], xyw[tri[t, (k + 2) % 3]], xyw[d])
    return (other > 0) == (own > 0)


@njit(cache=CACHE, inline="always")
def _edge_side(vi, vj, v):
    """``(vi x vj) . v`` for ``(x, y, w)`` vectors: the homogeneous side of the line through
    ``vi`` and ``vj`` that ``v`` lies on (``c_k . v`` of ``_is_silhouette``)."""
    cx = vi[1] * vj[2] - vi[2] * vj[1]
    cy = vi[2] * vj[0] - vi[0] * vj[2]
    cw = vi[0] * vj[1] - vi[1] * vj[0]
    return cx * v[0] + cy * v[1] + cw * v[2]
