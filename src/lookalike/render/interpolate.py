"""``interpolate``: vertex attributes at pixels, with their screen-space derivatives."""

from __future__ import annotations

import torch

from .pixels import covered_pixels, scatter_to_image


def interpolate(
    attr: torch.Tensor,
    rast: torch.Tensor,
    tri: torch.Tensor,
    rast_db: torch.Tensor | None = None,
    diff_attrs: str | list[int] | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Interpolate per-vertex attributes (nvdiffrast's ``dr.interpolate``).

    Args:
        attr: ``[B, V, C]`` (one set per view), ``[1, V, C]`` or ``[V, C]`` (shared).
        rast: ``[B, H, W, 4]`` output of :func:`rasterize`.
        tri: ``[T, 3]`` int32/int64, the triangles given to ``rasterize`` (its own
            attribute index buffer may differ, e.g. UV seams, as long as ``T`` agrees).
        rast_db: ``[B, H, W, 4]`` derivatives from ``rasterize``; needed with ``diff_attrs``.
        diff_attrs: ``"all"`` or a list of channel indices whose derivatives to return.

    Returns:
        ``out [B, H, W, C] = u a_0 + v a_1 + (1 - u - v) a_2`` with ``a_k`` the attribute of
        vertex ``k`` of the pixel's triangle, zero on background; and ``out_da [B, H, W, 2D]``
        = ``(dA/dX, dA/dY)`` in pixel units for each of the ``D`` selected channels in order
        (``dA/dX = (a_0 - a_2) du/dX + (a_1 - a_2) dv/dX``), or ``[B, H, W, 0]`` when
        ``diff_attrs`` is None.  Gradients flow to ``attr``, ``rast[..., 0:2]`` and ``rast_db``.
    """
    if attr.dim() == 2:
        attr = attr[None]
    if attr.dim() != 3:
        raise ValueError(f"attr must have shape [B, V, C] or [V, C], got {tuple(attr.shape)}")
    if rast.dim() != 4 or rast.shape[-1] != 4:
        raise ValueError(f"rast must have shape [B, H, W, 4], got {tuple(rast.shape)}")
    n_views, height, width = rast.shape[:3]
    if attr.shape[0] not in (1, n_views):
        raise ValueError(f"attr has {attr.shape[0]} views, rast has {n_views}")
    n_attr_views, n_verts, n_channels = attr.shape
    tri = tri.long()
    flat_pixel, tri_idx = covered_pixels(rast)
    view = flat_pixel // (height * width)
    vertex = tri.index_select(0, tri_idx)  # [N, 3]
    if n_attr_views > 1:
        vertex = vertex + (view * n_verts)[:, None]
    a = attr.reshape(-1, n_channels).index_select(0, vertex.reshape(-1)).reshape(-1, 3, n_channels)
    uv = rast.reshape(-1, 4)[:, :2].index_select(0, flat_pixel)
    da_du = a[:, 0] - a[:, 2]
    da_dv = a[:, 1] - a[:, 2]
    out = a[:, 2] + uv[:, :1] * da_du + uv[:, 1:] * da_dv
    image_shape = (n_views, height, width)
    out_image = scatter_to_image(out, flat_pixel, image_shape)
    if diff_attrs is None:
        return out_image, out_image.new_zeros(*image_shape, 0)
    if rast_db is None:
        raise ValueError("diff_attrs needs rast_db")
    channels = list(range(n_channels)) if diff_attrs == "all" else [int(c) for c in diff_attrs]
    db = rast_db.reshape(-1, 4).index_select(0, flat_pixel)  # du/dX, du/dY, dv/dX, dv/dY
    du, dv = da_du[:, channels], da_dv[:, channels]
    d_dx = du * db[:, 0:1] + dv * db[:, 2:3]
    d_dy = du * db[:, 1:2] + dv * db[:, 3:4]
    out_da = torch.stack([d_dx, d_dy], -1).reshape(-1, 2 * len(channels))
    return out_image, scatter_to_image(out_da, flat_pixel, image_shape)
