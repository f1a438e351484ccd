"""CUDA form of antialias's outline search (:mod:`.antialias_kernels`): the same passes on
torch's CUDA tensors, one thread per image row to count and list its pixel pairs (so that the
pairs come in the CPU form's order) and one per pair to walk its segment, each running the CPU
form's body (compiled for the GPU by ``devices.device_function``). The plain-torch twins are
:func:`.antialias.neighbour_pairs_python` and :func:`.antialias.outline_walk_python`.
"""

from __future__ import annotations

import torch
from numba import cuda

from ..devices import device_function, launch
from . import antialias_kernels as kernels
from .window import Window

_count_row = device_function(kernels.count_row_pairs)
_fill_row = device_function(kernels.fill_row_pairs)
_walk_pair = device_function(kernels.walk_pair)


@cuda.jit
def _count_pairs(rast, counts):
    """Thread per image row: :func:`.antialias_kernels.count_row_pairs`."""
    row = cuda.grid(1)
    if row < counts.shape[0]:
        _count_row(rast, counts, row)


@cuda.jit
def _fill_pairs(rast, starts, front, other, horizontal):
    """Thread per image row: :func:`.antialias_kernels.fill_row_pairs`."""
    row = cuda.grid(1)
    if row < starts.shape[0]:
        _fill_row(rast, starts, front, other, horizontal, row)


@cuda.jit
def _walk(xyw, tri, neighbour, opposite, front, other, start_tri, height, width, window, hit_tri, hit_edge):
    """Thread per pixel pair: :func:`.antialias_kernels.walk_pair`."""
    m = cuda.grid(1)
    if m < front.shape[0]:
        top, left, frame_height, frame_width = window
        _walk_pair(xyw, tri, neighbour, opposite, front, other, start_tri, height, width, top, left, frame_height,
                   frame_width, hit_tri, hit_edge, m)


def outline_crossings(rast: torch.Tensor, xyw: torch.Tensor, tri: torch.Tensor, neighbour: torch.Tensor,
                      opposite: torch.Tensor, window: Window | None = None):
    """:func:`.antialias_kernels.outline_crossings` on the tensors' GPU: ``rast [B, H, W, 4]``,
    ``xyw [B, V, 3]`` float64, ``tri``, ``neighbour``, ``opposite [T, 3]`` int64 (moved to
    ``rast``'s device). Returns ``(front [M], other [M], horizontal [M], edge_tri [M], edge
    [M])`` as there, in the same order, on that device."""
    device = rast.device
    tri, neighbour, opposite = (t.to(device=device, dtype=torch.int64).contiguous() for t in (tri, neighbour, opposite))
    n_views, height, width = rast.shape[:3]
    counts = torch.empty(n_views * height, dtype=torch.int64, device=device)
    launch(_count_pairs, counts.shape[0], rast, counts)
    starts = torch.cumsum(counts, 0) - counts
    total = int(counts.sum())
    front = torch.empty(total, dtype=torch.int64, device=device)
    other = torch.empty(total, dtype=torch.int64, device=device)
    horizontal = torch.empty(total, dtype=torch.bool, device=device)
    launch(_fill_pairs, starts.shape[0], rast, starts, front, other, horizontal)
    start_tri = rast.reshape(-1, 4)[front, 3].long() - 1
    hit_tri = torch.empty(total, dtype=torch.int64, device=device)
    hit_edge = torch.empty(total, dtype=torch.int64, device=device)
    frame = Window.whole(height, width) if window is None else window
    launch(_walk, total, xyw, tri, neighbour, opposite, front, other, start_tri, height, width,
           (frame.top, frame.left, frame.frame_height, frame.frame_width), hit_tri, hit_edge)
    hit = hit_edge >= 0
    return front[hit], other[hit], horizontal[hit], hit_tri[hit], hit_edge[hit]
