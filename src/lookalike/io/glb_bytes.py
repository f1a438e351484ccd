"""Assets as ``.glb`` bytes in memory: to keep an asset compactly (a checkpoint holds PNG-coded
maps instead of float arrays) and to measure what it weighs as a file."""

from __future__ import annotations

import tempfile
from pathlib import Path

from ..asset import Asset
from .registry import load, save


def to_glb_bytes(asset: Asset) -> bytes:
    """``asset`` written as a ``.glb`` file's bytes."""
    with tempfile.TemporaryDirectory(prefix="lookalike-glb-") as folder:
        path = Path(folder) / "asset.glb"
        save(asset, path)
        return path.read_bytes()


def from_glb_bytes(data: bytes) -> Asset:
    """The asset in ``.glb`` bytes (``to_glb_bytes``)."""
    with tempfile.TemporaryDirectory(prefix="lookalike-glb-") as folder:
        path = Path(folder) / "asset.glb"
        path.write_bytes(data)
        asset = load(path)
    asset.source = None
    return asset
