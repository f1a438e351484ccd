"""A chain of levels of detail in one ``.glb``, as the ``MSFT_lod`` glTF extension lays it out.

``MSFT_lod`` on a node names, in its ``ids`` array, the nodes that stand for it at lower levels
of detail, finest first; those nodes are in no scene, so a viewer that does not know the
extension shows the finest level alone (the extension is listed in ``extensionsUsed``, not
``extensionsRequired``). ``extras.MSFT_screencoverage`` on the same node holds one value per
level: level ``k`` is drawn while the object covers between value ``k - 1`` (1 for level 0) and
value ``k`` of the viewport's height, and nothing below the last value. One file holding every
level lets an engine build its LOD group from a single import; nodes are named ``NAME_LOD0`` ...
``NAME_LODn``, the suffix by which Unity's and Unreal's importers group levels.

Each level is written as ``write_glb`` writes an asset (``gltf_write.add_mesh``): its own mesh,
materials and textures (a texture shared by several levels is stored once), no transform.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path

from ..asset import Asset
from .gltf_write import GlbBuilder, add_mesh


def write_lod_chain(levels: list[Asset], path: str | Path, name: str, coverages: list[float],
                    ktx2_only: bool = False) -> Path:
    """Write ``levels`` (finest first) as one ``.glb`` whose scene holds level 0's node, with
    ``MSFT_lod`` pointing to the other levels' nodes (see the module docstring).

    Args:
        levels: still assets (no skin), level 0 the finest.
        path: the ``.glb`` file to write.
        name: node and mesh names are ``{name}_LOD{k}``.
        coverages: one value per level, strictly descending in [0, 1]: the fraction of the
            viewport's height below which level ``k`` gives way to level ``k + 1`` (to nothing
            after the last level).
        ktx2_only: textures with mip levels as KTX2 alone (``gltf_write.write_glb``).

    Returns:
        ``path`` as a ``Path``.

    Raises:
        ValueError: no levels, a number of coverages other than the number of levels, coverages
            not strictly descending in [0, 1], or a skinned level.
        AssetError: the file cannot be written.
    """
    if not levels:
        raise ValueError("write_lod_chain needs at least one level")
    if len(coverages) != len(levels):
        raise ValueError(f"{len(levels)} levels need {len(levels)} screen coverages, got {len(coverages)}")
    values = [float(c) for c in coverages]
    if not all(0.0 <= c <= 1.0 for c in values) or any(a <= b for a, b in zip(values, values[1:])):
        raise ValueError(f"screen coverages must descend strictly within [0, 1], got {values}")
    if any(level.skin is not None and level.mesh.v_joints is not None for level in levels):
        raise ValueError("write_lod_chain writes still assets; a level has a skin")

    builder = GlbBuilder(ktx2_only)
    nodes = []
    for k, level in enumerate(levels):
        level_name = f"{name}_LOD{k}"
        nodes.append({"name": level_name, "mesh": add_mesh(builder, level, level_name)})
    if len(levels) > 1:
        nodes[0]["extensions"] = {"MSFT_lod": {"ids": list(range(1, len(levels)))}}
        builder.extensions.add("MSFT_lod")
    nodes[0]["extras"] = {"MSFT_screencoverage": values}
    builder.doc["nodes"] = nodes
    builder.doc["scenes"] = [{"nodes": [0]}]
    builder.doc["scene"] = 0
    path = Path(path)
    builder.write(path)
    return path


def relink_lod_chain(path: str | Path) -> None:
    """Give the chain at ``path`` its ``MSFT_lod`` links back after a tool that does not know the
    extension rewrote the file (gltfpack keeps named nodes and extras but drops the extension):
    the node holding ``extras.MSFT_screencoverage``, named ``NAME_LOD0``, links the nodes named
    ``NAME_LOD1 ...`` in order. The binary chunk is kept as it is."""
    path = Path(path)
    data = path.read_bytes()
    length = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + length])
    nodes = doc.get("nodes", [])
    index = {node.get("name"): k for k, node in enumerate(nodes)}
    top = next(k for k, node in enumerate(nodes) if "MSFT_screencoverage" in (node.get("extras") or {}))
    name = nodes[top]["name"].removesuffix("_LOD0")
    ids = [index[f"{name}_LOD{k}"] for k in range(1, len(nodes[top]["extras"]["MSFT_screencoverage"]))]
    if ids:
        nodes[top].setdefault("extensions", {})["MSFT_lod"] = {"ids": ids}
        doc["extensionsUsed"] = sorted(set(doc.get("extensionsUsed", [])) | {"MSFT_lod"})
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    rest = data[20 + length:]
    head = struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(text) + len(rest)) + struct.pack("<I4s", len(text), b"JSON")
    path.write_bytes(head + text + rest)
