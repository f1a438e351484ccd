"""File formats registered by extension: ``load(path) -> Asset`` and ``save(asset, path)``.

Each format module registers its reader and/or writer with ``@reader(".ext")`` /
``@writer(".ext")``; ``lookalike.io`` imports them all.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

from ..asset import Asset
from ..errors import AssetError

Reader = Callable[[Path], Asset]
Writer = Callable[[Asset, Path], None]

_READERS: dict[str, Reader] = {}
_WRITERS: dict[str, Writer] = {}


def reader(*extensions: str):
    """Decorator registering ``fn(path) -> Asset`` for the given lower-case extensions."""
    def register(fn: Reader) -> Reader:
        for ext in extensions:
            _READERS[ext] = fn
        return fn
    return register


def writer(*extensions: str):
    """Decorator registering ``fn(asset, path)`` for the given lower-case extensions."""
    def register(fn: Writer) -> Writer:
        for ext in extensions:
            _WRITERS[ext] = fn
        return fn
    return register


def readable_extensions() -> list[str]:
    return sorted(_READERS)


def writable_extensions() -> list[str]:
    return sorted(_WRITERS)


def load(path: str | Path) -> Asset:
    """Read an asset file of any registered format. Raises ``AssetError`` naming the file."""
    path = Path(path)
    if not path.exists():
        raise AssetError(path, "no such file")
    if not path.is_file():
        raise AssetError(path, "not a file")
    ext = path.suffix.lower()
    if ext not in _READERS:
        raise AssetError(path, f"unknown format {ext!r}; readable: {', '.join(readable_extensions())}")
    asset = _READERS[ext](path)
    asset.source = path
    return asset


def save(asset: Asset, path: str | Path) -> None:
    """Write ``asset`` in the format given by ``path``'s extension."""
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in _WRITERS:
        raise AssetError(path, f"cannot write {ext!r}; writable: {', '.join(writable_extensions())}")
    _WRITERS[ext](asset, path)
