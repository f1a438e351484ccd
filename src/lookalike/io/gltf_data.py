"""Binary data of a parsed glTF 2.0 file: buffers (GLB chunk, ``.bin`` files, ``data:`` URIs),
accessors (strided, sparse, normalized integers) and images, decoded with NumPy.

pygltflib parses the JSON and the GLB container; everything it leaves to the caller lives here.
Every problem is an ``AssetError`` naming the file.
"""

from __future__ import annotations

import base64
import json
import struct
import urllib.parse
from pathlib import Path

import numpy as np
import pygltflib

from ..errors import AssetError
from .image_files import decode_image

COMPONENT_DTYPES = {
    5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32,
}
TYPE_SIZES = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
# Normalized integers map to [0, 1] (unsigned) or [-1, 1] (signed): x / max, signed clamped at -1.
_NORMALIZERS = {np.int8: 127.0, np.uint8: 255.0, np.int16: 32767.0, np.uint16: 65535.0, np.uint32: 4294967295.0}


def _decode_uri(uri: str, base: Path, path: Path, what: str) -> bytes:
    """Bytes behind a glTF URI: a ``data:`` URI or a file relative to ``base``."""
    if uri.startswith("data:"):
        header, _, payload = uri.partition(",")
        try:
            return base64.b64decode(payload) if header.endswith(";base64") else urllib.parse.unquote_to_bytes(payload)
        except ValueError as e:
            raise AssetError(path, f"{what}: malformed data URI ({e})") from None
    file = base / urllib.parse.unquote(uri)
    try:
        return file.read_bytes()
    except OSError:
        raise AssetError(path, f"{what} '{uri}' is missing or unreadable (looked for {file})") from None


class GltfData:
    """Decoded binary content of one glTF document.

    Attributes:
        gltf: the parsed ``pygltflib.GLTF2`` document.
        path: the file it came from (for error messages and relative URIs).
        buffers: raw bytes of each ``buffers[i]``, at least ``byteLength`` long.
    """

    def __init__(self, gltf: pygltflib.GLTF2, path: Path):
        self.gltf = gltf
        self.path = path
        self.buffers = [self._load_buffer(i, b) for i, b in enumerate(gltf.buffers)]

    def _load_buffer(self, index: int, buffer: pygltflib.Buffer) -> bytes:
        if buffer.uri is None and ((buffer.extensions or {}).get("EXT_meshopt_compression") or {}).get("fallback"):
            return b""  # holds no data: what it stands for is decoded from a compressed view (io.meshopt)
        if buffer.uri is None:
            data = self.gltf.binary_blob() if index == 0 else None
            if data is None:
                raise AssetError(self.path, f"buffer {index} has no uri and there is no GLB binary chunk")
        else:
            data = _decode_uri(buffer.uri, self.path.parent, self.path, f"buffer {index}")
        if len(data) < buffer.byteLength:
            raise AssetError(self.path,
                             f"buffer {index} is truncated: {len(data)} bytes, byteLength {buffer.byteLength}")
        return data

    def buffer_view(self, index: int) -> tuple[bytes, int, int, int | None]:
        """``(buffer bytes, byteOffset, byteLength, byteStride)`` of ``bufferViews[index]``,
        checked to lie inside its buffer."""
        views = self.gltf.bufferViews
        if not 0 <= index < len(views):
            raise AssetError(self.path, f"bufferView {index} does not exist")
        view = views[index]
        if not 0 <= view.buffer < len(self.buffers):
            raise AssetError(self.path, f"bufferView {index} refers to missing buffer {view.buffer}")
        data = self.buffers[view.buffer]
        offset = view.byteOffset or 0
        if offset + view.byteLength > len(data):
            raise AssetError(self.path, f"bufferView {index} runs past the end of buffer {view.buffer} (truncated?)")
        return data, offset, view.byteLength, view.byteStride

    def _strided(self, view_index: int, extra_offset: int, dtype, ncomp: int, count: int, what: str) -> np.ndarray:
        """``[count, ncomp]`` elements read from a buffer view, honouring ``byteStride``."""
        data, offset, length, stride = self.buffer_view(view_index)
        item = np.dtype(dtype).itemsize
        stride = stride or item * ncomp
        needed = extra_offset + stride * (count - 1) + item * ncomp if count else 0
        if needed > length:
            raise AssetError(self.path, f"{what} needs {needed} bytes but its bufferView has {length} (truncated?)")
        raw = np.frombuffer(data, dtype=np.uint8, count=length, offset=offset)
        rows = np.lib.stride_tricks.as_strided(raw[extra_offset:], shape=(count, ncomp * item), strides=(stride, 1))
        return np.ascontiguousarray(rows).view(dtype).reshape(count, ncomp)

    def accessor(self, index: int) -> np.ndarray:
        """Values of ``accessors[index]`` as ``[count, ncomp]`` (SCALAR: ``[count]``) arrays:
        float32 where the accessor is float or normalized, int64 otherwise; sparse
        substitutions applied; a view-less accessor starts from zeros."""
        accessors = self.gltf.accessors
        if index is None or not 0 <= index < len(accessors):
            raise AssetError(self.path, f"accessor {index} does not exist")
        acc = accessors[index]
        what = f"accessor {index}"
        if acc.componentType not in COMPONENT_DTYPES or acc.type not in TYPE_SIZES:
            raise AssetError(self.path, f"{what} has unknown componentType {acc.componentType} or type {acc.type}")
        dtype = COMPONENT_DTYPES[acc.componentType]
        ncomp = TYPE_SIZES[acc.type]
        if acc.bufferView is None:
            values = np.zeros((acc.count, ncomp), dtype=dtype)
        else:
            values = self._strided(acc.bufferView, acc.byteOffset or 0, dtype, ncomp, acc.count, what)
        if acc.sparse is not None and acc.sparse.count:
            values = values.copy()
            sparse = acc.sparse
            idx_dtype = COMPONENT_DTYPES.get(sparse.indices.componentType)
            if idx_dtype is None:
                raise AssetError(self.path, f"{what}: sparse indices have componentType {sparse.indices.componentType}")
            where = self._strided(sparse.indices.bufferView, sparse.indices.byteOffset or 0, idx_dtype, 1,
                                  sparse.count, f"{what} sparse indices")[:, 0].astype(np.int64)
            if where.size and (where.min() < 0 or where.max() >= acc.count):
                raise AssetError(self.path, f"{what}: sparse index out of range")
            values[where] = self._strided(sparse.values.bufferView, sparse.values.byteOffset or 0, dtype, ncomp,
                                          sparse.count, f"{what} sparse values")
        if dtype is np.float32:
            out = values.astype(np.float32)
        elif acc.normalized:
            out = np.maximum(values.astype(np.float32) / np.float32(_NORMALIZERS[dtype]), -1.0)
        else:
            out = values.astype(np.int64)
        return out[:, 0] if acc.type == "SCALAR" else out

    def image_bytes(self, index: int) -> bytes:
        """The encoded bytes (PNG, JPEG, KTX2, ...) of ``images[index]``, from its bufferView or uri."""
        images = self.gltf.images
        if not 0 <= index < len(images):
            raise AssetError(self.path, f"image {index} does not exist")
        image = images[index]
        if image.bufferView is not None:
            data, offset, length, _ = self.buffer_view(image.bufferView)
            return data[offset:offset + length]
        if image.uri:
            return _decode_uri(image.uri, self.path.parent, self.path, "texture")
        raise AssetError(self.path, f"image {index} has neither uri nor bufferView")

    def image(self, index: int) -> np.ndarray:
        """``images[index]`` decoded to ``[H, W, 4]`` float32 RGBA in ``[0, 1]`` (not linearised)."""
        encoded = self.image_bytes(index)
        return decode_image(encoded, f"{self.path} (image {self.gltf.images[index].uri or index})")


