"""Image files in and out (PNG, JPEG, anything Pillow reads), and sRGB at the file boundary.

Arrays are ``[H, W, C]`` float32 in ``[0, 1]``, row 0 at the top of the image. Colour inside
lookalike is linear; files hold sRGB-encoded colour (glTF base colour and emissive, OBJ
``map_Kd``), so readers call ``srgb_to_linear`` and writers ``linear_to_srgb`` on colour
channels only (never on alpha, roughness, metalness or normals). Both clamp to ``[0, 1]`` and
apply the transfer functions of ``lookalike.colour``.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from PIL import Image, UnidentifiedImageError

from ..colour import srgb_decode, srgb_encode
from ..errors import AssetError

_SIXTEEN_BIT_MODES = ("I;16", "I;16B", "I;16L", "I")


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """Linear float32 colour of sRGB-encoded ``c`` (any shape): ``lookalike.colour.srgb_decode``
    of ``c`` clamped to ``[0, 1]``."""
    return srgb_decode(np.clip(c, 0.0, 1.0)).astype(np.float32)


def linear_to_srgb(c: np.ndarray) -> np.ndarray:
    """sRGB-encoded float32 colour of linear ``c`` (any shape): ``lookalike.colour.srgb_encode``
    of ``c`` clamped to ``[0, 1]``."""
    return srgb_encode(np.clip(c, 0.0, 1.0)).astype(np.float32)


def decode_image(data: bytes, source: str | Path) -> np.ndarray:
    """Decode encoded image bytes to ``[H, W, 4]`` float32 RGBA in ``[0, 1]`` (grey images are
    replicated to RGB, missing alpha is 1). ``source`` names the file in errors."""
    try:
        image = Image.open(io.BytesIO(data))
        image.load()
    except (UnidentifiedImageError, OSError, ValueError) as e:
        raise AssetError(source, f"cannot decode image: {e}") from None
    if image.mode in _SIXTEEN_BIT_MODES:
        grey = np.asarray(image, dtype=np.float32) / 65535.0
        return np.concatenate([np.repeat(grey[..., None], 3, axis=-1), np.ones_like(grey)[..., None]], axis=-1)
    return np.asarray(image.convert("RGBA"), dtype=np.float32) / 255.0


def read_image(path: str | Path) -> np.ndarray:
    """Read an image file as ``decode_image`` does; a missing file is an ``AssetError``."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as e:
        raise AssetError(path, f"cannot read image: {e.strerror or e}") from None
    return decode_image(data, path)


def encode_png(pixels: np.ndarray, bits: int = 8) -> bytes:
    """Encode ``[H, W, C]`` float values in ``[0, 1]`` (C = 1, 3 or 4) as an 8-bit PNG, or with
    ``bits = 16`` one channel as a 16-bit grey PNG (heights, whose steps must not show);
    values are clamped and rounded to the nearest level."""
    pixels = np.asarray(pixels, dtype=np.float32)
    if pixels.ndim != 3 or pixels.shape[-1] not in (1, 3, 4) or (bits == 16 and pixels.shape[-1] != 1):
        raise ValueError(f"encode_png needs [H, W, 1|3|4] pixels (one channel at 16 bits), got "
                         f"{tuple(pixels.shape)} at {bits} bits")
    if bits == 16:
        buffer = io.BytesIO()
        grey = np.round(np.clip(pixels[..., 0], 0.0, 1.0) * 65535.0).astype(np.uint16)
        Image.fromarray(grey).save(buffer, format="PNG")
        return buffer.getvalue()
    levels = np.round(np.clip(pixels, 0.0, 1.0) * 255.0).astype(np.uint8)
    mode = {1: "L", 3: "RGB", 4: "RGBA"}[pixels.shape[-1]]
    buffer = io.BytesIO()
    Image.fromarray(levels[..., 0] if mode == "L" else levels, mode).save(buffer, format="PNG")
    return buffer.getvalue()


BAYER_ORDER = 3
"""Ordered dithers use the ``2^BAYER_ORDER``-sided Bayer matrix (8 x 8: 64 levels)."""


def bayer_thresholds(order: int = BAYER_ORDER) -> np.ndarray:
    """``[N, N]`` (N = 2^order) thresholds ``(B + 0.5) / N^2`` of the Bayer matrix ``B``,
    ``B_{2n} = [[4 B_n, 4 B_n + 2], [4 B_n + 3, 4 B_n + 1]]`` from ``B_1 = [[0]]``: every level
    once, neighbours far apart in value (the dither's error is of high frequency)."""
    matrix = np.zeros((1, 1))
    for _ in range(order):
        matrix = np.block([[4 * matrix, 4 * matrix + 2], [4 * matrix + 3, 4 * matrix + 1]])
    return (matrix + 0.5) / matrix.size


def tiled_thresholds(height: int, width: int, shift: tuple[int, int] = (0, 0)) -> np.ndarray:
    """``bayer_thresholds`` rolled by ``shift`` (rows, columns) and tiled over ``[height, width]``
    texels."""
    side = 2 ** BAYER_ORDER
    tile = np.roll(bayer_thresholds(), shift, axis=(0, 1))
    return np.tile(tile, (-(-height // side), -(-width // side)))[:height, :width]


def dithered(pixels: np.ndarray, levels: int = 255) -> np.ndarray:
    """``pixels [H, W, C]`` in ``[0, 1]`` on the grid of ``levels`` steps: colour channels (the
    first three; never alpha, which an alpha test cuts) ordered-dithered,
    ``round(x L + d_c[i, j]) / L`` with ``d_c = tiled_thresholds - 1/2`` shifted by
    ``(3c, 5c)`` for channel ``c``; alpha rounded. Why: rounding moves a whole smooth gradient of
    a normal or roughness map onto a few levels, whose edges show as contours in highlights
    (and in perceptual error); the dither keeps each 8 x 8 block's mean, and a value already on
    a level stays exactly there (``|d| < 1/2``)."""
    pixels = np.clip(np.asarray(pixels, dtype=np.float32), 0.0, 1.0)
    h, w, channels = pixels.shape
    noise = np.zeros((h, w, channels), np.float32)
    for c in range(min(channels, 3)):
        noise[..., c] = tiled_thresholds(h, w, (3 * c, 5 * c)) - 0.5
    return np.clip(np.round(pixels * levels + noise), 0, levels) / levels


def write_png(pixels: np.ndarray, path: str | Path, bits: int = 8) -> None:
    """Write ``encode_png(pixels, bits)`` to ``path``."""
    path = Path(path)
    try:
        path.write_bytes(encode_png(pixels, bits))
    except OSError as e:
        raise AssetError(path, f"cannot write image: {e.strerror or e}") from None


def resize(pixels: np.ndarray, height: int, width: int) -> np.ndarray:
    """Bilinear resample of ``[H, W, C]`` float32 pixels to ``[height, width, C]``."""
    if pixels.shape[:2] == (height, width):
        return pixels
    channels = [
        np.asarray(Image.fromarray(np.ascontiguousarray(pixels[..., c]), "F").resize((width, height), Image.BILINEAR))
        for c in range(pixels.shape[-1])
    ]
    return np.stack(channels, axis=-1).astype(np.float32)
