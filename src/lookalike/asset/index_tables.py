"""Compiled tables over a triangle list's indices: which triangles repeat a vertex triple
(and with which orientation), which triangles meet across an edge, and which corners repeat a
(position, normal) pair.

One sequential pass each (hash tables with open addressing, or lists per position; expected
O(T)), where the numpy twins sort (O(T log T)), because on inputs of millions of triangles the
sorts of ``decimate.clean_triangles_python``, ``transfer.surface_patches_python`` and
``normals.weld_normals_python`` dominated the start-up. Tests compare each with its twin.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..kernel_cache import CACHE

_EMPTY = -1


@njit(cache=CACHE, inline="always")
def _mix(h, x):
    """One round of a multiplicative hash of int64 ``x`` into ``h`` (wrapping arithmetic)."""
    h = (h ^ x) * 0x100000001B3
    return h ^ (h >> 29)


@njit(cache=CACHE, inline="always")
def _capacity(n):
    """A power of two at least ``2 n`` (and 16): a table at most half full."""
    capacity = 16
    while capacity < 2 * n:
        capacity *= 2
    return capacity


@njit(cache=CACHE, inline="always")
def _sorted3(a, b, c):
    if a > b:
        a, b = b, a
    if b > c:
        b, c = c, b
    if a > b:
        a, b = b, a
    return a, b, c


@njit(cache=CACHE)
def triple_copies(t_pos_idx):
    """Repeated vertex triples among the triangles ``t_pos_idx [T, 3]`` int64.

    Two triangles with the same set of three distinct indices have the same orientation when
    one is a rotation of the other (an even permutation). Returns ``(fin [T], first [T])``
    bool: ``fin`` where the triangle's triple appears with both orientations (a zero-volume
    fin), ``first`` where the triangle is the first (lowest index) of its triple with its
    orientation. Triangles with a repeated index are neither."""
    n = t_pos_idx.shape[0]
    capacity = _capacity(n)
    mask = capacity - 1
    holder = np.full(capacity, _EMPTY, np.int64)       # a triangle with the slot's triple
    first_of = np.full((capacity, 2), _EMPTY, np.int64)  # first triangle of each orientation
    slot_of = np.full(n, _EMPTY, np.int64)
    parity = np.zeros(n, np.int64)
    for t in range(n):
        x, y, z = t_pos_idx[t, 0], t_pos_idx[t, 1], t_pos_idx[t, 2]
        if x == y or y == z or z == x:
            continue
        a, b, c = _sorted3(x, y, z)
        # rotate the smallest index to the front: even permutations leave the other two ascending
        second, third = (y, z) if x == a else ((z, x) if y == a else (x, y))
        parity[t] = 0 if second < third else 1
        slot = _mix(_mix(_mix(0, a), b), c) & mask
        while True:
            other = holder[slot]
            if other == _EMPTY:
                holder[slot] = t
                break
            if _sorted3(t_pos_idx[other, 0], t_pos_idx[other, 1], t_pos_idx[other, 2]) == (a, b, c):
                break
            slot = (slot + 1) & mask
        slot_of[t] = slot
        if first_of[slot, parity[t]] == _EMPTY:
            first_of[slot, parity[t]] = t
    fin = np.zeros(n, np.bool_)
    first = np.zeros(n, np.bool_)
    for t in range(n):
        slot = slot_of[t]
        if slot != _EMPTY:
            fin[t] = first_of[slot, 0] != _EMPTY and first_of[slot, 1] != _EMPTY
            first[t] = first_of[slot, parity[t]] == t
    return fin, first


@njit(cache=CACHE, inline="always")
def _edge_ends(w_idx, half_edge):
    """``(lo, hi, flipped)``: the vertices of half-edge ``3 t + k`` (corner ``k`` to ``k + 1``
    of triangle ``t``), in ascending order, and whether that reverses them."""
    t, k = half_edge // 3, half_edge % 3
    start, end = w_idx[t, k], w_idx[t, (k + 1) % 3]
    return (end, start, True) if start > end else (start, end, False)


@njit(cache=CACHE, inline="always")
def _root(parent, node):
    while parent[node] != node:
        parent[node] = parent[parent[node]]
        node = parent[node]
    return node


@njit(cache=CACHE)
def patch_labels(w_idx, t_mat_idx, corner_uv, tolerance):
    """Connected components of triangles that share a material and an edge across which UVs
    are continuous (twin: ``transfer.surface_patches_python``).

    Half-edges are visited in index order; each is joined to the previous half-edge over the
    same pair of vertices when both triangles have the same material and the UVs at both ends
    differ by at most ``tolerance`` in each coordinate (so on an edge shared by more than two
    triangles, consecutive ones are joined, as the twin's stable sort pairs them).

    Args:
        w_idx: ``[T, 3]`` int64 welded position indices; t_mat_idx: ``[T]`` int64;
        corner_uv: ``[T, 3, 2]`` float64 UV at each corner; tolerance: in UV units.

    Returns:
        ``[T]`` int64 labels ``0 .. P-1``, numbered in order of each patch's first triangle.
    """
    n = w_idx.shape[0]
    parent = np.arange(n)
    capacity = _capacity(3 * n)
    mask = capacity - 1
    last = np.full(capacity, _EMPTY, np.int64)   # the latest half-edge over the slot's vertex pair
    for half_edge in range(3 * n):
        lo, hi, flipped = _edge_ends(w_idx, half_edge)
        slot = _mix(_mix(0, lo), hi) & mask
        while True:
            other = last[slot]
            if other == _EMPTY:
                break
            other_lo, other_hi, other_flipped = _edge_ends(w_idx, other)
            if other_lo == lo and other_hi == hi:
                break
            slot = (slot + 1) & mask
        if other != _EMPTY:
            t, s = half_edge // 3, other // 3
            if t_mat_idx[t] == t_mat_idx[s]:
                joined = True
                for end in range(2):
                    corner_t = (half_edge % 3 + (end if not flipped else 1 - end)) % 3
                    corner_s = (other % 3 + (end if not other_flipped else 1 - end)) % 3
                    for axis in range(2):
                        if not abs(corner_uv[t, corner_t, axis] - corner_uv[s, corner_s, axis]) <= tolerance:
                            joined = False  # (NaN UVs never join)
                if joined:
                    root_t, root_s = _root(parent, t), _root(parent, s)
                    if root_t != root_s:
                        parent[max(root_t, root_s)] = min(root_t, root_s)
        last[slot] = half_edge
    labels = np.full(n, _EMPTY, np.int64)
    count = 0
    for t in range(n):
        root = _root(parent, t)
        if labels[root] == _EMPTY:
            labels[root] = count
            count += 1
        labels[t] = labels[root]
    return labels


@njit(cache=CACHE)
def first_occurrence_slots(position, bits, n_positions):
    """Equal rows of ``(position [N] int64, bits [N, 3] int32)`` get equal slots.

    Each position in ``0 .. n_positions-1`` keeps a list of the first rows of its distinct
    ``bits`` (a few per position: one per smoothing group), so a row is compared only with rows
    at its own position, and no hashing scatters the accesses (so a mesh whose indices are
    local runs fastest).

    Returns ``(slot [N] int64, count)``, slots numbered ``0 .. count-1`` in the order of each
    distinct row's first occurrence (twin: ``normals.weld_normals_python``)."""
    n = position.shape[0]
    head = np.full(n_positions, _EMPTY, np.int64)   # the first row of each position's list
    after = np.empty(n, np.int64)                    # the next row in its position's list
    slot = np.empty(n, np.int64)
    count = 0
    for row in range(n):
        listed, last = head[position[row]], _EMPTY
        while listed != _EMPTY and not (bits[listed, 0] == bits[row, 0] and bits[listed, 1] == bits[row, 1]
                                        and bits[listed, 2] == bits[row, 2]):
            listed, last = after[listed], listed
        if listed != _EMPTY:
            slot[row] = slot[listed]
            continue
        after[row] = _EMPTY
        if last == _EMPTY:
            head[position[row]] = row
        else:
            after[last] = row
        slot[row] = count
        count += 1
    return slot, count
