"""CUDA forms of interpolate's kernels (:mod:`.interpolate_kernels`), the same formulas on
torch's CUDA tensors: one thread per listed pixel, and atomic adds where the backward pass
scatters into the vertices' attribute gradients (the CPU form keeps a private table per run of
the list instead). The plain-torch twin is :func:`.interpolate.interpolate_python`.
"""

from __future__ import annotations

from numba import cuda

from . import interpolate_kernels

_pixel = cuda.jit(device=True)(interpolate_kernels._pixel.py_func)


@cuda.jit
def interpolate_forward(attr, tri, rast, rast_db, diff, pixels, every, pixels_per_view, out, out_da):
    """Thread per listed pixel: :func:`.interpolate_kernels.interpolate_forward`."""
    i = cuda.grid(1)
    if i >= out.shape[0]:
        return
    p = _pixel(pixels, every, i)
    t = int(rast[p, 3]) - 1
    if t < 0:
        for ch in range(out.shape[1]):
            out[i, ch] = 0.0
        for ch in range(out_da.shape[1]):
            out_da[i, ch] = 0.0
        return
    ab = p // pixels_per_view if attr.shape[0] > 1 else 0
    u, v = rast[p, 0], rast[p, 1]
    i0, i1, i2 = tri[t, 0], tri[t, 1], tri[t, 2]
    for ch in range(attr.shape[2]):
        a2 = attr[ab, i2, ch]
        out[i, ch] = a2 + u * (attr[ab, i0, ch] - a2) + v * (attr[ab, i1, ch] - a2)
    for k in range(diff.shape[0]):
        ch = diff[k]
        a2 = attr[ab, i2, ch]
        da_du = attr[ab, i0, ch] - a2
        da_dv = attr[ab, i1, ch] - a2
        out_da[i, 2 * k] = da_du * rast_db[p, 0] + da_dv * rast_db[p, 2]
        out_da[i, 2 * k + 1] = da_du * rast_db[p, 1] + da_dv * rast_db[p, 3]


@cuda.jit
def interpolate_backward(attr, tri, rast, rast_db, diff, pixels, every, pixels_per_view, grad_out, grad_da,
                         grad_attr, grad_rast, grad_db):
    """Thread per listed pixel: :func:`.interpolate_kernels.interpolate_backward`, the additions
    to ``grad_attr [Ba, V, C]`` atomic (the listed pixels are distinct, so a pixel's own
    ``grad_rast`` and ``grad_db`` rows have one writer)."""
    i = cuda.grid(1)
    if i >= grad_out.shape[0]:
        return
    p = _pixel(pixels, every, i)
    t = int(rast[p, 3]) - 1
    if t < 0:
        return
    ab = p // pixels_per_view if attr.shape[0] > 1 else 0
    u, v = rast[p, 0], rast[p, 1]
    i0, i1, i2 = tri[t, 0], tri[t, 1], tri[t, 2]
    g_u = 0.0
    g_v = 0.0
    for ch in range(attr.shape[2]):
        g = grad_out[i, ch]
        a2 = attr[ab, i2, ch]
        g_u += g * (attr[ab, i0, ch] - a2)
        g_v += g * (attr[ab, i1, ch] - a2)
        cuda.atomic.add(grad_attr, (ab, i0, ch), g * u)
        cuda.atomic.add(grad_attr, (ab, i1, ch), g * v)
        cuda.atomic.add(grad_attr, (ab, i2, ch), g * (1.0 - u - v))
    grad_rast[p, 0] += g_u
    grad_rast[p, 1] += g_v
    for k in range(diff.shape[0]):
        ch = diff[k]
        gx, gy = grad_da[i, 2 * k], grad_da[i, 2 * k + 1]
        a2 = attr[ab, i2, ch]
        da_du = attr[ab, i0, ch] - a2
        da_dv = attr[ab, i1, ch] - a2
        if grad_db.shape[0] > 0:
            grad_db[p, 0] += gx * da_du
            grad_db[p, 1] += gy * da_du
            grad_db[p, 2] += gx * da_dv
            grad_db[p, 3] += gy * da_dv
        g0 = gx * rast_db[p, 0] + gy * rast_db[p, 1]
        g1 = gx * rast_db[p, 2] + gy * rast_db[p, 3]
        cuda.atomic.add(grad_attr, (ab, i0, ch), g0)
        cuda.atomic.add(grad_attr, (ab, i1, ch), g1)
        cuda.atomic.add(grad_attr, (ab, i2, ch), -(g0 + g1))
