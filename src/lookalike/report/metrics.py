"""Image metrics for held-out views: PSNR and FLIP on tone-mapped images.

Renders are linear HDR radiance. Both metrics first apply the paper's tone map
(Sec. "Objective function"), ``x' = srgb(log(x + 1))`` with ``srgb`` the sRGB transfer
function (``lookalike.colour.tonemap``), then clamp to [0, 1]; they compare the *whole* image,
background included (reference and candidate share the background, so uncovered pixels agree
and add no error; every method is scored on the same pixels, which keeps the comparison fair).
``masked_psnr_views`` scores only given pixels (e.g. ``coverage_union``: those either image
covers), as the independent judge (``lookalike.jobs.judge_scores``) does.
"""

from __future__ import annotations

import numpy as np
import torch

from ..colour import tonemap
from .flip_error import flip_error_maps

PSNR_CAP_DB = 100.0                # PSNR of identical images (MSE 0) is reported as this cap


def display_values(images) -> np.ndarray:
    """Tone-mapped RGB in [0, 1]: ``[..., C>=3]`` linear (torch or numpy) -> ``[..., 3]`` float32 numpy."""
    x = torch.as_tensor(images).detach().to("cpu", torch.float32)[..., :3]
    return tonemap(x).clamp(0, 1).numpy()


def _as_batch(images) -> np.ndarray:
    values = display_values(images)
    return values[None] if values.ndim == 3 else values


def _pair(reference, test) -> tuple[np.ndarray, np.ndarray]:
    """Both image sets as ``_as_batch`` values; ``ValueError`` if their shapes differ."""
    a, b = _as_batch(reference), _as_batch(test)
    if a.shape != b.shape:
        raise ValueError(f"images differ in shape: {a.shape} vs {b.shape}")
    return a, b


def _squared_error(reference, test) -> np.ndarray:
    """``[B, H, W, 3]`` float64 ``(ref' - test')^2`` of the tone-mapped, clamped images."""
    a, b = _pair(reference, test)
    return (a.astype(np.float64) - b.astype(np.float64)) ** 2


def psnr_views(reference, test) -> np.ndarray:
    """PSNR in dB of each view: ``10 log10(1 / MSE)`` over all pixels and RGB channels of the
    tone-mapped, clamped images (peak 1).

    Args:
        reference, test: ``[B, H, W, C>=3]`` (or ``[H, W, C]``) linear radiance, torch or numpy.

    Returns:
        ``[B]`` float64; identical views give ``PSNR_CAP_DB`` (100 dB) instead of infinity.
    """
    return _psnr_of_mse(_squared_error(reference, test).mean(axis=(1, 2, 3)))


def _psnr_of_mse(mse: np.ndarray) -> np.ndarray:
    """``10 log10(1 / MSE)`` (peak 1), capped at ``PSNR_CAP_DB``."""
    return np.minimum(10 * np.log10(1.0 / np.maximum(mse, 1e-300)), PSNR_CAP_DB)


def masked_psnr_views(reference, test, mask) -> np.ndarray:
    """PSNR in dB of each view over the pixels of ``mask`` only (all three channels):
    ``10 log10(1 / MSE)`` with ``MSE = sum_mask |ref' - test'|^2 / (3 |mask|)`` on the
    tone-mapped, clamped images, as ``psnr_views``. Unlike the whole-image PSNR it does not grow
    with the empty background around a small object; with ``mask = coverage_union(...)`` it is
    the PSNR "over the pixels either image covers".

    Args:
        reference, test: ``[B, H, W, C>=3]`` (or ``[H, W, C]``) linear radiance.
        mask: ``[B, H, W]`` (or ``[H, W]``) bool.
    Returns:
        ``[B]`` float64; a view with an empty mask (or no error in it) gives ``PSNR_CAP_DB``.
    """
    error = _squared_error(reference, test)
    mask = np.asarray(mask, bool).reshape(error.shape[:3])
    pixels = mask.sum(axis=(1, 2)) * error.shape[-1]
    return _psnr_of_mse((error * mask[..., None]).sum(axis=(1, 2, 3)) / np.maximum(pixels, 1))


def coverage_union(reference_alpha, test_alpha) -> np.ndarray:
    """``[B, H, W]`` bool: the pixels that either image covers (``alpha > 0`` in either);
    alphas ``[B, H, W]`` (or ``[H, W]``), torch or numpy."""
    a = torch.as_tensor(reference_alpha).detach().to("cpu").numpy()
    b = torch.as_tensor(test_alpha).detach().to("cpu").numpy()
    union = (a > 0) | (b > 0)
    return union[None] if union.ndim == 2 else union


def silhouette_iou(reference_alpha, test_alpha) -> float:
    """Soft intersection over union of two coverages ``[B, H, W]`` in [0, 1] (torch or numpy),
    over all views: sum min(a, b) / sum max(a, b); 1 where neither covers anything."""
    a = torch.as_tensor(reference_alpha).detach().to("cpu").double().clamp(0, 1)
    b = torch.as_tensor(test_alpha).detach().to("cpu").double().clamp(0, 1)
    union = float(torch.maximum(a, b).sum())
    return float(torch.minimum(a, b).sum()) / union if union > 0 else 1.0


