"""Compiled loops of stochastic MSAA (:mod:`.msaa`): choosing the sample a pixel is shaded at,
the backward of reading it, and compositing the shaded pixels over the samples, forward and
hand-written backward.

The plain-torch twins are :func:`.msaa.covered_sample_index_python`,
:func:`.msaa.pick_samples_python` and :func:`.msaa.upsample_over_python`; tests compare values
and gradients. The loops run in parallel over the rows of the low-resolution image (or the
picked samples), and each pixel writes only its own ``f x f`` block of samples (or its own
row), so no two threads write the same element. Each loop runs a per-pixel (per-row) body that
the CUDA forms (:mod:`.msaa_cuda`) run too, one thread per pixel (row).
"""

from __future__ import annotations

from numba import njit, prange

from ..kernel_cache import CACHE


@njit(cache=CACHE, parallel=True)
def covered_sample_index(ids, u, factor, out):
    """``out [B, H, W]`` (int64) = flat index into ``[B, H f, W f]`` of the sample pixel
    ``(b, y, x)`` is shaded at: of the ``k`` samples of its ``f x f`` block with ``ids > 0``
    (covered), taken in row-major order, number ``min(floor(u k), k - 1)``; where none is
    covered, sample ``min(floor(u f^2), f^2 - 1)`` of the block. ``ids [B, H f, W f]`` (the
    triangle ids of ``rast``), ``u [B, H, W]`` uniform in [0, 1)."""
    n_views, height, width = u.shape
    for row in prange(n_views * height):
        b, y = row // height, row % height
        for x in range(width):
            covered_sample_pixel(ids, u, factor, out, b, y, x)


@njit(cache=CACHE, inline="always")
def covered_sample_pixel(ids, u, factor, out, b, y, x):
    """Pixel ``(b, y, x)`` of :func:`covered_sample_index` (both its CPU and its CUDA form):
    ``out[b, y, x]``."""
    wide = u.shape[2] * factor
    high = u.shape[1] * factor
    covered = 0
    for sy in range(factor):
        for sx in range(factor):
            if ids[b, y * factor + sy, x * factor + sx] > 0:
                covered += 1
    pool = covered if covered > 0 else factor * factor
    target = min(int(u[b, y, x] * pool), pool - 1)  # u * pool >= 0: truncation is floor
    seen = 0
    chosen = 0
    for slot in range(factor * factor):
        sy, sx = slot // factor, slot % factor
        if covered == 0 or ids[b, y * factor + sy, x * factor + sx] > 0:
            if seen == target:
                chosen = slot
                break
            seen += 1
    sy, sx = chosen // factor, chosen % factor
    out[b, y, x] = (b * high + y * factor + sy) * wide + x * factor + sx


@njit(cache=CACHE, parallel=True)
def scatter_rows(values, index, out):
    """``out[index[i]] = values[i]`` for ``values [N, C]`` and distinct ``index [N]`` (``out``
    zeroed by the caller): the gradient of reading rows ``index`` of ``out``'s shape, in
    parallel because torch's ``index_add_`` runs serially."""
    for i in prange(index.shape[0]):
        scatter_row(values, index, out, i)


@njit(cache=CACHE, inline="always")
def scatter_row(values, index, out, i):
    """Row ``i`` of :func:`scatter_rows` (both its CPU and its CUDA form): ``out[index[i]]``."""
    for ch in range(values.shape[1]):
        out[index[i], ch] = values[i, ch]


@njit(cache=CACHE, parallel=True)
def upsample_over_forward(accum, colour, ids, factor, out):
    """``out [B, H f, W f, 4]`` = ``accum + a (c - accum)`` per sample, with ``c = (rgb, 1)`` of
    the sample's pixel in ``colour [B, H, W, 4]`` (straight alpha) and ``a`` its alpha where
    the sample is covered (``ids [B, H f, W f] > 0``), else 0."""
    n_views, height, width = colour.shape[0], colour.shape[1], colour.shape[2]
    for row in prange(n_views * height):
        b, y = row // height, row % height
        for x in range(width):
            upsample_over_pixel(accum, colour, ids, factor, out, b, y, x)


@njit(cache=CACHE, inline="always")
def upsample_over_pixel(accum, colour, ids, factor, out, b, y, x):
    """Pixel ``(b, y, x)`` of :func:`upsample_over_forward` (both its CPU and its CUDA form): its
    ``f x f`` block of ``out``."""
    alpha = colour[b, y, x, 3]
    for sy in range(factor):
        hy = y * factor + sy
        for sx in range(factor):
            hx = x * factor + sx
            a = alpha if ids[b, hy, hx] > 0 else 0.0
            for ch in range(3):
                out[b, hy, hx, ch] = accum[b, hy, hx, ch] + a * (colour[b, y, x, ch] - accum[b, hy, hx, ch])
            out[b, hy, hx, 3] = accum[b, hy, hx, 3] + a * (1.0 - accum[b, hy, hx, 3])


@njit(cache=CACHE, parallel=True)
def upsample_over_backward(accum, colour, ids, factor, grad_out, grad_accum, grad_colour):
    """Gradients of :func:`upsample_over_forward`: ``grad_accum = (1 - a) grad_out`` per
    sample; ``grad_colour[..., :3]`` sums ``a grad_out[..., :3]`` over the pixel's samples and
    ``grad_colour[..., 3]`` sums ``covered * (c - accum) . grad_out`` (every element written)."""
    n_views, height, width = colour.shape[0], colour.shape[1], colour.shape[2]
    for row in prange(n_views * height):
        b, y = row // height, row % height
        for x in range(width):
            upsample_over_backward_pixel(accum, colour, ids, factor, grad_out, grad_accum, grad_colour, b, y, x)


@njit(cache=CACHE, inline="always")
def upsample_over_backward_pixel(accum, colour, ids, factor, grad_out, grad_accum, grad_colour, b, y, x):
    """Pixel ``(b, y, x)`` of :func:`upsample_over_backward` (both its CPU and its CUDA form):
    ``grad_colour[b, y, x]`` and its ``f x f`` block of ``grad_accum``."""
    alpha = colour[b, y, x, 3]
    g_r = 0.0
    g_g = 0.0
    g_b = 0.0
    g_alpha = 0.0
    for sy in range(factor):
        hy = y * factor + sy
        for sx in range(factor):
            hx = x * factor + sx
            if ids[b, hy, hx] > 0:
                g0, g1, g2, g3 = grad_out[b, hy, hx, 0], grad_out[b, hy, hx, 1], grad_out[b, hy, hx, 2], grad_out[b, hy, hx, 3]
                g_r += alpha * g0
                g_g += alpha * g1
                g_b += alpha * g2
                g_alpha += ((colour[b, y, x, 0] - accum[b, hy, hx, 0]) * g0
                            + (colour[b, y, x, 1] - accum[b, hy, hx, 1]) * g1
                            + (colour[b, y, x, 2] - accum[b, hy, hx, 2]) * g2
                            + (1.0 - accum[b, hy, hx, 3]) * g3)
                for ch in range(4):
                    grad_accum[b, hy, hx, ch] = (1.0 - alpha) * grad_out[b, hy, hx, ch]
            else:
                for ch in range(4):
                    grad_accum[b, hy, hx, ch] = grad_out[b, hy, hx, ch]
    grad_colour[b, y, x, 0] = g_r
    grad_colour[b, y, x, 1] = g_g
    grad_colour[b, y, x, 2] = g_b
    grad_colour[b, y, x, 3] = g_alpha
