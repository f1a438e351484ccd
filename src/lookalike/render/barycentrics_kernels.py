"""Compiled per-pixel loops of rasterize's barycentrics, forward and hand-written backward.

The plain-torch twin is :func:`.barycentrics.barycentrics_python`; tests compare values and
gradients.  Pixels are walked row by row in parallel (``prange``) in the forward pass; the
backward pass accumulates into per-view gradient buffers, so it runs in parallel over views.
Each loop runs a per-element body (``barycentrics_pixel``, ``barycentrics_backward_pixel``,
``triangle_coefficients_one``, ``shown_triangle``) that the CUDA forms
(:mod:`.barycentrics_cuda`) run too, one thread per element.
Pixel ``(ix, iy)`` has its centre at NDC ``((2 ix + 1)/W - 1, (2 iy + 1)/H - 1)``.
"""

from __future__ import annotations

from numba import njit, prange

from ..kernel_cache import CACHE
from ..kernel_scatter import scatter_add


@njit(cache=CACHE, inline="always")
def _barycentrics(coef, window, b, t, iy, ix):
    """``(px, py, kx, ky, S, u, v)`` of triangle ``t`` of view ``b`` at pixel ``(iy, ix)``: its
    centre in the frame's NDC, ``(kx, ky) = (2 / frame_width, 2 / frame_height)``, ``S = s.p``,
    ``u = c_0.p / S`` and ``v = c_1.p / S``."""
    top, left, frame_height, frame_width = window
    px = (2 * (left + ix) + 1) / frame_width - 1.0
    py = (2 * (top + iy) + 1) / frame_height - 1.0
    s = coef[b, t, 6] * px + coef[b, t, 7] * py + coef[b, t, 8]
    u = (coef[b, t, 0] * px + coef[b, t, 1] * py + coef[b, t, 2]) / s
    v = (coef[b, t, 3] * px + coef[b, t, 4] * py + coef[b, t, 5]) / s
    return px, py, 2.0 / frame_width, 2.0 / frame_height, s, u, v


@njit(cache=CACHE, parallel=True)
def barycentrics_forward(coef, tri_id, depth, window, rast, rast_db):
    """Fill ``rast [B,H,W,4] = (u, v, z/w, id)`` and ``rast_db [B,H,W,4]``, the images being
    rows ``top ..`` and columns ``left ..`` of a ``frame_height x frame_width`` frame, ``window =
    (top, left, frame_height, frame_width)``, whose pixel centres and size they use.

    ``coef [B, T, 9]`` holds per triangle ``(c_0, c_1, s)`` with ``c_i = v_j x v_k`` and
    ``s = c_0 + c_1 + c_2`` (``v = (x, y, w)``); at ``p = (px, py, 1)``: ``u = c_0.p / s.p``,
    ``v = c_1.p / s.p``, ``du/dX = (2/W)(c_0x - u s_x) / s.p`` and likewise for the others.
    ``tri_id [B,H,W]`` int32 (triangle + 1, 0 = none), ``depth [B,H,W]`` float32.
    """
    n_views, height, width = tri_id.shape
    for row in prange(n_views * height):
        b, iy = row // height, row % height
        for ix in range(width):
            barycentrics_pixel(coef, tri_id, depth, window, rast, rast_db, b, iy, ix)


@njit(cache=CACHE, inline="always")
def barycentrics_pixel(coef, tri_id, depth, window, rast, rast_db, b, iy, ix):
    """Pixel ``(b, iy, ix)`` of :func:`barycentrics_forward` (both its CPU and its CUDA form):
    its rows of ``rast`` and ``rast_db``."""
    t = tri_id[b, iy, ix] - 1
    if t < 0:
        for k in range(4):
            rast[b, iy, ix, k] = 0.0
            rast_db[b, iy, ix, k] = 0.0
        return
    px, py, kx, ky, s, u, v = _barycentrics(coef, window, b, t, iy, ix)
    rast[b, iy, ix, 0] = u
    rast[b, iy, ix, 1] = v
    rast[b, iy, ix, 2] = depth[b, iy, ix]
    rast[b, iy, ix, 3] = t + 1
    rast_db[b, iy, ix, 0] = (coef[b, t, 0] - u * coef[b, t, 6]) / s * kx
    rast_db[b, iy, ix, 1] = (coef[b, t, 1] - u * coef[b, t, 7]) / s * ky
    rast_db[b, iy, ix, 2] = (coef[b, t, 3] - v * coef[b, t, 6]) / s * kx
    rast_db[b, iy, ix, 3] = (coef[b, t, 4] - v * coef[b, t, 7]) / s * ky


@njit(cache=CACHE, parallel=True)
def barycentrics_backward(coef, tri_id, window, grad_rast, grad_db, use_db, grad_coef):
    """Accumulate into ``grad_coef [B, T, 9]`` (zeroed) the gradient of
    :func:`barycentrics_forward` given ``grad_rast [B,H,W,4]`` (channels 0, 1 used) and
    ``grad_db [B,H,W,4]`` (used when ``use_db``); ``window`` as there.

    Per pixel, with ``S = s.p``: the db terms give direct gradients to ``c_0x, c_0y, c_1x,
    c_1y`` (``k/S``), to ``s_x, s_y`` (``-k u/S``, ``-k v/S``) and to ``S`` and ``u, v``;
    then ``u = c_0.p / S`` sends ``g_u p / S`` to ``c_0`` and ``-g_u u / S`` to ``S``, and
    ``S = s.p`` sends ``g_S p`` to ``s``.
    """
    n_views, height, width = tri_id.shape
    for b in prange(n_views):
        for iy in range(height):
            for ix in range(width):
                barycentrics_backward_pixel(coef, tri_id, window, grad_rast, grad_db, use_db, grad_coef, b, iy, ix)


