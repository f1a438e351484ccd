"""Image decoding/encoding and the sRGB transfer function."""

from __future__ import annotations

import io as stdio

import numpy as np
import pytest
from PIL import Image

from lookalike.errors import AssetError
from lookalike.io.image_files import decode_image, encode_png, linear_to_srgb, read_image, resize, srgb_to_linear


def test_srgb_transfer_known_values_and_inverse():
    assert np.allclose(srgb_to_linear(np.array([0.0, 0.04045, 0.5, 1.0])),
                       [0.0, 0.04045 / 12.92, ((0.5 + 0.055) / 1.055) ** 2.4, 1.0])
    x = np.linspace(0, 1, 1001, dtype=np.float32)
    assert np.abs(linear_to_srgb(srgb_to_linear(x)) - x).max() < 1e-5
    assert linear_to_srgb(np.array([-1.0, 2.0])).tolist() == [0.0, 1.0]  # clamped


@pytest.mark.parametrize("channels", [1, 3, 4])
def test_png_round_trip(channels):
    pixels = np.random.default_rng(0).integers(0, 256, size=(5, 7, channels)).astype(np.float32) / 255
    decoded = decode_image(encode_png(pixels), "x.png")
    assert decoded.shape == (5, 7, 4)
    expected = np.repeat(pixels, 3, -1) if channels == 1 else pixels[..., :3]
    assert np.array_equal(decoded[..., :3], expected)
    assert np.array_equal(decoded[..., 3], pixels[..., 3] if channels == 4 else np.ones((5, 7), np.float32))


def test_sixteen_bit_grey_and_jpeg(tmp_path):
    grey = (np.arange(12, dtype=np.uint16).reshape(3, 4) * 5000)
    buffer = stdio.BytesIO()
    Image.fromarray(grey).save(buffer, format="PNG")
    decoded = decode_image(buffer.getvalue(), "g.png")
    assert np.allclose(decoded[..., 0], grey / 65535.0) and np.all(decoded[..., 3] == 1)
    Image.fromarray(np.full((4, 4, 3), 200, np.uint8)).save(tmp_path / "a.jpg", quality=95)
    assert np.allclose(read_image(tmp_path / "a.jpg")[..., :3], 200 / 255, atol=2 / 255)


def test_bad_images_raise_asset_errors(tmp_path):
    with pytest.raises(AssetError, match="cannot decode image"):
        decode_image(b"not an image", tmp_path / "bad.png")
    with pytest.raises(AssetError, match="missing.png: cannot read image"):
        read_image(tmp_path / "missing.png")


def test_resize_keeps_constant_images_constant():
    out = resize(np.full((4, 6, 2), 0.25, np.float32), 3, 5)
    assert out.shape == (3, 5, 2) and np.allclose(out, 0.25)
