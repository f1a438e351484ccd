"""Compiled shading normals, forward and hand-written backward: normal mapping in the tangent
frame, the back-face flip and the bend towards the viewer (:mod:`.normal_map`), one pass per
point each way.

The plain-torch twin is :func:`.normal_map.shading_normal_python` (``perturb_normal`` and
``bend_towards_viewer``); tests compare values and gradients. Per point, with
``normalize(x) = x / sqrt(max(|x|^2, 1e-20))`` (``safe_normalize``):

    n = normalize(normal)
    m = normalize(a t' + b s (n x t') + c n),  t' = normalize(t - (t.n) n)   where mapped,
    m = n                                                                    elsewhere,
    out = normalize(f g + w (f m - f g)),  w = clamp(f m.v / BEND_THRESHOLD, 0, 1)

for the tangent ``(t, sign s)``, the tangent-space value ``(a, b, c)``, the geometric normal
``g``, the view direction ``v`` and the facing sign ``f``. Clamps pass gradients where their
input lies inside the closed range, as ``torch.clamp`` does. Arithmetic is float64 per point.
Each pass runs a per-point body (``shading_normal_point``, ``shading_normal_backward_point``)
that the CUDA forms (:mod:`.normal_map_cuda`) run too, one thread per point.
"""

from __future__ import annotations

import math

from numba import njit, prange

from ..kernel_cache import CACHE

_EPS = 1e-20  # safe_normalize's floor of |x|^2


@njit(cache=CACHE, inline="always")
def _normalize(x, y, z):
    """``(x, y, z) q`` with ``q = 1 / sqrt(max(|.|^2, eps))``: returns the three components,
    ``q`` and whether the floor was not hit (1.0/0.0)."""
    square = x * x + y * y + z * z
    inside = 1.0
    if square < _EPS:
        square = _EPS
        inside = 0.0
    q = 1.0 / math.sqrt(square)
    return x * q, y * q, z * q, q, inside


@njit(cache=CACHE, inline="always")
def _normalize_backward(ux, uy, uz, q, inside, gx, gy, gz):
    """Gradient to ``x`` of ``u = normalize(x)`` for ``g = dL/du``: ``q (g - u (u.g))`` (the
    projection only where the floor was not hit)."""
    dot = (ux * gx + uy * gy + uz * gz) * inside
    return q * (gx - ux * dot), q * (gy - uy * dot), q * (gz - uz * dot)


@njit(cache=CACHE, inline="always")
def _frame(normal, tangent, tangent_space, mapped, p):
    """The forward quantities of one point up to the mapped normal ``m``: ``(n, q_n, in_n, t',
    q_t, in_t, sign, mm, q_m, in_m, m)`` with vectors as 3-tuples (``t'`` and ``mm`` zero where
    not mapped)."""
    nx, ny, nz, qn, in_n = _normalize(normal[p, 0], normal[p, 1], normal[p, 2])
    zero = (0.0, 0.0, 0.0)
    if not mapped[p]:
        return (nx, ny, nz), qn, in_n, zero, 1.0, 0.0, 1.0, zero, 1.0, 0.0, (nx, ny, nz)
    tx, ty, tz = tangent[p, 0], tangent[p, 1], tangent[p, 2]
    d = tx * nx + ty * ny + tz * nz
    px, py, pz, qt, in_t = _normalize(tx - d * nx, ty - d * ny, tz - d * nz)
    sign = -1.0 if tangent[p, 3] < 0 else 1.0
    bx, by, bz = sign * (ny * pz - nz * py), sign * (nz * px - nx * pz), sign * (nx * py - ny * px)
    a, b, c = tangent_space[p, 0], tangent_space[p, 1], tangent_space[p, 2]
    mx, my, mz = a * px + b * bx + c * nx, a * py + b * by + c * ny, a * pz + b * bz + c * nz
    ux, uy, uz, qm, in_m = _normalize(mx, my, mz)
    return (nx, ny, nz), qn, in_n, (px, py, pz), qt, in_t, sign, (mx, my, mz), qm, in_m, (ux, uy, uz)


@njit(cache=CACHE, parallel=True)
def shading_normal_forward(normal, tangent, tangent_space, mapped, geometric, view_dir, facing, bend, out):
    """``out [N, 3]`` = the shading normals above for ``normal, geometric, view_dir [N, 3]``,
    ``tangent [N, 4]``, ``tangent_space [N, 3]`` (read where ``mapped [N]`` bool), ``facing [N]``
    (+1 or -1) and ``bend`` = BEND_THRESHOLD."""
    for p in prange(normal.shape[0]):
        shading_normal_point(normal, tangent, tangent_space, mapped, geometric, view_dir, facing, bend, out, p)


@njit(cache=CACHE, inline="always")
def shading_normal_point(normal, tangent, tangent_space, mapped, geometric, view_dir, facing, bend, out, p):
    """Point ``p`` of :func:`shading_normal_forward` (both its CPU and its CUDA form): ``out[p]``."""
    _, _, _, _, _, _, _, _, _, _, m = _frame(normal, tangent, tangent_space, mapped, p)
    f = facing[p]
    gx, gy, gz = f * geometric[p, 0], f * geometric[p, 1], f * geometric[p, 2]
    sx, sy, sz = f * m[0], f * m[1], f * m[2]
    w = (sx * view_dir[p, 0] + sy * view_dir[p, 1] + sz * view_dir[p, 2]) / bend
    w = min(max(w, 0.0), 1.0)
    ox, oy, oz, _, _ = _normalize(gx + w * (sx - gx), gy + w * (sy - gy), gz + w * (sz - gz))
    out[p, 0] = ox
    out[p, 1] = oy
    out[p, 2] = oz