@njit(cache=CACHE, inline="always")
def barycentrics_backward_pixel(coef, tri_id, window, grad_rast, grad_db, use_db, grad_coef, b, iy, ix):
    """Pixel ``(b, iy, ix)`` of :func:`barycentrics_backward` (both its CPU and its CUDA form):
    its gradients added into its triangle's row of ``grad_coef`` (``scatter_add``)."""
    t = tri_id[b, iy, ix] - 1
    if t < 0:
        return
    px, py, kx, ky, s, u, v = _barycentrics(coef, window, b, t, iy, ix)
    g_u = grad_rast[b, iy, ix, 0]
    g_v = grad_rast[b, iy, ix, 1]
    g_s = 0.0
    if use_db:
        gux, guy = grad_db[b, iy, ix, 0] * kx, grad_db[b, iy, ix, 1] * ky
        gvx, gvy = grad_db[b, iy, ix, 2] * kx, grad_db[b, iy, ix, 3] * ky
        sx, sy = coef[b, t, 6], coef[b, t, 7]
        dudx_s = coef[b, t, 0] - u * sx  # S * du/dX / kx, etc.
        dudy_s = coef[b, t, 1] - u * sy
        dvdx_s = coef[b, t, 3] - v * sx
        dvdy_s = coef[b, t, 4] - v * sy
        scatter_add(grad_coef, (b, t, 0), gux / s)
        scatter_add(grad_coef, (b, t, 1), guy / s)
        scatter_add(grad_coef, (b, t, 3), gvx / s)
        scatter_add(grad_coef, (b, t, 4), gvy / s)
        scatter_add(grad_coef, (b, t, 6), -((gux * u + gvx * v) / s))
        scatter_add(grad_coef, (b, t, 7), -((guy * u + gvy * v) / s))
        g_u -= (gux * sx + guy * sy) / s
        g_v -= (gvx * sx + gvy * sy) / s
        g_s -= (gux * dudx_s + guy * dudy_s + gvx * dvdx_s + gvy * dvdy_s) / (s * s)
    g_s -= (g_u * u + g_v * v) / s
    g_e0 = g_u / s
    g_e1 = g_v / s
    scatter_add(grad_coef, (b, t, 0), g_e0 * px)
    scatter_add(grad_coef, (b, t, 1), g_e0 * py)
    scatter_add(grad_coef, (b, t, 2), g_e0)
    scatter_add(grad_coef, (b, t, 3), g_e1 * px)
    scatter_add(grad_coef, (b, t, 4), g_e1 * py)
    scatter_add(grad_coef, (b, t, 5), g_e1)
    scatter_add(grad_coef, (b, t, 6), g_s * px)
    scatter_add(grad_coef, (b, t, 7), g_s * py)
    scatter_add(grad_coef, (b, t, 8), g_s)


@njit(cache=CACHE, parallel=True)
def triangle_coefficients_forward(xyw, tri, shown, coef):
    """Fill ``coef [B, T, 9]`` with ``(c_0, c_1, c_0 + c_1 + c_2)``, ``c_i = v_j x v_k``
    (``(i, j, k)`` cyclic) of the vertices ``v = xyw[b, tri[t]]`` (``(x, y, w)``, ``xyw [B, V, 3]``,
    ``tri [T, 3]`` int64) where ``shown [B, T]`` bool, leaving the other rows as they are:
    :func:`.barycentrics.triangle_coefficients` without its ``[B, T, 3, 3]`` temporaries, in
    parallel over views and triangles."""
    n_tris = tri.shape[0]
    for job in prange(xyw.shape[0] * n_tris):
        triangle_coefficients_one(xyw, tri, shown, coef, job // n_tris, job % n_tris)


@njit(cache=CACHE, inline="always")
def triangle_coefficients_one(xyw, tri, shown, coef, b, t):
    """Triangle ``t`` of view ``b`` in :func:`triangle_coefficients_forward` (both its CPU and
    its CUDA form): ``coef[b, t]`` where it is shown."""
    if not shown[b, t]:
        return
    for k in range(9):
        coef[b, t, k] = 0.0
    for i in range(3):
        vj, vk = xyw[b, tri[t, (i + 1) % 3]], xyw[b, tri[t, (i + 2) % 3]]
        cx = vj[1] * vk[2] - vj[2] * vk[1]
        cy = vj[2] * vk[0] - vj[0] * vk[2]
        cw = vj[0] * vk[1] - vj[1] * vk[0]
        if i < 2:
            coef[b, t, 3 * i] = cx
            coef[b, t, 3 * i + 1] = cy
            coef[b, t, 3 * i + 2] = cw
        coef[b, t, 6] += cx
        coef[b, t, 7] += cy
        coef[b, t, 8] += cw


@njit(cache=CACHE, parallel=True)
def shown_triangles(tri_id, shown):
    """Set ``shown[b, t]`` (``[B, T]`` bool, cleared by the caller) for every triangle ``t``
    that a pixel of view ``b`` shows (``tri_id [B, H, W]`` int32, triangle + 1, 0 = none)."""
    for b in prange(tri_id.shape[0]):
        for y in range(tri_id.shape[1]):
            for x in range(tri_id.shape[2]):
                shown_triangle(tri_id, shown, b, y, x)


@njit(cache=CACHE, inline="always")
def shown_triangle(tri_id, shown, b, y, x):
    """Pixel ``(b, y, x)`` of :func:`shown_triangles` (both its CPU and its CUDA form; every
    writer writes True)."""
    if tri_id[b, y, x] > 0:
        shown[b, tri_id[b, y, x] - 1] = True
