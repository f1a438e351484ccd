"""Reading and writing assets. ``load(path)`` and ``save(asset, path)`` pick the format by
file extension; each format lives in its own module and registers itself on import.

Formats: ``gltf_read`` (.gltf, .glb), ``gltf_write`` (.glb), ``obj`` (+ ``mtl``; .obj read and
write), ``ply`` (.ply read), ``mitsuba_xml`` (.xml read: a Mitsuba 3 scene's meshes and BSDFs), ``field_python`` (.py: a signed distance field in Python, read as its
marching-cubes mesh with the field attached, ``field_asset``). Shared pieces: ``gltf_data`` (buffers, accessors, images of a glTF),
``images`` (PNG/JPEG, sRGB), ``mikktspace`` (MikkTSpace tangent frames), ``normal_frames``
(normal maps between tangent frames), ``transforms``, ``arrays``, ``atomic`` (files that appear
complete or not at all).
"""

from . import field_glsl, field_python, gltf_read, gltf_write, mitsuba_xml, obj, ply  # noqa: F401  (register their readers and writers)
from .registry import load, readable_extensions, save, writable_extensions

__all__ = ["load", "readable_extensions", "save", "writable_extensions"]
