"""Compiled LDR FLIP (:func:`.flip_error.flip_error_maps`): two separable passes over one view's
rows, each row on its own thread. The first filters every row of both pictures along x (the
colour low-passes, and the feature detectors' x factors); the second filters those along y and
turns each pixel's sums into its error. The intermediates are channel-major ``[C, H, W]`` so
that both passes run their innermost loop over consecutive pixels. The plain-numpy twin is
:func:`.flip_error.flip_error_maps_python`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ..kernel_cache import CACHE

RGB_TO_XYZ = ((10135552 / 24577794, 8788810 / 24577794, 4435075 / 24577794),
              (2613072 / 12288897, 8788810 / 12288897, 887015 / 12288897),
              (1425312 / 73733382, 8788810 / 73733382, 70074185 / 73733382))
"""Linear sRGB to CIE XYZ (D65); the white point is its rows' sums, XYZ of RGB (1, 1, 1)."""
_WX, _WY, _WZ = (sum(row) for row in RGB_TO_XYZ)
_INV = tuple(map(tuple, np.linalg.inv(np.array(RGB_TO_XYZ))))
(_M00, _M01, _M02), (_M10, _M11, _M12), (_M20, _M21, _M22) = RGB_TO_XYZ
(_I00, _I01, _I02), (_I10, _I11, _I12), (_I20, _I21, _I22) = _INV
_DELTA3 = (6 / 29) ** 3
_LINEAR_SLOPE = 1 / (3 * (6 / 29) ** 2)

COLOUR_CHANNELS = 4
"""The first pass's colour rows: Y, Cx, and Cz under each of its two Gaussians."""
FEATURE_CHANNELS = 3
"""The first pass's feature rows: the normalised luminance under g, dg/dx and d2g/dx2."""


def flip_maps(a, b, colour, feature, error):
    """``error [B, H, W]`` of sRGB views ``a, b [B, H, W, 3]`` (float32) with the filters of
    :func:`.flip_error.colour_filters` and :func:`.flip_error.feature_filters`."""
    _, height, width, _ = a.shape
    first = np.empty((2, COLOUR_CHANNELS + FEATURE_CHANNELS, height, width), np.float32)
    cmax = _max_distance()
    for view in range(a.shape[0]):
        along_x(a[view], b[view], colour, feature, first)
        along_y(first, colour, feature, cmax, error[view])


def _max_distance() -> float:
    """``c_max``: the Hunt-adjusted HyAB distance of linear green from blue, to the power 0.7."""
    gl, ga, gb = _hunt_lab(0.0, 1.0, 0.0)
    bl, ba, bb = _hunt_lab(0.0, 0.0, 1.0)
    return (abs(gl - bl) + math.hypot(ga - ba, gb - bb)) ** 0.7


@njit(cache=CACHE, inline="always")
def _linear(c):
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


@njit(cache=CACHE, inline="always")
def _lab_f(t):
    return t ** (1.0 / 3.0) if t > _DELTA3 else t * _LINEAR_SLOPE + 4.0 / 29.0


@njit(cache=CACHE, inline="always")
def _hunt_lab(r, g, b):
    """Hunt-adjusted CIELAB ``(L, 0.01 L a, 0.01 L b)`` of linear RGB."""
    fx = _lab_f((_M00 * r + _M01 * g + _M02 * b) / _WX)
    fy = _lab_f(_M10 * r + _M11 * g + _M12 * b)
    fz = _lab_f((_M20 * r + _M21 * g + _M22 * b) / _WZ)
    lightness = 116.0 * fy - 16.0
    return lightness, 0.01 * lightness * 500.0 * (fx - fy), 0.01 * lightness * 200.0 * (fy - fz)