def psnr(reference, test) -> float:
    """Mean over views of ``psnr_views`` (dB)."""
    return float(psnr_views(reference, test).mean())


def flip_views(reference, test, with_maps: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
    """Mean FLIP error of each view (LDR FLIP at 67 pixels per degree,
    ``lookalike.report.flip_error``, as NVIDIA's ``flip-evaluator`` computes it) between the
    tone-mapped images, read as sRGB.

    Args:
        reference, test: ``[B, H, W, C>=3]`` (or ``[H, W, C]``) linear radiance.
        with_maps: also return the per-pixel error maps, coloured with FLIP's magma map.

    Returns:
        ``(mean [B] float64 in [0, 1], maps [B, H, W, 3] uint8 or None)``; 0 means identical.
    """
    error = flip_error_maps(*_pair(reference, test))
    means = error.mean(axis=(1, 2), dtype=np.float64)
    return means, (magma(error) if with_maps else None)


def magma(error: np.ndarray) -> np.ndarray:
    """``[..., 3]`` uint8: values in [0, 1] through matplotlib's 256-entry magma map (FLIP's),
    entry ``round(255 v)``."""
    from matplotlib import colormaps

    table = np.round(np.asarray(colormaps["magma"].colors) * 255).astype(np.uint8)
    return table[np.clip(np.floor(error * 255 + 0.5), 0, 255).astype(np.int64)]


SILHOUETTE_WIDTH_PX = 2
"""Half-width, in pixels, of the band around the reference's outline (``silhouette_band``)."""


def silhouette_band(coverage, width: int = SILHOUETTE_WIDTH_PX) -> np.ndarray:
    """Pixels within ``width`` pixels (a square neighbourhood) of the reference's outline.

    A pixel is covered where ``coverage >= 0.5``; the band holds every pixel that has both a
    covered and an uncovered pixel within ``width`` of it (itself included).

    Args:
        coverage: ``[B, H, W]`` (or ``[H, W]``) coverage in [0, 1], torch or numpy.
    Returns:
        ``[B, H, W]`` bool.
    """
    coverage = torch.as_tensor(coverage).detach().to("cpu", torch.float32)
    covered = (coverage >= 0.5).float().reshape(-1, 1, *coverage.shape[-2:])

    def within_reach(mask: torch.Tensor) -> torch.Tensor:
        return torch.nn.functional.max_pool2d(mask, 2 * width + 1, stride=1, padding=width)[:, 0] > 0

    return (within_reach(covered) & within_reach(1.0 - covered)).numpy()


def error_share(reference, test, mask) -> float:
    """The share of the squared error (tone-mapped, clamped, as in ``psnr_views``) of all views
    that lies in ``mask``: ``sum_mask e / sum e`` with ``e = |ref' - test'|^2`` summed over RGB;
    0 where the images agree everywhere.

    Args:
        reference, test: ``[B, H, W, C>=3]`` (or ``[H, W, C]``) linear radiance.
        mask: ``[B, H, W]`` (or ``[H, W]``) bool.
    """
    error = _squared_error(reference, test).sum(axis=-1)
    total = error.sum()
    return float(error[np.asarray(mask, bool).reshape(error.shape)].sum() / total) if total > 0 else 0.0


def flip(reference, test) -> float:
    """Mean FLIP error over all views (each view weighs the same)."""
    return float(flip_views(reference, test)[0].mean())


def flip_psnr(flip_mean: float) -> float:
    """A mean FLIP error on PSNR's scale: ``-20 log10(FLIP)``, the PSNR of an image whose RMS
    error (peak 1) equals that FLIP, capped at ``PSNR_CAP_DB`` as PSNR is (FLIP 0). Both are
    logarithms of an error in [0, 1], so a change of either in dB is the same relative change of
    its error."""
    return float(min(-20.0 * np.log10(max(flip_mean, 1e-300)), PSNR_CAP_DB))


def perceptual_score(psnr_db: float, flip_mean: float, flip_share: float) -> float:
    """A score in dB that weighs perceptual error beside the mean squared one:
    ``(1 - flip_share) * PSNR + flip_share * flip_psnr(FLIP)``; higher is better, and it is the
    PSNR where ``flip_share`` is 0. Why: grain and blotches in the maps cost a mean squared error
    little and a viewer (and FLIP) much, so that of two models with the same PSNR the one with
    the lower FLIP scores higher."""
    return (1.0 - flip_share) * psnr_db + flip_share * flip_psnr(flip_mean)


def temporal_change(frames) -> float:
    """Mean absolute difference between consecutive frames of ``frames [T, H, W, C>=3]``
    (linear; tone-mapped and clamped as for PSNR): ``mean_t mean |x'_{t+1} - x'_t|``, over
    pixels and channels. On a slow orbit the reference's own value is what the motion changes;
    a model's excess over it is flicker (aliasing, sparkle), which still pictures do not show."""
    values = display_values(frames).astype(np.float64)
    if values.shape[0] < 2:
        raise ValueError(f"temporal change needs at least two frames, not {values.shape[0]}")
    return float(np.abs(np.diff(values, axis=0)).mean())
