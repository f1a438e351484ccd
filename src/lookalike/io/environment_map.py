"""Environment maps (latitude-longitude ``.hdr`` and ``.exr`` files) as Mitsuba reads them.

A path-traced reference lights the asset with one; a file Mitsuba cannot read would fail deep
inside the path tracer, so it is read once up front and refused with one line naming it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import AssetError
from .mitsuba_runtime import mitsuba

SUFFIXES = (".hdr", ".exr")
"""Environment map files the path tracer reads: Radiance RGBE and OpenEXR."""


def read_environment_map(path: str | Path) -> np.ndarray:
    """``[H, W, 3]`` float32 linear radiance of the environment map at ``path``; ``AssetError``
    naming the file where it is missing, not an ``.hdr`` or ``.exr``, unreadable, or holds
    values that are negative or not finite."""
    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        raise AssetError(path, "an environment map is a Radiance .hdr or an OpenEXR .exr file")
    if not path.is_file():
        raise AssetError(path, "no such environment map")
    mi = mitsuba()
    try:
        bitmap = mi.Bitmap(str(path)).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False)
    except RuntimeError:
        kind = "Radiance HDR" if path.suffix.lower() == ".hdr" else "OpenEXR"
        raise AssetError(path, f"not a readable {kind} image, so not an environment map") from None
    pixels = np.array(bitmap, dtype=np.float32).reshape(bitmap.height(), bitmap.width(), 3)
    if not np.isfinite(pixels).all() or (pixels < 0).any():
        raise AssetError(path, "an environment map with negative or non-finite radiance")
    return pixels


def write_environment_map(path: str | Path, pixels: np.ndarray) -> Path:
    """Write ``pixels`` (``[H, W, 3]`` linear radiance, latitude-longitude, row 0 the zenith)
    to ``path`` (``.hdr`` or ``.exr``, by its suffix); returns the path."""
    mitsuba().Bitmap(np.ascontiguousarray(pixels, dtype=np.float32)).write(str(path))
    return Path(path)
