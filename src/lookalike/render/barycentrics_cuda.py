"""CUDA forms of rasterize's barycentric kernels (:mod:`.barycentrics_kernels`), the same formulas
on torch's CUDA tensors: one thread per pixel where the CPU forms walk pixels in ``prange``, one
per (view, triangle) for the coefficients, and atomic adds where the backward pass scatters into a
triangle's coefficients (the CPU form keeps one table per view instead). The plain-torch twin is
:func:`.barycentrics.barycentrics_python`.
"""

from __future__ import annotations

from numba import cuda


@cuda.jit(device=True)
def _pixel_ndc(job, height, width, window):
    """``(b, iy, ix, px, py)``: view, row and column of flat pixel ``job`` of ``[B, H, W]`` images
    that are rows ``top ..``, columns ``left ..`` of a ``frame_height x frame_width`` frame
    (``window = (top, left, frame_height, frame_width)``), and its centre in the frame's NDC."""
    top, left, frame_height, frame_width = window
    b, iy, ix = job // (height * width), (job // width) % height, job % width
    px = (2 * (left + ix) + 1) / frame_width - 1.0
    py = (2 * (top + iy) + 1) / frame_height - 1.0
    return b, iy, ix, px, py


@cuda.jit(device=True)
def _barycentrics(coef, b, t, px, py):
    """``(S, u, v)`` of triangle ``t`` of view ``b`` at NDC ``(px, py)``: ``S = s.p``, ``u = c_0.p
    / S``, ``v = c_1.p / S`` (``coef`` as :func:`.barycentrics_kernels.barycentrics_forward`'s)."""
    s = coef[b, t, 6] * px + coef[b, t, 7] * py + coef[b, t, 8]
    return s, (coef[b, t, 0] * px + coef[b, t, 1] * py + coef[b, t, 2]) / s, \
        (coef[b, t, 3] * px + coef[b, t, 4] * py + coef[b, t, 5]) / s


@cuda.jit
def barycentrics_forward(coef, tri_id, depth, window, rast, rast_db):
    """Thread per pixel: :func:`.barycentrics_kernels.barycentrics_forward`."""
    n_views, height, width = tri_id.shape
    job = cuda.grid(1)
    if job >= n_views * height * width:
        return
    b, iy, ix, px, py = _pixel_ndc(job, height, width, window)
    kx, ky = 2.0 / window[3], 2.0 / window[2]
    t = tri_id[b, iy, ix] - 1
    if t < 0:
        for k in range(4):
            rast[b, iy, ix, k] = 0.0
            rast_db[b, iy, ix, k] = 0.0
        return
    s, u, v = _barycentrics(coef, b, t, px, py)
    rast[b, iy, ix, 0] = u
    rast[b, iy, ix, 1] = v
    rast[b, iy, ix, 2] = depth[b, iy, ix]
    rast[b, iy, ix, 3] = t + 1
    rast_db[b, iy, ix, 0] = (coef[b, t, 0] - u * coef[b, t, 6]) / s * kx
    rast_db[b, iy, ix, 1] = (coef[b, t, 1] - u * coef[b, t, 7]) / s * ky
    rast_db[b, iy, ix, 2] = (coef[b, t, 3] - v * coef[b, t, 6]) / s * kx
    rast_db[b, iy, ix, 3] = (coef[b, t, 4] - v * coef[b, t, 7]) / s * ky


@cuda.jit
def barycentrics_backward(coef, tri_id, window, grad_rast, grad_db, use_db, grad_coef):
    """Thread per pixel: :func:`.barycentrics_kernels.barycentrics_backward`, its additions to
    ``grad_coef [B, T, 9]`` atomic."""
    n_views, height, width = tri_id.shape
    job = cuda.grid(1)
    if job >= n_views * height * width:
        return
    b, iy, ix, px, py = _pixel_ndc(job, height, width, window)
    kx, ky = 2.0 / window[3], 2.0 / window[2]
    t = tri_id[b, iy, ix] - 1
    if t < 0:
        return
    s, u, v = _barycentrics(coef, b, t, px, py)
    g_u = grad_rast[b, iy, ix, 0]
    g_v = grad_rast[b, iy, ix, 1]
    g_s = 0.0
    if use_db:
        gux, guy = grad_db[b, iy, ix, 0] * kx, grad_db[b, iy, ix, 1] * ky
        gvx, gvy = grad_db[b, iy, ix, 2] * kx, grad_db[b, iy, ix, 3] * ky
        sx, sy = coef[b, t, 6], coef[b, t, 7]
        cuda.atomic.add(grad_coef, (b, t, 0), gux / s)
        cuda.atomic.add(grad_coef, (b, t, 1), guy / s)
        cuda.atomic.add(grad_coef, (b, t, 3), gvx / s)
        cuda.atomic.add(grad_coef, (b, t, 4), gvy / s)
        cuda.atomic.add(grad_coef, (b, t, 6), -(gux * u + gvx * v) / s)
        cuda.atomic.add(grad_coef, (b, t, 7), -(guy * u + gvy * v) / s)
        g_u -= (gux * sx + guy * sy) / s
        g_v -= (gvx * sx + gvy * sy) / s
        g_s -= (gux * (coef[b, t, 0] - u * sx) + guy * (coef[b, t, 1] - u * sy)
                + gvx * (coef[b, t, 3] - v * sx) + gvy * (coef[b, t, 4] - v * sy)) / (s * s)
    g_s -= (g_u * u + g_v * v) / s
    g_e0 = g_u / s
    g_e1 = g_v / s
    for k, g in ((0, g_e0), (3, g_e1), (6, g_s)):
        cuda.atomic.add(grad_coef, (b, t, k), g * px)
        cuda.atomic.add(grad_coef, (b, t, k + 1), g * py)
        cuda.atomic.add(grad_coef, (b, t, k + 2), g)


@cuda.jit
def triangle_coefficients_forward(xyw, tri, shown, coef):
    """Thread per (view, triangle): :func:`.barycentrics_kernels.triangle_coefficients_forward`."""
    n_tris = tri.shape[0]
    job = cuda.grid(1)
    if job >= xyw.shape[0] * n_tris:
        return
    b, t = job // n_tris, job % n_tris
    if not shown[b, t]:
        return
    for k in range(9):
        coef[b, t, k] = 0.0
    for i in range(3):
        j, k = tri[t, (i + 1) % 3], tri[t, (i + 2) % 3]
        cx = xyw[b, j, 1] * xyw[b, k, 2] - xyw[b, j, 2] * xyw[b, k, 1]
        cy = xyw[b, j, 2] * xyw[b, k, 0] - xyw[b, j, 0] * xyw[b, k, 2]
        cw = xyw[b, j, 0] * xyw[b, k, 1] - xyw[b, j, 1] * xyw[b, k, 0]
        if i < 2:
            coef[b, t, 3 * i] = cx
            coef[b, t, 3 * i + 1] = cy
            coef[b, t, 3 * i + 2] = cw
        coef[b, t, 6] += cx
        coef[b, t, 7] += cy
        coef[b, t, 8] += cw


@cuda.jit
def shown_triangles(tri_id, shown):
    """Thread per pixel: :func:`.barycentrics_kernels.shown_triangles` (every writer writes True)."""
    n_views, height, width = tri_id.shape
    job = cuda.grid(1)
    if job >= n_views * height * width:
        return
    b, y, x = job // (height * width), (job // width) % height, job % width
    if tri_id[b, y, x] > 0:
        shown[b, tri_id[b, y, x] - 1] = True