@njit(cache=CACHE, parallel=True)
def along_x(a, b, colour, feature, first):
    """``first [2, 7, H, W]``: each row of ``a`` and ``b`` ``[H, W, 3]`` in YCxCz, filtered along
    x (edges clamped): Y, Cx, Cz by ``colour [4, 2R + 1]``, and ``Y' = (Y + 16) / 116`` by
    ``feature [3, 2F + 1]``."""
    height, width = a.shape[0], a.shape[1]
    rc, rf = colour.shape[1] // 2, feature.shape[1] // 2
    pad = max(rc, rf)
    for task in prange(2 * height):
        image = a if task < height else b
        y = task % height
        side = task // height
        row = np.empty((4, width + 2 * pad), np.float32)
        for x in range(width + 2 * pad):
            source = min(max(x - pad, 0), width - 1)
            lr = _linear(image[y, source, 0])
            lg = _linear(image[y, source, 1])
            lb = _linear(image[y, source, 2])
            vx = (_M00 * lr + _M01 * lg + _M02 * lb) / _WX
            vy = _M10 * lr + _M11 * lg + _M12 * lb
            vz = (_M20 * lr + _M21 * lg + _M22 * lb) / _WZ
            row[0, x] = 116.0 * vy - 16.0
            row[1, x] = 500.0 * (vx - vy)
            row[2, x] = 200.0 * (vy - vz)
            row[3, x] = vy                              # (Y + 16) / 116
        out = first[side]
        out[:, y, :] = 0.0
        start_c, start_f = pad - rc, pad - rf
        _correlate(out[0, y], colour[0], row[0], start_c)
        _correlate(out[1, y], colour[1], row[1], start_c)
        _correlate(out[2, y], colour[2], row[2], start_c)
        _correlate(out[3, y], colour[3], row[2], start_c)
        _correlate(out[4, y], feature[0], row[3], start_f)
        _correlate(out[5, y], feature[1], row[3], start_f)
        _correlate(out[6, y], feature[2], row[3], start_f)


@njit(cache=CACHE, inline="always")
def _correlate(out, weights, row, start):
    """``out[x] += sum_k weights[k] row[start + k + x]``, the innermost loop over ``x``."""
    for k in range(weights.shape[0]):
        weight = weights[k]
        for x in range(out.shape[0]):
            out[x] += weight * row[start + k + x]


@njit(cache=CACHE, parallel=True)
def along_y(first, colour, feature, cmax, error):
    """``error [H, W]``: ``first`` (:func:`along_x`) filtered along y, then each pixel's colour
    and feature differences and ``e_c^(1 - e_f)``."""
    height, width = first.shape[2], first.shape[3]
    rc, rf = colour.shape[1] // 2, feature.shape[1] // 2
    knee = 0.4 * cmax
    for y in prange(height):
        sums = np.zeros((2, 8, width), np.float32)
        for side in range(2):
            source = first[side]
            acc = sums[side]
            for k in range(2 * rc + 1):
                yy = min(max(y + k - rc, 0), height - 1)
                for x in range(width):
                    acc[0, x] += colour[0, k] * source[0, yy, x]
                    acc[1, x] += colour[1, k] * source[1, yy, x]
                    acc[2, x] += colour[2, k] * source[2, yy, x] + colour[3, k] * source[3, yy, x]
            for k in range(2 * rf + 1):
                yy = min(max(y + k - rf, 0), height - 1)
                for x in range(width):
                    acc[3, x] += feature[1, k] * source[4, yy, x]   # d/dy of the x-Gaussian
                    acc[4, x] += feature[2, k] * source[4, yy, x]   # d2/dy2 of the x-Gaussian
                    acc[5, x] += feature[0, k] * source[5, yy, x]   # d/dx, y-Gaussian
                    acc[6, x] += feature[0, k] * source[6, yy, x]   # d2/dx2, y-Gaussian
        for x in range(width):
            l0, a0, b0, edge0, point0 = _filtered_pixel(sums[0], x)
            l1, a1, b1, edge1, point1 = _filtered_pixel(sums[1], x)
            hyab = abs(l0 - l1) + math.sqrt((a0 - a1) ** 2 + (b0 - b1) ** 2)
            e_c = hyab ** 0.7
            e_c = e_c * 0.95 / knee if e_c < knee else 0.95 + (e_c - knee) / (cmax - knee) * 0.05
            e_f = math.sqrt(max(abs(edge0 - edge1), abs(point0 - point1)) / math.sqrt(2.0))
            error[y, x] = e_c ** (1.0 - e_f)


@njit(cache=CACHE, inline="always")
def _filtered_pixel(acc, x):
    """Hunt-adjusted CIELAB and edge and point strengths of pixel ``x`` of one picture's sums
    (:func:`along_y`): its low-passed YCxCz back in linear RGB, clamped to [0, 1]."""
    luma = (acc[0, x] + 16.0) / 116.0
    vx = (luma + acc[1, x] / 500.0) * _WX
    vz = (luma - acc[2, x] / 200.0) * _WZ
    r = min(max(_I00 * vx + _I01 * luma + _I02 * vz, 0.0), 1.0)
    g = min(max(_I10 * vx + _I11 * luma + _I12 * vz, 0.0), 1.0)
    b = min(max(_I20 * vx + _I21 * luma + _I22 * vz, 0.0), 1.0)
    lightness, a_star, b_star = _hunt_lab(r, g, b)
    edge = math.sqrt(acc[5, x] * acc[5, x] + acc[3, x] * acc[3, x])
    point = math.sqrt(acc[6, x] * acc[6, x] + acc[4, x] * acc[4, x])
    return lightness, a_star, b_star, edge, point
