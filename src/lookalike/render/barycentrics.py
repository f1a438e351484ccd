"""Differentiable perspective-correct barycentrics of known triangles at pixel centres.

Given which triangle covers a pixel (from the visibility kernel), the barycentrics are a
smooth function of that triangle's clip-space vertices, so gradients reach ``x, y, w``.

With ``v_i = (x_i, y_i, w_i)`` and the pixel centre ``p = (px, py, 1)`` in NDC
(``px = (2 ix + 1) / W - 1``, ``py = (2 iy + 1) / H - 1``), the homogeneous edge functions are
``e_i = c_i . p`` with ``c_i = v_j x v_k`` (``(i, j, k)`` cyclic) and the perspective-correct
barycentrics are ``b_i = e_i / S`` with ``S = e_0 + e_1 + e_2``.  nvdiffrast reports
``u = b_0``, ``v = b_1`` (vertex 2 gets ``1 - u - v``).

Their screen-space derivatives in pixel units (``X``, ``Y`` = pixel index along x, y):
``db_i/dX = (2 / W) (c_i.x S - e_i S_x) / S^2`` with ``S_x = sum_i c_i.x``, likewise for ``Y``
with the ``y`` components and ``2 / H``.

:func:`pixel_barycentrics` computes them on whole images with compiled loops
(:mod:`.barycentrics_kernels`) from per-triangle coefficients (by torch where positions take
gradients, by a compiled loop where they do not), with a hand-written backward;
:func:`barycentrics_python` is its plain-torch twin at given points, which the tests compare
it with.
"""

from __future__ import annotations

import torch

from ..devices import launch, uses_cuda_kernels
from . import barycentrics_kernels
from .window import Window


def edge_coefficients(v0: torch.Tensor, v1: torch.Tensor, v2: torch.Tensor) -> torch.Tensor:
    """``[..., 3 edges, 3]``: ``c_i = v_j x v_k`` for vertices ``v_* [..., 3] = (x, y, w)``;
    edge function ``i`` (zero on the edge opposite vertex ``i``) is ``c_i . (px, py, 1)``."""
    return torch.stack([torch.cross(v1, v2, dim=-1), torch.cross(v2, v0, dim=-1), torch.cross(v0, v1, dim=-1)], -2)


