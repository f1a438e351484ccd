"""Image decoding/encoding and the sRGB transfer function."""

from __future__ import annotations

import io as stdio

import numpy as np
import pytest
from PIL import Image

from lookalike.errors import AssetError
from lookalike.io.image_files import (bayer_thresholds, decode_image, dithered, encode_png, linear_to_srgb, read_image,
                                      resize, srgb_to_linear)


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


def test_bayer_thresholds_hold_every_level_once_neighbours_far_apart():
    thresholds = bayer_thresholds(3)
    assert sorted((thresholds * 64 - 0.5).round().astype(int).ravel().tolist()) == list(range(64))
    assert abs(thresholds[0, 0] - thresholds[0, 1]) * 64 >= 16 and abs(thresholds[0, 0] - thresholds[1, 0]) * 64 >= 16


def test_dithered_keeps_levels_and_each_blocks_mean_where_rounding_bands():
    on_level = np.full((8, 8, 4), 102 / 255, np.float32)
    assert np.abs(dithered(on_level) - on_level).max() < 1e-6  # a value on a level stays there
    ramp = np.broadcast_to(np.linspace(76.0, 78.0, 32, dtype=np.float32)[None, :, None] / 255, (32, 32, 4)).copy()
    out = dithered(ramp) * 255
    assert np.abs(out - ramp * 255).max() < 1.0  # never more than one level off
    assert np.array_equal(out[..., 3], np.round(ramp[..., 3] * 255))  # alpha rounded, not dithered
    block = (out[..., :3] - ramp[..., :3] * 255).reshape(4, 8, 4, 8, 3).mean(axis=(1, 3))
    rounded = (np.round(ramp[..., :3] * 255) - ramp[..., :3] * 255).reshape(4, 8, 4, 8, 3).mean(axis=(1, 3))
    assert np.abs(block).max() < 0.06 < np.abs(rounded).max()  # rounding moves a band by up to half a level
    assert np.array_equal(decode_image(encode_png(dithered(ramp)), "x.png") * 255, np.round(out))  # exact in a PNG
