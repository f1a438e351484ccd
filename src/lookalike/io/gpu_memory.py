"""What a glTF file takes in GPU memory once an engine has loaded it: its meshes' vertex and
index buffers, uncompressed, and its textures with full mip chains (RGBA8, or block-compressed
where a KTX2 source is given). Why: a level of detail is chosen for what it costs to hold and
draw, and file bytes (PNG, quantised buffers) say little about that."""

from __future__ import annotations

import io
from pathlib import Path

from PIL import Image

from .gltf_data import GltfData, parse_gltf
from .ktx2 import read_ktx2

COMPONENT_BYTES = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
"""Bytes of each glTF ``componentType``."""
TYPE_COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
MIP_CHAIN = 4 / 3
"""A full mip chain adds a third to the base level (``sum_k 4^-k``)."""
RGBA8_TEXEL_BYTES = 4
BLOCK_TEXEL_BYTES = 1
"""A 4 x 4 block of 16 bytes (BC7, ASTC 4 x 4: what UASTC transcodes to)."""


def gpu_bytes(path: str | Path) -> dict[str, int]:
    """``{"buffers", "textures", "total"}`` bytes of the glTF at ``path``: every primitive's
    attribute and index accessors (``count x components x component bytes``, each accessor
    counted once) and every texture's image with a full mip chain, counted once per image: a
    KTX2 source (``KHR_texture_basisu``, which an engine that reads it draws instead of the
    fallback) as transcoded 4 x 4 blocks of 16 bytes (BC7 or ASTC, one byte per texel), other
    images as RGBA8. ``AssetError`` where the file cannot be read."""
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
    images = {}
    for texture in gltf.textures:
        basisu = (texture.extensions or {}).get("KHR_texture_basisu")
        if isinstance(basisu, dict) and basisu.get("source") is not None:
            parsed = read_ktx2(data.image_bytes(basisu["source"]))
            images[basisu["source"]] = (parsed.width, parsed.height, BLOCK_TEXEL_BYTES)
        elif texture.source is not None:
            with Image.open(io.BytesIO(data.image_bytes(texture.source))) as image:  # the header, not the pixels
                images[texture.source] = (*image.size, RGBA8_TEXEL_BYTES)
    textures = sum(round(width * height * texel * MIP_CHAIN) for width, height, texel in images.values())
    return {"buffers": int(buffers), "textures": int(textures), "total": int(buffers + textures)}