def parse_gltf(path: Path) -> pygltflib.GLTF2:
    """Parse a ``.gltf`` or ``.glb`` container with pygltflib; any failure is an ``AssetError``."""
    try:
        with open(path, "rb") as f:
            head = f.read(4)
        if head == b"glTF":
            gltf = pygltflib.GLTF2.load_binary(str(path))
        else:
            gltf = pygltflib.GLTF2.load_json(str(path))
    except OSError as e:
        raise AssetError(path, f"cannot read file: {e.strerror or e}") from None
    except Exception as e:  # pygltflib raises bare exceptions of many kinds on malformed input
        raise AssetError(path, f"not a valid glTF file ({type(e).__name__}: {e})") from None
    if gltf is None:
        raise AssetError(path, "not a valid glTF file")
    return gltf


def triangle_count(path: str | Path) -> int:
    """Triangles of the glTF at ``path`` read from its JSON alone (a ``.glb``'s binary chunk is
    not read), each mesh counted once: a triangle-list primitive's index count (else its vertex
    count) / 3; 0 for what cannot be read. For sizing a tool's work, not for checking a file."""
    try:
        with open(path, "rb") as f:
            head = f.read(20)
            if head[:4] == b"glTF":
                doc = json.loads(f.read(struct.unpack_from("<I", head, 12)[0]))
            else:
                doc = json.loads(head + f.read())
        accessors = doc.get("accessors", [])
        total = 0
        for mesh in doc.get("meshes", []):
            for primitive in mesh.get("primitives", []):
                if primitive.get("mode", 4) == 4:
                    total += accessors[primitive.get("indices", primitive["attributes"]["POSITION"])]["count"] // 3
        return total
    except (OSError, ValueError, KeyError, IndexError, TypeError, AttributeError, struct.error):
        return 0
