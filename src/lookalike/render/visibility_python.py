"""Slow, obviously-correct visibility in plain torch: :func:`visibility_python`, the twin the
compiled kernel :func:`.visibility.visible_triangles` is tested against.  Meant for small meshes and images only (memory is
``O(T * H * W)`` per chunk of triangles).

For every triangle and pixel centre ``p = (px, py, 1)`` (nvdiffrast's pixel centres, row 0
at ``y = -1``) it solves ``M b' = p`` with ``M = [v_0 v_1 v_2]``, ``v_i = (x_i, y_i, w_i)``:
the point of the triangle's plane seen through the pixel is ``W p = M b`` with barycentrics
``b = b' / sum(b')`` and ``W = 1 / sum(b')``.  It is visible when ``b >= 0``, ``W > 0`` and
its depth ``z/w = (b . z) / (b . w)`` lies in ``[-1, 1]`` and exceeds ``min_depth``; the
nearest such triangle wins, the lower index on ties.
"""

from __future__ import annotations

import torch

from .window import Window

_CHUNK = 64


def pixel_centres(height: int, width: int, dtype=torch.float64) -> tuple[torch.Tensor, torch.Tensor]:
    """``(px [H,W], py [H,W])``: NDC coordinates of the pixel centres,
    ``px = (2 ix + 1) / W - 1``, ``py = (2 iy + 1) / H - 1`` (row 0 is ``y = -1``)."""
    py = (2 * torch.arange(height, dtype=dtype) + 1) / height - 1
    px = (2 * torch.arange(width, dtype=dtype) + 1) / width - 1
    return px.expand(height, width), py[:, None].expand(height, width)


def visibility_python(
    pos: torch.Tensor,
    tri: torch.Tensor,
    resolution: tuple[int, int],
    tri_range: torch.Tensor | None = None,
    min_depth: torch.Tensor | None = None,
    window: Window | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Same contract as :func:`.visibility.visible_triangles`, in torch.

    Args:
        pos: ``[B, V, 4]`` clip-space positions (any float dtype; computed in float64).
        tri: ``[T, 3]`` integer vertex indices.
        resolution: ``(H, W)``.
        tri_range: ``[B, 2]`` ``(first, count)`` per view, or None for all triangles.
        min_depth: ``[B, H, W]`` or None; keep only depths strictly greater.
        window: where given, the pixels outside it stay background.

    Returns:
        ``(tri_id [B,H,W] int32, depth [B,H,W] float32)``, triangle index + 1 (0 = none)
        and z/w (``+inf`` = none).
    """
    height, width = resolution
    n_views, n_tris = pos.shape[0], tri.shape[0]
    px, py = pixel_centres(height, width)
    p = torch.stack([px, py, torch.ones_like(px)], -1).reshape(-1, 3)  # [P, 3]
    tri = tri.long()
    tri_ids = torch.zeros(n_views, height * width, dtype=torch.int32)
    depths = torch.full((n_views, height * width), float("inf"), dtype=torch.float64)
    for b in range(n_views):
        first, count = (0, n_tris) if tri_range is None else (int(tri_range[b, 0]), int(tri_range[b, 1]))
        floor = None if min_depth is None else min_depth[b].reshape(-1).double()
        for start in range(first, first + count, _CHUNK):
            ids = torch.arange(start, min(start + _CHUNK, first + count))
            verts = pos[b].double()[tri[ids]]  # [t, 3 vertices, 4]
            m = verts[..., [0, 1, 3]].transpose(1, 2)  # [t, 3, 3], columns v_i
            solvable = torch.linalg.det(m) != 0
            m_inv = torch.linalg.inv(torch.where(solvable[:, None, None], m, torch.eye(3, dtype=m.dtype)))
            b_prime = torch.einsum("tij,pj->tpi", m_inv, p)  # [t, P, 3]
            total = b_prime.sum(-1)
            bary = b_prime / total[..., None]
            z = (bary * verts[:, None, :, 2]).sum(-1) / (bary * verts[:, None, :, 3]).sum(-1)
            visible = solvable[:, None] & (bary >= 0).all(-1) & (total > 0) & (z >= -1) & (z <= 1)
            if floor is not None:
                visible &= z.float() > floor.float()
            z = torch.where(visible, z, torch.inf)
            best, arg = z.min(0)  # first minimum = lowest index on ties
            better = best < depths[b]
            depths[b] = torch.where(better, best, depths[b])
            tri_ids[b] = torch.where(better, (ids[arg] + 1).int(), tri_ids[b])
    tri_ids, depths = tri_ids.reshape(n_views, height, width), depths.float().reshape(n_views, height, width)
    if window is not None:
        inside = torch.zeros(1, height, width, dtype=torch.bool)
        window.crop(inside).fill_(True)
        tri_ids, depths = torch.where(inside, tri_ids, 0), torch.where(inside, depths, torch.inf)
    return tri_ids, depths


def visible_layers_python(
    pos: torch.Tensor,
    tri: torch.Tensor,
    resolution: tuple[int, int],
    layers: int,
    tri_range: torch.Tensor | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Twin of :func:`.visibility.visible_layers` by its definition: ``layers`` passes of
    :func:`visibility_python`, each keeping only fragments strictly behind the previous pass's
    depth (depth peeling). Returns ``(tri_id [L,B,H,W] int32, depth [L,B,H,W] float32)``."""
    ids, depths, floor = [], [], None
    for _ in range(layers):
        tri_id, depth = visibility_python(pos, tri, resolution, tri_range, floor)
        ids.append(tri_id)
        depths.append(depth)
        floor = depth
    return torch.stack(ids), torch.stack(depths)
