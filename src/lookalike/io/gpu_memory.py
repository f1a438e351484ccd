"""What a glTF file takes in GPU memory once an engine has loaded it uncompressed: its meshes'
vertex and index buffers and its textures as RGBA8 with full mip chains. Why: a level of
detail is chosen for what it costs to hold and draw, and file bytes (PNG, quantised buffers)
say little about that."""

from __future__ import annotations

from pathlib import Path

from .gltf_data import GltfData, parse_gltf

COMPONENT_BYTES = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
"""Bytes of each glTF ``componentType``."""
TYPE_COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
MIP_CHAIN = 4 / 3
"""A full mip chain adds a third to the base level (``sum_k 4^-k``)."""


def gpu_bytes(path: str | Path) -> dict[str, int]:
    """``{"buffers", "textures", "total"}`` bytes of the glTF at ``path``: every primitive's
    attribute and index accessors (``count x components x component bytes``, each accessor
    counted once) and every image as ``width x height x 4 x 4/3``. ``AssetError`` where the
    file cannot be read."""
    path = Path(path)
    data = GltfData(parse_gltf(path), path)
    gltf = data.gltf
    accessors = set()
    for mesh in gltf.meshes:
        for primitive in mesh.primitives:
            accessors.update(i for i in vars(primitive.attributes).values() if isinstance(i, int))
            if primitive.indices is not None:
                accessors.add(primitive.indices)
    buffers = sum(gltf.accessors[i].count * TYPE_COMPONENTS[gltf.accessors[i].type]
                  * COMPONENT_BYTES[gltf.accessors[i].componentType] for i in accessors)
    textures = 0
    for index in range(len(gltf.images)):
        height, width = data.image(index).shape[:2]
        textures += round(width * height * 4 * MIP_CHAIN)
    return {"buffers": int(buffers), "textures": int(textures), "total": int(buffers + textures)}
