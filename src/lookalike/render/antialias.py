"""``antialias``: analytic antialiasing of silhouette edges (Laine et al. 2020), which gives
vertex positions gradients from coverage."""

from __future__ import annotations

import torch

from .barycentrics import edge_coefficients, pixel_ndc, triangle_vertices_xyw
from .pair_kernels import silhouette_pair_candidates
from .topology import antialias_construct_topology_hash
from .views import check_rast_ids, check_triangles

__all__ = ["antialias", "antialias_construct_topology_hash"]


class _ScaleGradient(torch.autograd.Function):
    """Identity forward; backward multiplies the gradient by ``scale``."""

    @staticmethod
    def forward(ctx, x: torch.Tensor, scale: float) -> torch.Tensor:
        ctx.scale = scale
        return x.view_as(x)

    @staticmethod
    def backward(ctx, grad: torch.Tensor):
        return grad * ctx.scale, None


def silhouette_edges(pos: torch.Tensor, tri: torch.Tensor, opposite: torch.Tensor) -> torch.Tensor:
    """``[B, T, 3]`` bool: is edge ``k`` (opposite vertex ``k``) of triangle ``t`` a
    silhouette edge in view ``b``?

    It is when it has no neighbouring triangle (``opposite == -1``) or when the neighbour's
    far vertex ``d`` lies on the same side of the edge as the triangle's own vertex ``k``,
    i.e. the two triangles fold over each other on screen.  The side test is homogeneous:
    ``sign(c_k . v)`` with ``c_k = v_i x v_j`` over the edge's vertices ``(x, y, w)``; for
    vertex ``k`` itself ``c_k . v_k = det M``.  ``pos [B, V, 4]`` (no gradient is taken).
    """
    xyw = pos.detach()[..., [0, 1, 3]]  # [B, V, 3]
    verts = xyw[:, tri]  # [B, T, 3, 3]
    c = edge_coefficients(verts[:, :, 0], verts[:, :, 1], verts[:, :, 2])  # [B, T, 3, 3]
    own = (c[:, :, 0] * verts[:, :, 0]).sum(-1)  # det M, [B, T]
    far = xyw[:, opposite.clamp_min(0)]  # [B, T, 3, 3]
    other = (c * far).sum(-1)  # [B, T, 3]
    return (opposite < 0) | ((other > 0) == (own[..., None] > 0))


def neighbour_pairs_reference(ids: torch.Tensor, depth: torch.Tensor, has_silhouette: torch.Tensor):
    """Horizontally and vertically adjacent pixel pairs that may straddle a silhouette
    (plain-torch twin of :func:`.pair_kernels.silhouette_pair_candidates`).

    ``ids [B, H, W]`` int64 (triangle + 1), ``depth [B, H, W]`` (z/w), ``has_silhouette
    [B, T + 1]`` bool (column 0 = background, False).  A pair qualifies when the ids differ
    and the *front* triangle (the nearer one; any triangle is in front of background) has a
    silhouette edge.  Returns flat pixel indices ``(front [M], other [M])``, the front
    triangle's index ``[M]`` and whether the pair is horizontal ``[M]`` bool.
    """
    n_views, height, width = ids.shape
    flat = torch.arange(ids.numel()).reshape(ids.shape)
    fronts, others, tris, horizontal = [], [], [], []
    everything = slice(None)
    for is_horizontal, slice_a, slice_b in (
        (False, (everything, slice(0, -1), everything), (everything, slice(1, None), everything)),
        (True, (everything, everything, slice(0, -1)), (everything, everything, slice(1, None))),
    ):
        id_a, id_b = ids[slice_a], ids[slice_b]
        a_in_front = (id_a > 0) & ((id_b == 0) | (depth[slice_a] < depth[slice_b]))
        front_id = torch.where(a_in_front, id_a, id_b)
        view = torch.arange(n_views)[:, None, None]
        candidate = (id_a != id_b) & has_silhouette[view, front_id]
        pick = torch.nonzero(candidate.reshape(-1)).squeeze(1)
        pa = flat[slice_a].reshape(-1).index_select(0, pick)
        pb = flat[slice_b].reshape(-1).index_select(0, pick)
        a_front = a_in_front.reshape(-1).index_select(0, pick)
        fronts.append(torch.where(a_front, pa, pb))
        others.append(torch.where(a_front, pb, pa))
        tris.append(front_id.reshape(-1).index_select(0, pick) - 1)
        horizontal.append(torch.full_like(pick, is_horizontal, dtype=torch.bool))
    return torch.cat(fronts), torch.cat(others), torch.cat(tris), torch.cat(horizontal)


