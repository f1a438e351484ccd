"""``antialias``: analytic antialiasing of silhouette edges (Laine et al. 2020), which gives
vertex positions gradients from coverage.

The search for the pixel pairs an outline runs between and the silhouette edge it crosses is
compiled (:mod:`.antialias_kernels`, :mod:`.antialias_cuda` for tensors on the GPU; no gradient
flows through it), with the plain-torch twins
:func:`neighbour_pairs_python` and :func:`outline_walk_python`; the blend is torch, so
autograd differentiates it."""

from __future__ import annotations

from dataclasses import dataclass

import torch

from ..devices import uses_cuda_kernels
from .antialias_kernels import MAX_WALK, outline_crossings
from .barycentrics import edge_coefficients, pixel_ndc, triangle_vertices_xyw
from .inputs import check_rast_ids, check_triangles
from .topology import EdgeTopology, antialias_construct_topology_hash
from .window import Window

__all__ = ["OutlineBlend", "antialias", "antialias_construct_topology_hash", "outline_blend"]


class _ScaleGradient(torch.autograd.Function):
    """Identity forward; backward multiplies the gradient by ``scale``."""

    @staticmethod
    def forward(ctx, x: torch.Tensor, scale: float) -> torch.Tensor:
        ctx.scale = scale
        return x.view_as(x)

    @staticmethod
    def backward(ctx, grad: torch.Tensor):
        return grad * ctx.scale, None


def silhouette_edges_python(pos: torch.Tensor, tri: torch.Tensor, opposite: torch.Tensor) -> torch.Tensor:
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


def neighbour_pairs_python(ids: torch.Tensor, depth: torch.Tensor):
    """Horizontally and vertically adjacent pixel pairs showing different triangles
    (plain-torch twin of the pair search in :func:`.antialias_kernels.outline_crossings`).

    ``ids [B, H, W]`` int64 (triangle + 1), ``depth [B, H, W]`` (z/w).  The *front* pixel
    of a pair is the nearer one (any triangle is in front of background).  Returns flat
    pixel indices ``(front [M], other [M])``, the front triangle's index ``[M]`` and
    whether the pair is horizontal ``[M]`` bool.
    """
    flat = torch.arange(ids.numel()).reshape(ids.shape)
    fronts, others, tris, horizontal = [], [], [], []
    everything = slice(None)
    for is_horizontal, slice_a, slice_b in (
        (False, (everything, slice(0, -1), everything), (everything, slice(1, None), everything)),
        (True, (everything, everything, slice(0, -1)), (everything, everything, slice(1, None))),
    ):
        id_a, id_b = ids[slice_a], ids[slice_b]
        a_in_front = (id_a > 0) & ((id_b == 0) | (depth[slice_a] < depth[slice_b]))
        pick = torch.nonzero((id_a != id_b).reshape(-1)).squeeze(1)
        pa = flat[slice_a].reshape(-1).index_select(0, pick)
        pb = flat[slice_b].reshape(-1).index_select(0, pick)
        a_front = a_in_front.reshape(-1).index_select(0, pick)
        fronts.append(torch.where(a_front, pa, pb))
        others.append(torch.where(a_front, pb, pa))
        tris.append(torch.where(a_front, id_a.reshape(-1)[pick], id_b.reshape(-1)[pick]) - 1)
        horizontal.append(torch.full_like(pick, is_horizontal, dtype=torch.bool))
    return torch.cat(fronts), torch.cat(others), torch.cat(tris), torch.cat(horizontal)


