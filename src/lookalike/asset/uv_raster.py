"""Rasterising triangles in texture space (NumPy), for baking and re-expressing textures.

Texel ``(row, col)`` of an ``H x W`` texture has its centre at ``uv = ((col + 0.5) / W,
(row + 0.5) / H)`` (glTF convention, row 0 at the top). A texel is covered by a triangle when its
centre lies inside or on the triangle. UVs outside ``[0, 1]`` wrap (tiling textures).
"""

from __future__ import annotations

import numpy as np

_CHUNK_TEXELS = 1 << 24  # candidate texels examined per batch (bounds memory)


def rasterize_uv(uv: np.ndarray, height: int, width: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Texels covered by UV-space triangles.

    Args:
        uv: ``[T, 3, 2]`` float corner UVs.
        height, width: texture size.
    Returns:
        ``rows [K]``, ``cols [K]`` int64 texel indices (wrapped into the texture), ``tri [K]``
        int64 covering triangle, ``bary [K, 3]`` float64 barycentric weights of the texel centre
        (``sum(bary * corner value)`` interpolates). A texel covered twice appears twice.
    """
    xy = np.asarray(uv, np.float64) * np.array([width, height]) - 0.5  # texel-index space
    lo = np.ceil(xy.min(axis=1)).astype(np.int64)
    hi = np.floor(xy.max(axis=1)).astype(np.int64)
    size = np.maximum(hi - lo + 1, 0)
    e1, e2 = xy[:, 1] - xy[:, 0], xy[:, 2] - xy[:, 0]
    area = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    count = np.where(area != 0, size[:, 0] * size[:, 1], 0)
    ends = np.cumsum(count)
    out = ([], [], [], [])
    start_tri = 0
    while start_tri < len(count):
        base = ends[start_tri - 1] if start_tri else 0
        stop_tri = max(int(np.searchsorted(ends, base + _CHUNK_TEXELS, side="right")), start_tri + 1)
        for part, piece in zip(out, _rasterize_range(xy, lo, size, area, count, start_tri, stop_tri)):
            part.append(piece)
        start_tri = stop_tri
    if not out[0]:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 3))
    rows, cols, tri, bary = (np.concatenate(p) for p in out)
    return rows % height, cols % width, tri, bary


def _rasterize_range(xy, lo, size, area, count, start: int, stop: int):
    """``rasterize_uv`` for triangles ``start:stop`` (unwrapped texel indices)."""
    c = count[start:stop]
    tri = np.repeat(np.arange(start, stop), c)
    local = np.arange(int(c.sum())) - np.repeat(np.cumsum(c) - c, c)
    cols = lo[tri, 0] + local % np.maximum(size[tri, 0], 1)
    rows = lo[tri, 1] + local // np.maximum(size[tri, 0], 1)
    p = np.stack([cols, rows], axis=-1).astype(np.float64)
    a, b, d = xy[tri, 0], xy[tri, 1], xy[tri, 2]

    def edge(u, v):  # twice the signed area of (u, v, p)
        return (v[:, 0] - u[:, 0]) * (p[:, 1] - u[:, 1]) - (v[:, 1] - u[:, 1]) * (p[:, 0] - u[:, 0])

    bary = np.stack([edge(b, d), edge(d, a), edge(a, b)], axis=-1) / area[tri, None]
    inside = (bary >= -1e-9).all(axis=-1)
    return rows[inside], cols[inside], tri[inside], bary[inside]


def dilate(values: np.ndarray, covered: np.ndarray, iterations: int) -> tuple[np.ndarray, np.ndarray]:
    """Grow covered texels into uncovered neighbours, ``iterations`` texels deep: each uncovered
    texel next to covered ones (4-neighbourhood) takes their mean.

    Args:
        values: ``[H, W, C]`` float texels.
        covered: ``[H, W]`` bool.
    Returns:
        ``(values [H, W, C], covered [H, W])`` after dilation (inputs are not modified).
    """
    values = values.astype(np.float32, copy=True)
    covered = covered.copy()
    for _ in range(iterations):
        total = np.zeros_like(values)
        hits = np.zeros(covered.shape, np.float32)
        for axis, shift in ((0, 1), (0, -1), (1, 1), (1, -1)):
            rolled = np.roll(covered, shift, axis=axis)
            edge = np.ones_like(covered)  # no wrap-around at the image border
            if axis == 0:
                edge[0 if shift == 1 else -1, :] = False
            else:
                edge[:, 0 if shift == 1 else -1] = False
            take = rolled & edge
            total += np.where(take[..., None], np.roll(values, shift, axis=axis), 0.0)
            hits += take
        grow = ~covered & (hits > 0)
        if not grow.any():
            break
        values[grow] = total[grow] / hits[grow][:, None]
        covered |= grow
    return values, covered


def sample_bilinear(texture: np.ndarray, uv: np.ndarray, wrap: str = "wrap") -> np.ndarray:
    """Bilinear lookup of ``texture [H, W, C]`` at ``uv [K, 2]`` (glTF convention, texel centres
    at ``(i + 0.5) / size``), with ``wrap`` ("wrap": repeat, "clamp": clamp to edge).

    Returns:
        ``[K, C]`` float32 ``sum_corners w * texel``, ``w`` the bilinear weights of the four
        texels around ``uv * (W, H) - 0.5``.
    """
    height, width = texture.shape[:2]
    x = np.asarray(uv[:, 0], np.float64) * width - 0.5
    y = np.asarray(uv[:, 1], np.float64) * height - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    x0, y0 = x0.astype(np.int64), y0.astype(np.int64)

    def index(i, size):
        return np.mod(i, size) if wrap == "wrap" else np.clip(i, 0, size - 1)

    xs = (index(x0, width), index(x0 + 1, width))
    ys = (index(y0, height), index(y0 + 1, height))
    top = texture[ys[0], xs[0]] * (1 - fx) + texture[ys[0], xs[1]] * fx
    bottom = texture[ys[1], xs[0]] * (1 - fx) + texture[ys[1], xs[1]] * fx
    return (top * (1 - fy) + bottom * fy).astype(np.float32)


def apply_uv_transform(uv: np.ndarray, transform) -> np.ndarray:
    """UVs ``[..., 2]`` mapped by a texture's ``[3, 3]`` affine ``transform`` (``M @ (u, v, 1)``,
    KHR_texture_transform), or returned unchanged for ``None``."""
    if transform is None:
        return uv
    m = np.asarray(transform.detach().cpu().double() if hasattr(transform, "detach") else transform, np.float64)
    return uv @ m[:2, :2].T + m[:2, 2]