def antialias(
    color: torch.Tensor,
    rast: torch.Tensor,
    pos: torch.Tensor,
    tri: torch.Tensor,
    topology_hash: torch.Tensor | None = None,
    pos_gradient_boost: float = 1.0,
) -> torch.Tensor:
    """Blend pixel colours across silhouette edges by analytic coverage (nvdiffrast's
    ``dr.antialias``).

    For every horizontally or vertically adjacent pixel pair whose triangle ids differ, the
    nearer (*front*) triangle's centre pixel ``P_f`` is inside it and the other centre ``P_o``
    is not, so the segment ``P_f -> P_o`` leaves the triangle through one edge: the edge
    with the smallest crossing ``alpha = e(P_f) / (e(P_f) - e(P_o))`` among those whose edge
    function ``e`` is negative at ``P_o``.  If that edge is a silhouette edge (see
    :func:`silhouette_edges`), the pixel on whose side of the midpoint it crosses is
    blended with its neighbour: for ``alpha < 1/2`` ``C_f += (1/2 - alpha)(C_o - C_f)``,
    else ``C_o += (alpha - 1/2)(C_f - C_o)`` (all blends use the input colours and add up).
    Each edge is handled only by the pairs running across it, horizontal pairs for edges
    closer to vertical and vertical pairs otherwise, so no coverage is counted twice.
    ``alpha`` depends on the edge's two vertices only, so gradients reach their ``x, y, w``
    (scaled by ``pos_gradient_boost``) and the colours; interior edges, whose neighbour
    continues the surface, are left alone and give no position gradient.

    Args:
        color: ``[B, H, W, C]`` shaded image.
        rast: ``[B, H, W, 4]`` from :func:`rasterize` with the same ``pos`` and ``tri``.
        pos: ``[B, V, 4]`` (or ``[V, 4]`` in range mode) clip-space positions.
        tri: ``[T, 3]`` int32/int64.
        topology_hash: from :func:`antialias_construct_topology_hash` (built if None).
        pos_gradient_boost: factor on the gradient to ``pos``.

    Returns:
        ``[B, H, W, C]`` antialiased colour.
    """
    if color.dim() != 4 or rast.shape[:3] != color.shape[:3]:
        raise ValueError(f"color must be [B, H, W, C] matching rast {tuple(rast.shape)}, got {tuple(color.shape)}")
    n_views, height, width, n_channels = color.shape
    views = pos if pos.dim() == 3 else pos.expand(n_views, -1, -1)
    if views.shape[0] != n_views:
        raise ValueError(f"pos has {views.shape[0]} views, color has {n_views}")
    tri = check_triangles(tri, views.shape[1])
    check_rast_ids(rast, tri.shape[0])
    opposite = antialias_construct_topology_hash(tri) if topology_hash is None else topology_hash
    if pos_gradient_boost != 1.0:
        views = _ScaleGradient.apply(views, pos_gradient_boost)

    silhouette = silhouette_edges(views, tri, opposite)  # [B, T, 3]
    has_silhouette = torch.cat([silhouette.new_zeros(n_views, 1), silhouette.any(-1)], 1)
    pairs = silhouette_pair_candidates(rast.detach().contiguous().numpy(), has_silhouette.numpy())
    front, other, horizontal = (torch.from_numpy(a) for a in pairs)
    front_tri = rast.detach().reshape(-1, 4)[front, 3].long() - 1

    view = front // (height * width)
    verts = triangle_vertices_xyw(views, tri, view, front_tri)
    c = edge_coefficients(verts[:, 0], verts[:, 1], verts[:, 2])  # [M, 3 edges, 3]
    det_sign = torch.sign((c[:, 0] * verts[:, 0]).sum(-1)).detach()[:, None]
    e_front = (c * pixel_ndc(front, height, width, c.dtype)[:, None]).sum(-1) * det_sign  # [M, 3]
    e_other = (c * pixel_ndc(other, height, width, c.dtype)[:, None]).sum(-1) * det_sign
    exits = e_other.detach() < 0
    alpha_all = e_front / (e_front - e_other).where(exits, torch.ones_like(e_front))
    alpha_rank = torch.where(exits, alpha_all.detach(), torch.inf)
    edge = alpha_rank.argmin(1)
    # an edge is handled by the pairs running across it: horizontal pairs for edges closer
    # to vertical (normal (c.x / W, c.y / H) in pixel units mostly along x), vertical otherwise
    normal = c.detach().gather(1, edge[:, None, None].expand(-1, 1, 3))[:, 0, :2].abs()
    mostly_vertical = normal[:, 0] / width >= normal[:, 1] / height
    keep = exits.any(1) & silhouette[view, front_tri, edge] & (mostly_vertical == horizontal)
    front, other = front[keep], other[keep]
    alpha = alpha_all[keep].gather(1, edge[keep, None]).clamp(0.0, 1.0)  # [K, 1]

    flat_color = color.reshape(-1, n_channels)
    c_front = flat_color.index_select(0, front)
    c_other = flat_color.index_select(0, other)
    into_front = alpha < 0.5
    target = torch.where(into_front[:, 0], front, other)
    delta = torch.where(into_front, (0.5 - alpha) * (c_other - c_front), (alpha - 0.5) * (c_front - c_other))
    return flat_color.index_add(0, target, delta).reshape(color.shape)
