"""Our compiled LDR FLIP against its numpy twin and against NVIDIA's ``flip-evaluator``."""

import numpy as np
import pytest

from lookalike.report.flip_error import feature_filters, colour_filters, flip_error_maps, flip_error_maps_python


def _pictures(height, width, seed=0):
    """A smooth, striped and edged sRGB picture and a noisy, shifted, tinted copy of it."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:height, 0:width] / max(height, width)
    a = np.stack([0.5 + 0.4 * np.sin(40 * x + 3 * y), 0.5 + 0.3 * np.cos(25 * y), (x > 0.5) * 0.8 + 0.1], -1)
    b = a + rng.normal(0, 0.04, a.shape) + 0.06 * (y > 0.3)[..., None] * np.array([1.0, -0.5, 0.2])
    return a.astype(np.float32), np.clip(b, 0, 1).astype(np.float32)


@pytest.mark.parametrize("shape", [(64, 96), (7, 5), (1, 30)])
def test_kernels_match_their_numpy_twin(shape):
    a, b = _pictures(*shape)
    views_a, views_b = np.stack([a, b, a]), np.stack([b, a, np.clip(a * 1.3, 0, 1)])
    compiled, plain = flip_error_maps(views_a, views_b), flip_error_maps_python(views_a, views_b)
    assert compiled.shape == (3, *shape)
    assert np.abs(compiled - plain).max() < 1e-4
    assert compiled.max() > 0.1                      # the pictures differ: the test sees errors


def test_identical_pictures_have_no_error():
    a, _ = _pictures(40, 40)
    assert flip_error_maps(a, a).max() == 0.0


def test_filters_are_normalised():
    colour, feature = colour_filters(), feature_filters()
    assert colour.shape == (4, 21) and feature.shape == (3, 19)          # radii 10 and 9 at 67 ppd
    assert colour[0].sum() == pytest.approx(1) and colour[1].sum() == pytest.approx(1)
    assert colour[2].sum() ** 2 + colour[3].sum() ** 2 == pytest.approx(1)
    assert feature[0].sum() == pytest.approx(1)
    for derivative in feature[1:]:
        assert derivative[derivative > 0].sum() == pytest.approx(1)
        assert derivative[derivative < 0].sum() == pytest.approx(-1)


def test_matches_nvidia_flip_evaluator():
    flip_evaluator = pytest.importorskip("flip_evaluator", reason="flip-evaluator (the test extra) is not installed")
    a, b = _pictures(96, 128, seed=3)
    theirs, mean, _ = flip_evaluator.evaluate(a, b, "LDR", inputsRGB=True, applyMagma=False, computeMeanError=True)
    ours = flip_error_maps(a, b)[0]
    assert np.abs(ours - np.asarray(theirs).reshape(ours.shape)).max() < 1e-4
    assert ours.mean(dtype=np.float64) == pytest.approx(mean, abs=1e-6)


def test_coloured_maps_match_nvidia_flip_evaluator():
    flip_evaluator = pytest.importorskip("flip_evaluator", reason="flip-evaluator (the test extra) is not installed")
    from lookalike.report.metrics import magma

    a, b = _pictures(48, 40, seed=4)
    theirs, _, _ = flip_evaluator.evaluate(a, b, "LDR", inputsRGB=True, applyMagma=True, computeMeanError=True)
    theirs = np.clip(np.round(np.asarray(theirs) * 255), 0, 255).astype(np.uint8)
    ours = magma(flip_error_maps(a, b)[0])
    assert (ours != theirs).any(axis=-1).mean() < 0.001     # a pixel at a rounding boundary may differ