@njit(cache=CACHE, parallel=True)
def shading_normal_backward(normal, tangent, tangent_space, mapped, geometric, view_dir, facing, bend, grad_out,
                            grad_normal, grad_tangent, grad_tangent_space, grad_geometric, grad_view_dir):
    """Gradients of :func:`shading_normal_forward` for ``grad_out [N, 3]``: overwrite every row
    of ``grad_normal, grad_tangent_space, grad_geometric, grad_view_dir [N, 3]`` and
    ``grad_tangent [N, 4]`` (zero where not mapped, and in the sign column)."""
    for p in prange(normal.shape[0]):
        shading_normal_backward_point(normal, tangent, tangent_space, mapped, geometric, view_dir, facing, bend,
                                      grad_out, grad_normal, grad_tangent, grad_tangent_space, grad_geometric,
                                      grad_view_dir, p)


@njit(cache=CACHE, inline="always")
def shading_normal_backward_point(normal, tangent, tangent_space, mapped, geometric, view_dir, facing, bend, grad_out,
                                  grad_normal, grad_tangent, grad_tangent_space, grad_geometric, grad_view_dir, p):
    """Point ``p`` of :func:`shading_normal_backward` (both its CPU and its CUDA form): its rows
    of the gradients."""
    n, qn, in_n, t, qt, in_t, sign, _, qm, in_m, m = _frame(normal, tangent, tangent_space, mapped, p)
    f = facing[p]
    vx, vy, vz = view_dir[p, 0], view_dir[p, 1], view_dir[p, 2]
    gx, gy, gz = f * geometric[p, 0], f * geometric[p, 1], f * geometric[p, 2]
    sx, sy, sz = f * m[0], f * m[1], f * m[2]
    raw = (sx * vx + sy * vy + sz * vz) / bend
    w = min(max(raw, 0.0), 1.0)
    w_inside = 1.0 if 0.0 <= raw <= 1.0 else 0.0
    lx, ly, lz = gx + w * (sx - gx), gy + w * (sy - gy), gz + w * (sz - gz)
    ox, oy, oz, ql, in_l = _normalize(lx, ly, lz)
    glx, gly, glz = _normalize_backward(ox, oy, oz, ql, in_l, grad_out[p, 0], grad_out[p, 1], grad_out[p, 2])
    # lerp(g', s, w): d/dg' = 1 - w, d/ds = w, d/dw = s - g'; w = clamp(s.v / bend)
    g_raw = (glx * (sx - gx) + gly * (sy - gy) + glz * (sz - gz)) * w_inside / bend
    gsx, gsy, gsz = w * glx + g_raw * vx, w * gly + g_raw * vy, w * glz + g_raw * vz
    grad_view_dir[p, 0] = g_raw * sx
    grad_view_dir[p, 1] = g_raw * sy
    grad_view_dir[p, 2] = g_raw * sz
    grad_geometric[p, 0] = f * (1.0 - w) * glx
    grad_geometric[p, 1] = f * (1.0 - w) * gly
    grad_geometric[p, 2] = f * (1.0 - w) * glz
    gmx, gmy, gmz = f * gsx, f * gsy, f * gsz
    for k in range(4):
        grad_tangent[p, k] = 0.0
    if not mapped[p]:
        grad_tangent_space[p, 0] = 0.0
        grad_tangent_space[p, 1] = 0.0
        grad_tangent_space[p, 2] = 0.0
        gnx, gny, gnz = gmx, gmy, gmz
    else:
        gux, guy, guz = _normalize_backward(m[0], m[1], m[2], qm, in_m, gmx, gmy, gmz)
        nx, ny, nz = n
        px, py, pz = t
        bx, by, bz = sign * (ny * pz - nz * py), sign * (nz * px - nx * pz), sign * (nx * py - ny * px)
        a, b, c = tangent_space[p, 0], tangent_space[p, 1], tangent_space[p, 2]
        grad_tangent_space[p, 0] = gux * px + guy * py + guz * pz
        grad_tangent_space[p, 1] = gux * bx + guy * by + guz * bz
        grad_tangent_space[p, 2] = gux * nx + guy * ny + guz * nz
        # mm = a t' + b (s n x t') + c n
        gbx, gby, gbz = b * gux, b * guy, b * guz
        gtx = a * gux + sign * (gby * nz - gbz * ny)  # d/dt' of s (n x t').gb = s (gb x n)
        gty = a * guy + sign * (gbz * nx - gbx * nz)
        gtz = a * guz + sign * (gbx * ny - gby * nx)
        gnx = c * gux + sign * (py * gbz - pz * gby)  # d/dn = s (t' x gb)
        gny = c * guy + sign * (pz * gbx - px * gbz)
        gnz = c * guz + sign * (px * gby - py * gbx)
        # t' = normalize(t - (t.n) n)
        gpx, gpy, gpz = _normalize_backward(px, py, pz, qt, in_t, gtx, gty, gtz)
        tx, ty, tz = tangent[p, 0], tangent[p, 1], tangent[p, 2]
        d = tx * nx + ty * ny + tz * nz
        gpn = gpx * nx + gpy * ny + gpz * nz
        grad_tangent[p, 0] = gpx - nx * gpn
        grad_tangent[p, 1] = gpy - ny * gpn
        grad_tangent[p, 2] = gpz - nz * gpn
        gnx -= d * gpx + gpn * tx
        gny -= d * gpy + gpn * ty
        gnz -= d * gpz + gpn * tz
    grad_n = _normalize_backward(n[0], n[1], n[2], qn, in_n, gnx, gny, gnz)
    grad_normal[p, 0] = grad_n[0]
    grad_normal[p, 1] = grad_n[1]
    grad_normal[p, 2] = grad_n[2]
