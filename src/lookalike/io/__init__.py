"""Reading and writing assets. ``load(path)`` and ``save(asset, path)`` pick the format by
file extension; each format lives in its own module and registers itself on import."""

from . import gltf_read, gltf_write, obj, ply  # noqa: F401  (register their readers and writers)
from .registry import load, readable_extensions, save, writable_extensions

__all__ = ["load", "readable_extensions", "save", "writable_extensions"]
