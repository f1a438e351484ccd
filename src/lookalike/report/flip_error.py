"""LDR FLIP (Andersson et al. 2020, "FLIP: A Difference Evaluator for Alternating Images"), the
per-pixel perceptual error of a test picture against a reference, as NVIDIA's ``flip-evaluator``
computes it, in compiled kernels (:mod:`.flip_kernels`) that score a batch of views on every core.

Why our own: a run's validation scores FLIP on every view of every scoring, and
``flip-evaluator`` runs on one core and holds the GIL, so it took a large share of the fitting
time that a run is given. The plain-numpy twin is :func:`flip_error_maps_python`.

The pipeline, for sRGB pictures ``[H, W, 3]`` in [0, 1] viewed at ``ppd`` pixels per degree
(67.02: 0.7 m from a 0.7 m wide 3840-pixel screen):

- colour: both pictures in YCxCz, each channel low-passed by the eye's contrast sensitivity (a
  Gaussian, a sum of two for Cz; separable, edges clamped), back to linear RGB clamped to
  [0, 1], then CIELAB with the Hunt adjustment ``(L, 0.01 L a, 0.01 L b)``;
  ``e_c = HyAB^0.7`` (``HyAB = |dL| + |d(a, b)|``), mapped to [0, 1]: linearly to 0.95 below
  0.4 ``c_max``, the rest to (0.95, 1], ``c_max`` being green's distance from blue;
- features: on ``Y' = (Y + 16) / 116``, edges (first derivative of a Gaussian of standard
  deviation ``0.041 ppd``) and points (second derivative);
  ``e_f = (max(|edge_r - edge_t|, |point_r - point_t|) / sqrt(2))^0.5``;
- ``FLIP = e_c^(1 - e_f)``.
"""

from __future__ import annotations

import math

import numpy as np

from . import flip_kernels

PIXELS_PER_DEGREE = 0.7 * (3840 / 0.7) * math.pi / 180
"""FLIP's default viewing condition: 0.7 m from a 0.7 m wide monitor of 3840 pixels."""

CSF_A1 = (1.0, 1.0, 34.1)
CSF_B1 = (0.0047, 0.0053, 0.04)
CSF_A2 = (0.0, 0.0, 13.5)
CSF_B2 = (1.0e-5, 1.0e-5, 0.025)
"""The contrast sensitivity of Y, Cx and Cz as sums of two Gaussians
``a1 sqrt(pi / b1) exp(-pi^2 x^2 / b1) + a2 ...`` (x in degrees; FLIP paper, Sec. 3.1)."""

FEATURE_WIDTH = 0.082
"""``w``: the feature detectors' standard deviation is ``0.5 w ppd`` pixels."""


def _gaussian(x2: np.ndarray, a: float, b: float) -> np.ndarray:
    return a * np.sqrt(np.pi / b) * np.exp(-np.pi ** 2 * x2 / b)


def colour_filters(ppd: float = PIXELS_PER_DEGREE) -> np.ndarray:
    """``[4, 2r + 1]`` float32 one-dimensional low-pass weights: Y, Cx, and the two Gaussians of
    Cz, whose outer products summed give Cz's two-dimensional filter. Radius
    ``r = ceil(3 sqrt(max b / (2 pi^2)) ppd)``; Y and Cx each sum to 1, Cz's two so that their
    two-dimensional sum does (``s1^2 + s2^2 = 1``)."""
    radius = math.ceil(3 * math.sqrt(max(CSF_B1 + CSF_B2) / (2 * math.pi ** 2)) * ppd)
    x2 = ((np.arange(-radius, radius + 1) / ppd) ** 2).astype(np.float32)
    y = _gaussian(x2, CSF_A1[0], CSF_B1[0])
    cx = _gaussian(x2, CSF_A1[1], CSF_B1[1])
    cz1 = np.sqrt(CSF_A1[2] * np.sqrt(np.pi / CSF_B1[2])) * np.exp(-np.pi ** 2 * x2 / CSF_B1[2])
    cz2 = np.sqrt(CSF_A2[2] * np.sqrt(np.pi / CSF_B2[2])) * np.exp(-np.pi ** 2 * x2 / CSF_B2[2])
    cz_norm = math.hypot(cz1.sum(), cz2.sum())
    return np.stack([y / y.sum(), cx / cx.sum(), cz1 / cz_norm, cz2 / cz_norm]).astype(np.float32)


def feature_filters(ppd: float = PIXELS_PER_DEGREE) -> np.ndarray:
    """``[3, 2r + 1]`` float32: a Gaussian ``g`` of standard deviation ``s = 0.5 w ppd`` (sums to
    1), its first derivative ``-x g`` and its second ``(x^2 / s^2 - 1) g``, each derivative's
    positive weights scaled to sum to 1 and its negative ones to -1; ``r = ceil(3 s)``."""
    sd = 0.5 * FEATURE_WIDTH * ppd
    radius = math.ceil(3 * sd)
    x = np.arange(-radius, radius + 1, dtype=np.float64)
    g = np.exp(-x * x / (2 * sd * sd))

    def signed_unit(weights: np.ndarray) -> np.ndarray:
        return np.where(weights > 0, weights / weights[weights > 0].sum(), weights / -weights[weights < 0].sum())

    return np.stack([g / g.sum(), signed_unit(-x * g), signed_unit((x * x / (sd * sd) - 1) * g)]).astype(np.float32)


