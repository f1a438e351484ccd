"""PSNR and FLIP on tone-mapped images."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from lookalike.report.metrics import PSNR_CAP_DB, error_share, flip, flip_views, psnr, psnr_views, silhouette_band


def _linear_for_display(value: float) -> float:
    """The linear radiance x whose tone-mapped value srgb(log(x + 1)) is ``value``."""
    log_value = ((value + 0.055) / 1.055) ** 2.4 if value > 0.04045 else value / 12.92
    return float(np.expm1(log_value))


def _scene(rng, n=2, size=48):
    """Smooth linear HDR images with values up to about 3."""
    y, x = np.mgrid[0:size, 0:size] / size
    base = np.stack([np.sin(6 * x + k) * np.cos(4 * y) for k in range(3)], axis=-1)
    return np.stack([(1.5 + 1.4 * base * (i + 1) / n) for i in range(n)]).astype(np.float32)


def test_identical_images_give_the_cap():
    img = _scene(np.random.default_rng(0))
    np.testing.assert_array_equal(psnr_views(img, img), [PSNR_CAP_DB, PSNR_CAP_DB])
    assert psnr(torch.as_tensor(img), img) == PSNR_CAP_DB


def test_known_mse_gives_known_psnr():
    reference = np.zeros((1, 8, 8, 3), dtype=np.float32)                      # tone-maps to 0
    test = np.full((1, 8, 8, 3), _linear_for_display(0.1), dtype=np.float32)  # tone-maps to 0.1
    assert psnr(reference, test) == pytest.approx(20.0, abs=1e-4)              # MSE 0.01
    half = test.copy()
    half[:, :4] = 0                                                            # MSE 0.005
    assert psnr(reference, half) == pytest.approx(10 * np.log10(200), abs=1e-4)


def test_psnr_averages_views_and_ignores_alpha():
    reference = np.zeros((2, 4, 4, 4), dtype=np.float32)
    test = reference.copy()
    test[0, ..., :3] = _linear_for_display(0.1)
    test[..., 3] = 1.0                                                         # alpha differs: ignored
    views = psnr_views(reference, test)
    np.testing.assert_allclose(views, [20.0, PSNR_CAP_DB], atol=1e-4)
    assert psnr(reference, test) == pytest.approx(views.mean())


def test_flip_is_zero_for_identical_images_and_grows_with_noise():
    rng = np.random.default_rng(1)
    img = _scene(rng)
    assert flip(img, img) == 0.0
    errors = []
    for sigma in (0.02, 0.1, 0.4):
        noisy = np.clip(img * (1 + sigma * rng.normal(size=img.shape)), 0, None).astype(np.float32)
        errors.append(flip(img, noisy))
    assert 0 < errors[0] < errors[1] < errors[2] < 1


def test_flip_maps_are_coloured_per_view():
    rng = np.random.default_rng(2)
    img = _scene(rng, n=3, size=32)
    noisy = img * 1.3
    means, maps = flip_views(img, noisy, with_maps=True)
    assert means.shape == (3,) and maps.shape == (3, 32, 32, 3) and maps.dtype == np.uint8
    assert flip_views(img, noisy)[1] is None
    assert flip(img, noisy) == pytest.approx(means.mean())


def test_shape_mismatch_is_an_error():
    with pytest.raises(ValueError, match="differ in shape"):
        psnr(np.zeros((1, 4, 4, 3)), np.zeros((1, 4, 5, 3)))
    with pytest.raises(ValueError, match="differ in shape"):
        flip(np.zeros((1, 4, 4, 3)), np.zeros((2, 4, 4, 3)))
    with pytest.raises(ValueError, match="differ in shape"):
        error_share(np.zeros((1, 4, 4, 3)), np.zeros((1, 5, 4, 3)), np.ones((1, 4, 4), bool))


def test_the_silhouette_band_surrounds_the_outline_on_both_sides():
    coverage = np.zeros((2, 12, 12), np.float32)
    coverage[0, 4:8, 4:8] = 1.0
    coverage[0, 4:8, 8] = 0.4  # partly covered: counts as outside
    band = silhouette_band(torch.from_numpy(coverage), width=1)
    expected = np.zeros((12, 12), bool)
    expected[3:9, 3:9] = True
    expected[5:7, 5:7] = False  # two pixels deep inside
    np.testing.assert_array_equal(band[0], expected)
    assert not band[1].any()  # nothing covered: no outline
    np.testing.assert_array_equal(silhouette_band(coverage[0], width=1)[0], expected)


def test_the_error_share_is_the_squared_error_in_the_mask_over_all_of_it():
    reference = np.zeros((1, 4, 4, 3), np.float32)
    test = reference.copy()
    test[0, 0, 0] = _linear_for_display(0.2)   # error 3 * 0.04 inside the mask
    test[0, 3, 3, 0] = _linear_for_display(0.4)  # error 0.16 outside
    mask = np.zeros((1, 4, 4), bool)
    mask[0, :2, :2] = True
    assert error_share(reference, test, mask) == pytest.approx(0.12 / 0.28, abs=1e-4)
    assert error_share(reference, reference, mask) == 0.0


def test_masked_psnr_scores_only_the_masked_pixels():
    from lookalike.report.metrics import coverage_union, masked_psnr_views

    reference = np.zeros((2, 8, 8, 3), dtype=np.float32)
    test = reference.copy()
    test[:, :2] = _linear_for_display(0.1)                                     # error only in rows 0-1
    alpha_ref, alpha_test = np.zeros((2, 8, 8)), np.zeros((2, 8, 8))
    alpha_ref[:, :2], alpha_test[:, 2:4] = 1.0, 0.5                             # union: rows 0-3
    mask = coverage_union(torch.as_tensor(alpha_ref), alpha_test)
    assert mask.shape == (2, 8, 8) and mask.sum() == 2 * 32
    np.testing.assert_allclose(masked_psnr_views(reference, test, mask), 10 * np.log10(200), atol=1e-4)  # MSE 0.005
    np.testing.assert_allclose(masked_psnr_views(reference, test, np.ones((2, 8, 8), bool)), psnr_views(reference, test))
    assert masked_psnr_views(reference, test, np.zeros((2, 8, 8), bool)).tolist() == [PSNR_CAP_DB, PSNR_CAP_DB]


def test_temporal_change_is_the_mean_step_between_consecutive_frames():
    from lookalike.report.metrics import temporal_change

    still = np.full((5, 4, 4, 3), _linear_for_display(0.5), dtype=np.float32)
    assert temporal_change(still) == pytest.approx(0.0, abs=1e-7)
    flicker = still.copy()
    flicker[1::2] = _linear_for_display(0.7)       # every step changes every value by 0.2
    assert temporal_change(flicker) == pytest.approx(0.2, abs=1e-4)
    ramp = np.stack([np.full((4, 4, 3), _linear_for_display(0.1 * t), dtype=np.float32) for t in range(5)])
    assert temporal_change(ramp) == pytest.approx(0.1, abs=1e-4)
    with pytest.raises(ValueError, match="two frames"):
        temporal_change(still[:1])