def pixel_ndc(flat_pixel: torch.Tensor, height: int, width: int, dtype: torch.dtype,
              window: Window | None = None) -> torch.Tensor:
    """``[N, 3]`` homogeneous NDC pixel centres ``(px, py, 1)`` of flat pixel indices
    ``flat_pixel [N]`` int64 into ``[B, H, W]`` images; where those images are ``window`` of a
    larger frame, the centres are the frame's pixels'."""
    ix = flat_pixel % width
    iy = (flat_pixel // width) % height
    if window is not None:
        ix, iy = ix + window.left, iy + window.top
        height, width = window.frame_height, window.frame_width
    px = (2 * ix + 1).to(dtype) / width - 1
    py = (2 * iy + 1).to(dtype) / height - 1
    return torch.stack([px, py, torch.ones_like(px)], -1)


def triangle_vertices_xyw(pos: torch.Tensor, tri: torch.Tensor, view: torch.Tensor, tri_idx: torch.Tensor) -> torch.Tensor:
    """``[N, 3 vertices, 3]``: ``(x, y, w)`` of triangle ``tri_idx [N]`` in view ``view [N]``
    gathered from ``pos [B, V, 4]`` (``index_select``, whose backward is ``index_add_``)."""
    n_verts = pos.shape[1]
    vertex = tri.index_select(0, tri_idx) + (view * n_verts)[:, None]  # [N, 3]
    xyw = pos[..., [0, 1, 3]].reshape(-1, 3)
    return xyw.index_select(0, vertex.reshape(-1)).reshape(-1, 3, 3)


def barycentrics_python(
    pos: torch.Tensor,
    tri: torch.Tensor,
    view: torch.Tensor,
    tri_idx: torch.Tensor,
    p: torch.Tensor,
    resolution: tuple[int, int],
    with_db: bool = True,
) -> tuple[torch.Tensor, torch.Tensor | None]:
    """Barycentrics ``(u, v)`` and their pixel derivatives at given points.

    Args:
        pos: ``[B, V, 4]`` clip-space positions (float32 or float64; gradients flow to
            ``x, y, w``).
        tri: ``[T, 3]`` int64 vertex indices.
        view: ``[N]`` int64 view of each point.
        tri_idx: ``[N]`` int64 triangle of each point (not + 1).
        p: ``[N, 3]`` homogeneous NDC points ``(px, py, 1)`` (see :func:`pixel_ndc`).
        resolution: ``(H, W)``, the pixel size for the derivatives.
        with_db: also return the derivatives.

    Returns:
        ``(uv [N, 2], db [N, 4] or None)`` in ``pos.dtype``; ``db = (du/dX, du/dY, dv/dX,
        dv/dY)`` in pixel units.
    """
    height, width = resolution
    verts = triangle_vertices_xyw(pos, tri, view, tri_idx)
    c = edge_coefficients(verts[:, 0], verts[:, 1], verts[:, 2])  # [N, 3, 3]
    e = (c[:, :2] * p[:, None]).sum(-1)  # [N, 2]: e_0, e_1
    s = (c * p[:, None]).sum(-1).sum(-1)  # [N]
    inv_s = 1.0 / s
    uv = e * inv_s[:, None]
    if not with_db:
        return uv, None
    s_xy = c[..., :2].sum(1)  # [N, 2]: S_x, S_y
    scale = torch.tensor([2.0 / width, 2.0 / height], dtype=pos.dtype, device=pos.device)
    # d b_i / d(X, Y) for i = 0, 1: [N, 2 (i), 2 (X, Y)]
    db = (c[:, :2, :2] - uv[..., None] * s_xy[:, None, :]) * (inv_s[:, None, None] * scale)
    return uv, db.reshape(-1, 4)


def triangle_coefficients(pos: torch.Tensor, tri: torch.Tensor) -> torch.Tensor:
    """``[B, T, 9]``: per view and triangle ``(c_0, c_1, c_0 + c_1 + c_2)`` (each
    ``(x, y, w)`` components) of :func:`edge_coefficients`, from ``pos [B, V, 4]`` and
    ``tri [T, 3]`` int64; differentiable in ``pos``."""
    xyw = pos[..., [0, 1, 3]]
    verts = xyw[:, tri]  # [B, T, 3, 3]
    c = edge_coefficients(verts[:, :, 0], verts[:, :, 1], verts[:, :, 2])
    return torch.cat([c[:, :, 0], c[:, :, 1], c.sum(2)], -1)


def constant_triangle_coefficients(pos: torch.Tensor, tri: torch.Tensor, tri_id: torch.Tensor | None = None) -> torch.Tensor:
    """:func:`triangle_coefficients` of positions that take no gradient (a reference's), by a
    compiled loop (``barycentrics_kernels.triangle_coefficients_forward``, or its CUDA form):
    the torch version's ``[B, T, 3, 3]`` gathers were a fifth of a 4-million-triangle render.
    With ``tri_id [B, H, W]`` int32 (triangle + 1 per pixel), only the rows of triangles that
    a pixel shows are computed, the others are zero: a 4-million-triangle reference shows under
    a million at 1024 x 1024 samples."""
    xyw = pos.detach()[..., [0, 1, 3]].contiguous()
    n_views, n_tris = xyw.shape[0], tri.shape[0]
    tri = tri.contiguous()
    if tri_id is None:
        shown = torch.ones(n_views, n_tris, dtype=torch.bool, device=xyw.device)
        coef = xyw.new_empty(n_views, n_tris, 9)
    else:
        shown = torch.zeros(n_views, n_tris, dtype=torch.bool, device=xyw.device)
        coef = xyw.new_zeros(n_views, n_tris, 9)
    if uses_cuda_kernels(xyw):
        from . import barycentrics_cuda

        if tri_id is not None:
            launch(barycentrics_cuda.shown_triangles, tri_id.numel(), tri_id, shown)
        launch(barycentrics_cuda.triangle_coefficients_forward, n_views * n_tris, xyw, tri, shown, coef)
        return coef
    if tri_id is not None:
        barycentrics_kernels.shown_triangles(tri_id.numpy(), shown.numpy())
    barycentrics_kernels.triangle_coefficients_forward(xyw.numpy(), tri.numpy(), shown.numpy(), coef.numpy())
    return coef


class _PixelBarycentrics(torch.autograd.Function):
    """``(coef [B,T,9], tri_id [B,H,W] int32, depth [B,H,W] float32, window (top, left,
    frame_height, frame_width), use_db)`` -> ``(rast, rast_db)``; gradients reach ``coef``
    only. The compiled kernels, or their CUDA forms for tensors on the GPU."""

    @staticmethod
    def forward(ctx, coef, tri_id, depth, window, use_db):
        n_views, height, width = tri_id.shape
        rast = coef.new_empty(n_views, height, width, 4)
        rast_db = coef.new_empty(n_views, height, width, 4)
        coef_c = coef.detach().contiguous()
        if uses_cuda_kernels(coef):
            from . import barycentrics_cuda

            launch(barycentrics_cuda.barycentrics_forward, tri_id.numel(), coef_c, tri_id, depth, window, rast, rast_db)
        else:
            barycentrics_kernels.barycentrics_forward(coef_c.numpy(), tri_id.numpy(), depth.numpy(), window,
                                                      rast.numpy(), rast_db.numpy())
        ctx.save_for_backward(coef, tri_id)
        ctx.window = window
        ctx.use_db = use_db
        if not use_db:
            ctx.mark_non_differentiable(rast_db)
        return rast, rast_db

    @staticmethod
    def backward(ctx, grad_rast, grad_db):
        coef, tri_id = ctx.saved_tensors
        grad_coef = torch.zeros_like(coef)
        shape = (*tri_id.shape, 4)
        grad_rast = coef.new_zeros(shape) if grad_rast is None else grad_rast.contiguous()
        use_db = ctx.use_db and grad_db is not None
        grad_db = grad_rast if not use_db else grad_db.contiguous()
        coef_c = coef.detach().contiguous()
        if uses_cuda_kernels(coef):
            from . import barycentrics_cuda

            launch(barycentrics_cuda.barycentrics_backward, tri_id.numel(), coef_c, tri_id, ctx.window, grad_rast,
                   grad_db, use_db, grad_coef)
        else:
            barycentrics_kernels.barycentrics_backward(coef_c.numpy(), tri_id.numpy(), ctx.window, grad_rast.numpy(),
                                                       grad_db.numpy(), use_db, grad_coef.numpy())
        return grad_coef, None, None, None, None


def pixel_barycentrics(
    pos: torch.Tensor, tri: torch.Tensor, tri_id: torch.Tensor, depth: torch.Tensor, with_db_gradient: bool = True,
    window: Window | None = None,
) -> tuple[torch.Tensor, torch.Tensor]:
    """``rast [B,H,W,4] = (u, v, z/w, id)`` and ``rast_db [B,H,W,4]`` of whole images, or of
    the ``window`` of a larger frame that ``tri_id`` and ``depth`` are (pixel centres and
    derivatives then the frame's).

    Args:
        pos: ``[B, V, 4]`` clip-space positions (gradients flow to ``x, y, w``).
        tri: ``[T, 3]`` int64.
        tri_id: ``[B, H, W]`` int32, contiguous, triangle index + 1 (0 = background).
        depth: ``[B, H, W]`` float32, contiguous, copied into ``rast[..., 2]`` (no gradient).
        with_db_gradient: let gradients of ``rast_db`` flow back.
    """
    differentiable = torch.is_grad_enabled() and pos.requires_grad
    coef = triangle_coefficients(pos, tri) if differentiable else constant_triangle_coefficients(pos, tri, tri_id)
    frame = Window.whole(*tri_id.shape[1:]) if window is None else window
    return _PixelBarycentrics.apply(coef, tri_id, depth, (frame.top, frame.left, frame.frame_height, frame.frame_width),
                                    with_db_gradient)
