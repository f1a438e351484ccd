"""sRGB encoding and decoding and the paper's tone map, on torch tensors and NumPy arrays."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from lookalike.colour import srgb_decode, srgb_encode, tonemap


def test_tonemap_follows_the_paper():
    x = torch.tensor([0.0, np.e - 1, 1e-4, 5.0], dtype=torch.float64)
    expected = torch.tensor([0.0, 1.0, 12.92 * np.log1p(1e-4), 1.055 * np.log(6.0) ** (1 / 2.4) - 0.055], dtype=torch.float64)
    torch.testing.assert_close(tonemap(x), expected)
    assert tonemap(torch.tensor([-1.0])).item() == 0.0
    torch.testing.assert_close(srgb_encode(torch.tensor([0.0031308])), torch.tensor([12.92 * 0.0031308]))


def test_decode_known_values_and_inverse():
    np.testing.assert_allclose(srgb_decode(np.array([0.0, 0.04045, 0.5, 1.0])),
                               [0.0, 0.04045 / 12.92, ((0.5 + 0.055) / 1.055) ** 2.4, 1.0])
    x = np.linspace(0, 1, 1001)
    np.testing.assert_allclose(srgb_encode(srgb_decode(x)), x, atol=1e-12)


def test_numpy_and_torch_agree_without_nan():
    x = np.linspace(-1.0, 3.0, 401)
    for f in (srgb_encode, srgb_decode, tonemap):
        got = f(x)
        assert isinstance(got, np.ndarray) and got.dtype == np.float64 and np.isfinite(got).all()
        np.testing.assert_allclose(got, f(torch.from_numpy(x)).numpy(), rtol=1e-15, atol=0)
    assert srgb_encode(np.float32([0.5])).dtype == np.float32
    t = torch.linspace(-1.0, 3.0, 401, dtype=torch.float64, requires_grad=True)
    tonemap(t).sum().backward()
    assert torch.isfinite(t.grad).all()


def _hand_srgb(x: float) -> float:
    return 12.92 * x if x <= 0.0031308 else 1.055 * x ** (1 / 2.4) - 0.055


def test_tonemap_matches_the_papers_formula_over_the_range():
    xs = [0.0, 0.001, 0.003, 0.01, 0.5, 1.0, 7.0, 1000.0]
    got = tonemap(torch.tensor(xs, dtype=torch.float64))
    want = [_hand_srgb(np.log1p(x)) for x in xs]
    assert got.tolist() == pytest.approx(want, rel=1e-12, abs=1e-15)


def test_srgb_is_continuous_at_the_knee():
    knee = torch.tensor([0.0031308 - 1e-9, 0.0031308 + 1e-9], dtype=torch.float64)
    low, high = srgb_encode(knee).tolist()
    assert abs(low - high) < 1e-6