def _as_views(pictures) -> np.ndarray:
    values = np.ascontiguousarray(pictures, dtype=np.float32)
    return values[None] if values.ndim == 3 else values


def flip_error_maps(reference, test, ppd: float = PIXELS_PER_DEGREE) -> np.ndarray:
    """Per-pixel FLIP of each view (module docstring), compiled.

    Args:
        reference, test: ``[B, H, W, 3]`` (or ``[H, W, 3]``) sRGB values in [0, 1].
    Returns:
        ``[B, H, W]`` float32 in [0, 1].
    """
    a, b = _as_views(reference), _as_views(test)
    if a.shape != b.shape:
        raise ValueError(f"pictures differ in shape: {a.shape} vs {b.shape}")
    error = np.empty(a.shape[:3], np.float32)
    flip_kernels.flip_maps(a, b, colour_filters(ppd), feature_filters(ppd), error)
    return error


def flip_error_maps_python(reference, test, ppd: float = PIXELS_PER_DEGREE) -> np.ndarray:
    """:func:`flip_error_maps` in plain numpy (float64), one step of the pipeline at a time: the
    twin its kernels are tested against."""
    a, b = _as_views(reference).astype(np.float64), _as_views(test).astype(np.float64)
    colour, feature = colour_filters(ppd).astype(np.float64), feature_filters(ppd).astype(np.float64)
    ycxcz_r, ycxcz_t = _ycxcz(a), _ycxcz(b)
    cmax = _hyab(_hunt_lab(np.array([0.0, 1.0, 0.0])), _hunt_lab(np.array([0.0, 0.0, 1.0]))) ** 0.7
    hyab = _hyab(_hunt_lab(_filtered_rgb(ycxcz_r, colour)), _hunt_lab(_filtered_rgb(ycxcz_t, colour))) ** 0.7
    knee = 0.4 * cmax
    e_c = np.where(hyab < knee, hyab * 0.95 / knee, 0.95 + (hyab - knee) / (cmax - knee) * 0.05)
    (edge_r, point_r), (edge_t, point_t) = _features(ycxcz_r, feature), _features(ycxcz_t, feature)
    e_f = (np.maximum(np.abs(edge_r - edge_t), np.abs(point_r - point_t)) / np.sqrt(2)) ** 0.5
    return (e_c ** (1 - e_f)).astype(np.float32)


_RGB_TO_XYZ = np.array(flip_kernels.RGB_TO_XYZ)
_WHITE = _RGB_TO_XYZ.sum(axis=1)
"""Linear sRGB to CIE XYZ (D65), and the white point, XYZ of RGB (1, 1, 1)."""


def _ycxcz(srgb: np.ndarray) -> np.ndarray:
    linear = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
    xyz = linear @ _RGB_TO_XYZ.T / _WHITE
    return np.stack([116 * xyz[..., 1] - 16, 500 * (xyz[..., 0] - xyz[..., 1]),
                     200 * (xyz[..., 1] - xyz[..., 2])], axis=-1)


def _convolve(image: np.ndarray, weights: np.ndarray, axis: int) -> np.ndarray:
    """``image [B, H, W]`` convolved along ``axis`` (1 or 2) with ``weights [2r + 1]``, edges
    clamped (the nearest pixel repeats)."""
    radius = len(weights) // 2
    pad = [(0, 0)] * 3
    pad[axis] = (radius, radius)
    padded = np.pad(image, pad, mode="edge")
    size = image.shape[axis]
    return sum(w * np.take(padded, np.arange(k, k + size), axis=axis) for k, w in enumerate(weights))


def _separable(image: np.ndarray, along_x: np.ndarray, along_y: np.ndarray) -> np.ndarray:
    return _convolve(_convolve(image, along_x, 2), along_y, 1)


def _filtered_rgb(ycxcz: np.ndarray, filters: np.ndarray) -> np.ndarray:
    y = _separable(ycxcz[..., 0], filters[0], filters[0])
    cx = _separable(ycxcz[..., 1], filters[1], filters[1])
    cz = _separable(ycxcz[..., 2], filters[2], filters[2]) + _separable(ycxcz[..., 2], filters[3], filters[3])
    luma = (y + 16) / 116
    xyz = np.stack([luma + cx / 500, luma, luma - cz / 200], axis=-1) * _WHITE
    return np.clip(xyz @ np.linalg.inv(_RGB_TO_XYZ).T, 0, 1)


def _hunt_lab(rgb: np.ndarray) -> np.ndarray:
    t = (rgb @ _RGB_TO_XYZ.T) / _WHITE
    delta = 6 / 29
    f = np.where(t > delta ** 3, np.cbrt(t), t / (3 * delta ** 2) + 4 / 29)
    lightness = 116 * f[..., 1] - 16
    return np.stack([lightness, 0.01 * lightness * 500 * (f[..., 0] - f[..., 1]),
                     0.01 * lightness * 200 * (f[..., 1] - f[..., 2])], axis=-1)


def _hyab(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    return np.abs(p[..., 0] - q[..., 0]) + np.hypot(p[..., 1] - q[..., 1], p[..., 2] - q[..., 2])


def _features(ycxcz: np.ndarray, filters: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Edge and point strengths ``[B, H, W]`` of the normalised luminance."""
    gray = (ycxcz[..., 0] + 16) / 116
    g, dg, ddg = filters
    edge = np.hypot(_separable(gray, dg, g), _separable(gray, g, dg))
    point = np.hypot(_separable(gray, ddg, g), _separable(gray, g, ddg))
    return edge, point