def outline_walk_python(
    pos: torch.Tensor,
    tri: torch.Tensor,
    neighbour: torch.Tensor,
    silhouette: torch.Tensor,
    front: torch.Tensor,
    other: torch.Tensor,
    start_tri: torch.Tensor,
    height: int,
    width: int,
    window: Window | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """The silhouette edge between each pixel pair (plain-torch twin of the walk in
    :func:`.antialias_kernels.outline_crossings`, same rule, all pairs stepped together).

    Args:
        pos: ``[B, V, 4]`` clip-space positions (used in float64).
        tri, neighbour: ``[T, 3]`` int64 (``neighbour`` from ``EdgeTopology``).
        silhouette: ``[B, T, 3]`` bool.
        front, other, start_tri: ``[M]`` int64 from :func:`neighbour_pairs_python`.
        height, width: image size.
        window: the window of a larger frame the images are (``None``: the whole frame).

    Returns:
        ``(edge_tri [M], edge [M])`` int64, -1 where the pair has no outline between it.
    """
    pos = pos.detach().double()
    view = front // (height * width)
    p_front = pixel_ndc(front, height, width, torch.float64, window)[:, None]  # [M, 1, 3]
    p_other = pixel_ndc(other, height, width, torch.float64, window)[:, None]
    t, entry, s_in = start_tri.clone(), torch.full_like(front, -1), torch.zeros(front.shape, dtype=torch.float64)
    walking = torch.ones_like(front, dtype=torch.bool)
    edge_tri, edge = torch.full_like(front, -1), torch.full_like(front, -1)
    corners = torch.arange(3)
    for _ in range(MAX_WALK):
        verts = triangle_vertices_xyw(pos, tri, view, t)
        c = edge_coefficients(verts[:, 0], verts[:, 1], verts[:, 2])  # [M, 3 edges, 3]
        e_front, e_other = (c * p_front).sum(-1), (c * p_other).sum(-1)
        crossing = e_front / (e_front - e_other)
        allowed = (e_front != e_other) & (crossing > s_in[:, None]) & (corners != entry[:, None])
        s_out, k = torch.where(allowed, crossing, torch.inf).min(1)
        walking &= s_out <= 1.0
        found = walking & silhouette[view, t, k]
        edge_tri, edge = torch.where(found, t, edge_tri), torch.where(found, k, edge)
        walking &= ~found
        shared = tri[t[:, None], (k[:, None] + corners[None, 1:]) % 3]  # [M, 2]
        t = torch.where(walking, neighbour[t, k], t)
        off_edge = (tri[t][:, :, None] != shared[:, None, :]).all(-1)  # [M, 3]: the far vertex
        entry = torch.where(walking, off_edge.int().argmax(1), entry)
        s_in = torch.where(walking, s_out, s_in)
    return edge_tri, edge


@dataclass
class OutlineBlend:
    """What ``antialias`` does to an image, once the geometry is known: a linear map of the
    colours (weights differentiable in the positions). ``K`` blends into ``U`` pixels:

        C'_p = (1 - sum_s w_s) C_p + sum_s w_s C_s   for the blended pixels p,

    every other pixel unchanged.

    Attributes:
        blended: ``[U]`` int64 flat pixel indices into ``[B, H, W]``.
        slot: ``[K]`` int64 index into ``blended`` of each blend's target.
        source: ``[K]`` int64 flat pixel index of each blend's source.
        weight: ``[K, 1]`` ``w_s`` (normalised so a pixel's weights sum to at most 1).
        own_share: ``[U, 1]`` ``1 - sum_s w_s`` of each blended pixel.
    """

    blended: torch.Tensor
    slot: torch.Tensor
    source: torch.Tensor
    weight: torch.Tensor
    own_share: torch.Tensor

    def apply(self, color: torch.Tensor) -> torch.Tensor:
        """``color [B, H, W, C]`` (the shape it was found for) blended: ``[B, H, W, C]``."""
        flat_color = color.reshape(-1, color.shape[-1])
        own = flat_color.index_select(0, self.blended) * self.own_share
        mixed = own.index_add(0, self.slot, self.weight * flat_color.index_select(0, self.source))  # [U, C]
        return flat_color.index_copy(0, self.blended, mixed).reshape(color.shape)


def antialias(
    color: torch.Tensor,
    rast: torch.Tensor,
    pos: torch.Tensor,
    tri: torch.Tensor,
    topology_hash: EdgeTopology | None = None,
    pos_gradient_boost: float = 1.0,
    window: Window | None = None,
) -> torch.Tensor:
    """Blend pixel colours across silhouette edges by analytic coverage (nvdiffrast's
    ``dr.antialias``, extended to outlines made of sub-pixel triangles):
    ``outline_blend(rast, pos, tri, ...).apply(color)``.

    Args:
        color: ``[B, H, W, C]`` shaded image.
        rast: ``[B, H, W, 4]`` from :func:`rasterize` with the same ``pos`` and ``tri``.
        pos: ``[B, V, 4]`` (or ``[V, 4]`` in range mode) clip-space positions.
        tri: ``[T, 3]`` int32/int64.
        topology_hash: from :func:`antialias_construct_topology_hash` (built if None).
        pos_gradient_boost: factor on the gradient to ``pos``.
        window: where ``color`` and ``rast`` are a ``Window`` of a larger frame (an extension
            of nvdiffrast's contract): pixel centres are the frame's. The result equals that
            window of the frame's antialiased image when no pixel within one of the window's
            border is covered (``covered_window`` leaves such a margin).

    Returns:
        ``[B, H, W, C]`` antialiased colour.
    """
    if color.dim() != 4 or rast.shape[:3] != color.shape[:3]:
        raise ValueError(f"color must be [B, H, W, C] matching rast {tuple(rast.shape)}, got {tuple(color.shape)}")
    return outline_blend(rast, pos, tri, topology_hash, pos_gradient_boost, window).apply(color)


def outline_blend(
    rast: torch.Tensor,
    pos: torch.Tensor,
    tri: torch.Tensor,
    topology_hash: EdgeTopology | None = None,
    pos_gradient_boost: float = 1.0,
    window: Window | None = None,
) -> OutlineBlend:
    """The blend ``antialias`` applies to images rasterized as ``rast`` (see ``OutlineBlend``).

    For every horizontally or vertically adjacent pixel pair whose triangle ids differ, the
    segment from the nearer (*front*) pixel centre ``P_f`` to the other, ``P_o``, is
    followed across interior edges until it crosses a silhouette edge (see
    :func:`silhouette_edges_python` and :func:`.antialias_kernels.outline_crossings`), at
    ``alpha = e(P_f) / (e(P_f) - e(P_o))`` with that edge's function ``e``.  nvdiffrast
    looks at the front triangle's own edges only, which misses most of the outline of a
    finely tessellated mesh, whose silhouette triangles are grazing slivers.

    The pixel on whose side of the midpoint the edge crosses is blended with its neighbour:
    for ``alpha < 1/2`` ``C_f += (1/2 - alpha)(C_o - C_f)``, else ``C_o += (alpha - 1/2)
    (C_f - C_o)``.  All blends use the input colours and add up: a pixel ``p`` blended with
    sources ``s`` at weights ``w_s`` becomes ``(1 - sum w_s) C_p + sum w_s C_s``.  Where the
    weights sum past 1 (a sub-pixel piece of surface, its outline crossing the pixel on
    several sides) they are scaled to sum to 1, so the pixel stays a mix of its neighbours'
    colours, computed as a sum of non-negative terms.  Each
    edge is handled only by the pairs running across it, horizontal pairs for edges closer to
    vertical and vertical pairs otherwise, so no coverage is counted twice.

    ``alpha`` depends on the edge's two vertices only, so gradients reach their ``x, y, w``
    (scaled by ``pos_gradient_boost``); interior edges, whose neighbour continues the surface,
    give no position gradient. ``window``: see ``antialias``.
    """
    n_views, height, width = rast.shape[:3]
    views = pos if pos.dim() == 3 else pos.expand(n_views, -1, -1)
    if views.shape[0] != n_views:
        raise ValueError(f"pos has {views.shape[0]} views, rast has {n_views}")
    tri = check_triangles(tri, views.shape[1])
    check_rast_ids(rast, tri.shape[0])
    topology = antialias_construct_topology_hash(tri) if topology_hash is None else topology_hash
    if pos_gradient_boost != 1.0:
        views = _ScaleGradient.apply(views, pos_gradient_boost)

    arrays = (rast.detach().contiguous(), views.detach()[..., [0, 1, 3]].double().contiguous(), tri,
              topology.neighbour, topology.opposite)
    if uses_cuda_kernels(rast):
        from . import antialias_cuda

        crossings = antialias_cuda.outline_crossings(*arrays, window)
    else:
        crossings = (torch.from_numpy(a) for a in outline_crossings(*(a.numpy() for a in arrays), window))
    front, other, horizontal, edge_tri, edge = crossings
    verts = triangle_vertices_xyw(views, tri.to(front.device), front // (height * width), edge_tri)  # [M, 3, 3]
    c = edge_coefficients(*verts.unbind(1))[torch.arange(edge.shape[0], device=edge.device), edge]  # the edge's, [M, 3]
    # an edge is handled by the pairs running across it: horizontal pairs for edges closer
    # to vertical (normal (c.x / W, c.y / H) in pixel units mostly along x), vertical otherwise
    frame = Window.whole(height, width) if window is None else window
    normal = c.detach()[:, :2].abs()
    keep = (normal[:, 0] / frame.frame_width >= normal[:, 1] / frame.frame_height) == horizontal
    front, other, c = front[keep], other[keep], c[keep]
    e_front = (c * pixel_ndc(front, height, width, c.dtype, window)).sum(-1)
    e_other = (c * pixel_ndc(other, height, width, c.dtype, window)).sum(-1)
    span = e_front - e_other
    alpha = (e_front / torch.where(span == 0, torch.ones_like(span), span)).clamp(0.0, 1.0)[:, None]  # [K, 1]

    into_front = alpha[:, 0] < 0.5
    target = torch.where(into_front, front, other)
    source = torch.where(into_front, other, front)
    weight = (0.5 - alpha).abs()  # [K, 1]
    blended, slot = torch.unique(target, return_inverse=True)  # [U] pixels, [K] -> index into them
    total = weight.new_zeros(blended.shape[0], 1).index_add(0, slot, weight)  # [U, 1]
    weight = weight / total.clamp_min(1.0).index_select(0, slot)
    return OutlineBlend(blended=blended, slot=slot, source=source, weight=weight,
                        own_share=(1.0 - total).clamp_min(0.0))
