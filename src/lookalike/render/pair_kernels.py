"""Compiled search for the adjacent pixel pairs that antialiasing must look at.

Twin of :func:`.antialias.neighbour_pairs_reference` (plain torch); tests compare them.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(cache=True, inline="always")
def _candidate(rast, has_silhouette, b, ya, xa, yb, xb):
    """Front pixel side (+1: a, -1: b) when pixels a and b show different triangles and
    the front one has a silhouette edge, else 0."""
    id_a = int(rast[b, ya, xa, 3])
    id_b = int(rast[b, yb, xb, 3])
    if id_a == id_b:
        return 0
    a_in_front = id_a > 0 and (id_b == 0 or rast[b, ya, xa, 2] < rast[b, yb, xb, 2])
    front = id_a if a_in_front else id_b
    if not has_silhouette[b, front]:
        return 0
    return 1 if a_in_front else -1


@njit(cache=True, parallel=True)
def _count_pairs(rast, has_silhouette, counts):
    n_views, height, width = rast.shape[0], rast.shape[1], rast.shape[2]
    for row in prange(n_views * height):
        b, y = row // height, row % height
        n = 0
        for x in range(width):
            if x + 1 < width and _candidate(rast, has_silhouette, b, y, x, y, x + 1) != 0:
                n += 1
            if y + 1 < height and _candidate(rast, has_silhouette, b, y, x, y + 1, x) != 0:
                n += 1
        counts[row] = n


@njit(cache=True, parallel=True)
def _fill_pairs(rast, has_silhouette, starts, front, other, horizontal):
    n_views, height, width = rast.shape[0], rast.shape[1], rast.shape[2]
    for row in prange(n_views * height):
        b, y = row // height, row % height
        k = starts[row]
        base = row * width
        for x in range(width):
            for is_horizontal in (True, False):
                yb, xb = (y, x + 1) if is_horizontal else (y + 1, x)
                if yb >= height or xb >= width:
                    continue
                side = _candidate(rast, has_silhouette, b, y, x, yb, xb)
                if side == 0:
                    continue
                pa, pb = base + x, (b * height + yb) * width + xb
                front[k] = pa if side > 0 else pb
                other[k] = pb if side > 0 else pa
                horizontal[k] = is_horizontal
                k += 1


def silhouette_pair_candidates(rast: np.ndarray, has_silhouette: np.ndarray):
    """Adjacent pixel pairs that may straddle a silhouette edge.

    Args:
        rast: ``[B, H, W, 4]`` float (channel 2 depth z/w, channel 3 triangle id + 1).
        has_silhouette: ``[B, T + 1]`` bool, whether triangle ``id - 1`` has a silhouette
            edge in view ``b`` (column 0, background, False).

    Returns:
        ``(front [M], other [M], horizontal [M])``: flat pixel indices into ``[B, H, W]``
        of each pair whose ids differ and whose front (nearer; any triangle is in front of
        background) triangle has a silhouette edge, and whether the pair is horizontal.
        Pairs come in row-major order of their first pixel, horizontal before vertical.
    """
    n_views, height = rast.shape[0], rast.shape[1]
    counts = np.empty(n_views * height, np.int64)
    _count_pairs(rast, has_silhouette, counts)
    starts = np.zeros_like(counts)
    np.cumsum(counts[:-1], out=starts[1:])
    total = int(counts.sum())
    front = np.empty(total, np.int64)
    other = np.empty(total, np.int64)
    horizontal = np.empty(total, np.bool_)
    _fill_pairs(rast, has_silhouette, starts, front, other, horizontal)
    return front, other, horizontal
