"""Binary glTF 2.0 (``.glb``) writer: one mesh with a primitive per material, PNG textures
embedded in the binary chunk (8-bit colour ordered-dithered, ``io.image_files.dithered``, so that smooth
maps do not band).

Vertices are unwelded per distinct corner (position, normal slot, UVs, MikkTSpace tangent), as glTF
needs one index buffer. NORMAL holds the shading normals lookalike renders with (``Mesh.normals``:
the authored ones, or split smooth normals); TANGENT holds MikkTSpace tangents of the written mesh
(on those normals, so they follow hard edges), and normal maps are converted into that frame, so
clients that read TANGENT and clients that compute MikkTSpace (Blender, the glTF specification's
default) decode the same normals. TANGENT follows the UV set of the first normal map; a normal map
on another UV set is converted to MikkTSpace of its own set, which only MikkTSpace-computing
clients then decode exactly.

Material channels: base colour (+ alpha) as ``baseColorFactor`` or an sRGB PNG; ``ks`` as
``roughnessFactor``/``metallicFactor`` or one RGBA PNG used both as ``metallicRoughnessTexture``
(R = 1, G = roughness, B = metalness) and as KHR_materials_specular ``specularTexture`` (A =
``1 - gamma``); a constant ``gamma != 0`` becomes ``specularFactor = 1 - gamma``. Note that glTF's
specular factor scales only the dielectric lobe, while the paper's ``gamma`` also scales metals.
1x1 (constant) textures are written as factors (a normal map only where it is flat, ``(0, 0, 1)``:
glTF has no normal factor, so a constant tilt stays a texture). An unlit material (``Material.unlit``) is a
``KHR_materials_unlit`` material whose base colour is its emission (clipped to [0, 1]); the
asset's point lights are ``KHR_lights_punctual`` lights on nodes of their own. Emission is ``emissiveFactor``/``emissiveTexture``
(sRGB), divided by its largest value where that exceeds 1, which KHR_materials_emissive_strength
then holds. Occlusion is ``occlusionTexture`` (R): in the R channel of the metallic-roughness
image (an ORM image) where both share size, UV set, transform and wrap mode, else an image of
its own. A displacement map (``Material.displacement``) is a 16-bit PNG texture named in the
material's ``extras.displacement`` with its scale, offset, level and shading convention (no glTF
extension holds one). A texture with mip levels of its own (``Texture.mips``: fitted, prefiltered) is also
written as a KTX2 mip chain of exactly those levels (UASTC, ``io.ktx2``) through
``KHR_texture_basisu`` where the ``basisu`` encoder is found, the PNG staying the fallback for
viewers without a transcoder (which then build box-filtered mips from it); with ``ktx2_only``,
the KTX2 alone (``KHR_texture_basisu`` required), as a compressed model ships.

Unskinned assets are one mesh node with no transform (the geometry is in the asset's frame).
Skinned assets keep every node of their ``Skin`` (so joint indices and animation targets keep
their meaning), the skin and the animations, written as held: a file read with one skin keeps
its joint list, node names, hierarchy and TRS values, and the float32 data of its inverse bind
matrices and animation samplers byte for byte. Skinned meshes are written in the frame their
inverse bind matrices expect: ``inv(mesh_to_world)`` applied to the positions, normals and
tangents transformed to match (tangents are MikkTSpace of the asset-frame data, computed
before), on the node that held the skinned mesh in the file read (``Skin.mesh_node``, where it is
a leaf; else a new root node), with no transform (glTF ignores a skinned mesh node's transform).
Weights whose rows sum to 1 to float32 rounding are written as given, others renormalised;
influences are written in sets of 4 (JOINTS_k / WEIGHTS_k), the last padded with weight 0.

``GlbBuilder`` and ``add_mesh`` also serve files of several meshes (``gltf_lod_chain``).
"""

from __future__ import annotations

import dataclasses
import json
import struct
from pathlib import Path

import numpy as np
import torch

from ..asset import Asset, Material, Texture
from ..asset.material import Displacement
from ..errors import AssetError, ConfigError
from .arrays import constant_texel, unique_rows
from .image_files import dithered, encode_png, linear_to_srgb, resize
from .ktx2 import ENCODER_HINT, encode_mip_chain, find_encoder
from .mikktspace import mikktspace_tangents
from .normal_frames import export_normal_maps
from .registry import writer

_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
_FLOAT, _UNSIGNED_SHORT, _UNSIGNED_INT = 5126, 5123, 5125
_TYPES = {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4", 16: "MAT4"}
_WRAP = {"wrap": 10497, "clamp": 33071}


class GlbBuilder:
    """Accumulates the JSON document and the binary chunk of a GLB file."""

    def __init__(self, ktx2_only: bool = False):
        self.doc: dict = {"asset": {"version": "2.0", "generator": "lookalike"}, "buffers": [],
                          "bufferViews": [], "accessors": []}
        self.chunks: list[bytes] = []
        self.length = 0
        self.extensions: set[str] = set()
        self.required: set[str] = set()
        self.texture_cache: dict[tuple, int] = {}
        self.encoder = find_encoder()
        self.ktx2_only = ktx2_only
        if ktx2_only and self.encoder is None:
            raise ConfigError(f"KTX2 textures need {ENCODER_HINT}")

    def view(self, data: bytes, target: int | None = None) -> int:
        """Append ``data`` (4-byte aligned) as a bufferView; returns its index."""
        pad = -self.length % 4
        self.chunks.append(b"\0" * pad)
        self.length += pad
        view = {"buffer": 0, "byteOffset": self.length, "byteLength": len(data)}
        if target is not None:
            view["target"] = target
        self.chunks.append(data)
        self.length += len(data)
        self.doc["bufferViews"].append(view)
        return len(self.doc["bufferViews"]) - 1

    def accessor(self, values: np.ndarray, component: int, target: int | None = None, bounds: bool = False,
                 normalized: bool = False, matrix: bool = False) -> int:
        """Append ``values [n, k]`` (or ``[n]``) as an accessor; ``bounds`` adds min/max."""
        dtype = {_FLOAT: np.float32, _UNSIGNED_SHORT: np.uint16, _UNSIGNED_INT: np.uint32}[component]
        values = np.ascontiguousarray(values, dtype=dtype)
        rows = values.reshape(len(values), -1)
        acc = {"bufferView": self.view(values.tobytes(), target), "componentType": component,
               "count": len(values), "type": "MAT4" if matrix else _TYPES[rows.shape[1]]}
        if normalized:
            acc["normalized"] = True
        if bounds:
            acc["min"] = rows.min(axis=0).tolist()
            acc["max"] = rows.max(axis=0).tolist()
        self.doc["accessors"].append(acc)
        return len(self.doc["accessors"]) - 1

    def texture(self, pixels: np.ndarray, wrap: str, key: tuple, mips: list[np.ndarray] | None = None,
                linear: bool = True, bits: int = 8) -> int:
        """Index of a texture holding ``pixels [H, W, C]`` (values in [0, 1], already encoded),
        written once per ``key`` (a tensor in it counts by identity, and the key keeps it alive,
        so a texture freed while the file is built cannot pass its identity to another). With
        ``mips`` (levels 1.. encoded alike) and a KTX2 encoder (``io.ktx2.find_encoder``), the
        chain is also written as KTX2 (``linear``: non-colour data) through
        ``KHR_texture_basisu``, the PNG staying the fallback source (with ``ktx2_only``, the KTX2
        alone, and the extension required); ``bits``: the PNG's depth
        (``io.image_files.encode_png``), an 8-bit PNG's colour ordered-dithered
        (``io.image_files.dithered``)."""
        if key not in self.texture_cache:
            alone = bool(mips) and self.ktx2_only
            texture = {} if alone else {"source": self.image(encode_png(dithered(pixels) if bits == 8 else pixels, bits),
                                                             "image/png")}
            if mips and self.encoder is not None:
                chain = [_rgba8(level) for level in (pixels, *mips)]
                ktx2 = self.image(encode_mip_chain(chain, linear, self.encoder), "image/ktx2")
                texture["extensions"] = {"KHR_texture_basisu": {"source": ktx2}}
                self.extensions.add("KHR_texture_basisu")
                if alone:
                    self.required.add("KHR_texture_basisu")
            samplers = self.doc.setdefault("samplers", [])
            sampler = {"magFilter": 9729, "minFilter": 9987, "wrapS": _WRAP[wrap], "wrapT": _WRAP[wrap]}
            if sampler not in samplers:
                samplers.append(sampler)
            texture["sampler"] = samplers.index(sampler)
            self.doc.setdefault("textures", []).append(texture)
            self.texture_cache[key] = len(self.doc["textures"]) - 1
        return self.texture_cache[key]

    def image(self, data: bytes, mime_type: str) -> int:
        """Append an image of ``data`` (``mime_type``) in a bufferView; returns its index."""
        self.doc.setdefault("images", []).append({"bufferView": self.view(data), "mimeType": mime_type})
        return len(self.doc["images"]) - 1

    def glb(self) -> bytes:
        """The GLB container: 12-byte header, JSON chunk (space padded), BIN chunk (zero padded)."""
        binary = b"".join(self.chunks)
        binary += b"\0" * (-len(binary) % 4)
        doc = dict(self.doc, buffers=[{"byteLength": len(binary)}])
        if self.extensions:
            doc["extensionsUsed"] = sorted(self.extensions)
        if self.required:
            doc["extensionsRequired"] = sorted(self.required)
        if not binary:  # glTF allows no empty arrays and no empty buffer: a file with no data has neither
            doc = {key: value for key, value in doc.items() if key not in ("buffers", "bufferViews", "accessors")}
        text = json.dumps(doc, separators=(",", ":")).encode()
        text += b" " * (-len(text) % 4)
        chunk = struct.pack("<I4s", len(binary), b"BIN\0") + binary if binary else b""
        total = 12 + 8 + len(text) + len(chunk)
        return struct.pack("<4sII", b"glTF", 2, total) + struct.pack("<I4s", len(text), b"JSON") + text + chunk

    def write(self, path: Path) -> None:
        """Write the GLB container to ``path``; ``AssetError`` where the file cannot be written."""
        try:
            path.write_bytes(self.glb())
        except OSError as e:
            raise AssetError(path, f"cannot write file: {e.strerror or e}") from None


def _rgba8(pixels: np.ndarray) -> np.ndarray:
    """``[H, W, C]`` values in [0, 1] as ``[H, W, 4]`` uint8 RGBA (missing channels: G = B = R
    for one channel, alpha 1)."""
    rgba = np.ones(pixels.shape[:2] + (4,), np.float32)
    rgba[..., :3] = pixels[..., :3] if pixels.shape[-1] >= 3 else pixels[..., :1]
    if pixels.shape[-1] == 4:
        rgba[..., 3] = pixels[..., 3]
    return np.round(np.clip(rgba, 0, 1) * 255).astype(np.uint8)


def _texture_info(builder: GlbBuilder, texture: Texture, encode, channel: str, linear: bool = True) -> dict:
    """A glTF textureInfo for ``texture``, its texels (and own mip levels) written as
    ``encode([h, w, C] array)`` gives them, with KHR_texture_transform."""
    pixels = encode(texture.data.detach().numpy())
    mips = [encode(level.detach().numpy()) for level in texture.mips] if texture.mips else None
    info = {"index": builder.texture(pixels, texture.wrap, (texture.data, channel), mips, linear)}
    if texture.uv_set:
        info["texCoord"] = texture.uv_set
    if texture.transform is not None:
        m = texture.transform.detach().double().numpy()
        # m[:2, :2] = R S with R = [[c, s], [-s, c]]: column 0 = sx (c, -s), column 1 = sy (s, c).
        sx = float(np.hypot(m[0, 0], m[1, 0]))
        rotation = float(np.arctan2(-m[1, 0], m[0, 0]))
        sy = float(np.sign(np.linalg.det(m[:2, :2])) or 1.0) * float(np.hypot(m[0, 1], m[1, 1]))
        info["extensions"] = {"KHR_texture_transform": {
            "offset": [float(m[0, 2]), float(m[1, 2])], "rotation": rotation, "scale": [sx, sy]}}
        builder.extensions.add("KHR_texture_transform")
    return info


def _same_layout(a: Texture, b: Texture) -> bool:
    """Whether ``a`` and ``b`` can share one image: same size, UV set, transform and wrap mode."""
    if a.data.shape[:2] != b.data.shape[:2] or a.uv_set != b.uv_set or a.wrap != b.wrap:
        return False
    if a.transform is None or b.transform is None:
        return a.transform is None and b.transform is None
    return bool(np.array_equal(a.transform.detach().numpy(), b.transform.detach().numpy()))


def _unlit_material(builder: GlbBuilder, material: Material, has_uv: bool) -> dict:
    """glTF ``KHR_materials_unlit`` material JSON for an unlit ``material``: its emission, clipped
    to [0, 1], as the base colour, with its alpha."""
    emission = (material.emissive.data.detach().float() if material.emissive is not None
                else torch.zeros(1, 1, 3)).clamp(0.0, 1.0)
    alpha = material.kd.data.detach().float()[..., 3:4]
    if alpha.shape[:2] != emission.shape[:2]:
        size = max(alpha.shape[:2], emission.shape[:2])
        alpha = torch.from_numpy(resize(alpha.numpy(), *size))
        emission = torch.from_numpy(resize(emission.numpy(), *size))
    colour = Material(name=material.name, kd=dataclasses.replace(material.kd, data=torch.cat([emission, alpha], -1),
                                                                 mips=None),
                      ks=Texture.constant([0.0, 1.0, 0.0]), alpha_mode=material.alpha_mode,
                      alpha_cutoff=material.alpha_cutoff, double_sided=material.double_sided)
    out = _material(builder, colour, has_uv)
    out.setdefault("extensions", {})["KHR_materials_unlit"] = {}
    builder.extensions.add("KHR_materials_unlit")
    return out


def _material(builder: GlbBuilder, material: Material, has_uv: bool) -> dict:
    """glTF material JSON for ``material`` (textures written to ``builder``)."""
    if material.unlit:
        return _unlit_material(builder, material, has_uv)
    def constant_or_mean(texture: Texture) -> np.ndarray | None:
        value = constant_texel(texture)
        if value is None and not has_uv:  # a texture without UVs to map it: its mean colour
            value = texture.data.detach().reshape(-1, texture.channels).mean(0).double().numpy()
        return value

    pbr: dict = {}
    out: dict = {"name": material.name, "pbrMetallicRoughness": pbr}
    kd = constant_or_mean(material.kd)
    if kd is not None:
        pbr["baseColorFactor"] = np.clip(kd, 0, 1).tolist()
    else:
        opaque = bool(np.all(material.kd.data.detach().numpy()[..., 3] == 1.0))

        def srgb_colour(data: np.ndarray) -> np.ndarray:
            rgb = linear_to_srgb(data[..., :3])
            return rgb if opaque else np.concatenate([rgb, data[..., 3:]], axis=-1)

        pbr["baseColorTexture"] = _texture_info(builder, material.kd, srgb_colour, "kd", linear=False)
    ks = constant_or_mean(material.ks)
    orm = material.occlusion is not None and _same_layout(material.occlusion, material.ks)
    if ks is not None:
        pbr["roughnessFactor"] = float(np.clip(ks[1], 0, 1))
        pbr["metallicFactor"] = float(np.clip(ks[2], 0, 1))
        if ks[0] != 0:
            out.setdefault("extensions", {})["KHR_materials_specular"] = {
                "specularFactor": float(np.clip(1 - ks[0], 0, 1))}
    else:
        gamma = material.ks.data.detach().numpy()[..., 0]
        varies = not np.all(gamma == gamma.flat[0])
        occlusion = material.occlusion.data.detach().numpy()[..., :1] if orm else None

        def orm_pixels(data: np.ndarray) -> np.ndarray:
            red = (np.ones_like(data[..., 0]) if occlusion is None
                   else resize(occlusion.astype(np.float32), *data.shape[:2])[..., 0])
            return np.stack([red, data[..., 1], data[..., 2]] + ([1.0 - data[..., 0]] if varies else []), -1)

        info = _texture_info(builder, material.ks, orm_pixels, "ks")
        pbr["metallicRoughnessTexture"] = info
        if orm:
            out["occlusionTexture"] = dict(info)
        if varies:
            out.setdefault("extensions", {})["KHR_materials_specular"] = {"specularTexture": dict(info)}
        elif gamma.flat[0] != 0:
            out.setdefault("extensions", {})["KHR_materials_specular"] = {
                "specularFactor": float(np.clip(1 - gamma.flat[0], 0, 1))}
    if "KHR_materials_specular" in out.get("extensions", {}):
        builder.extensions.add("KHR_materials_specular")
    if material.normal is not None and has_uv and not _flat(material.normal):
        out["normalTexture"] = _texture_info(builder, material.normal, lambda data: data * 0.5 + 0.5, "normal")
    if material.emissive is not None:
        ke = constant_or_mean(material.emissive)
        if ke is not None:
            strength = max(float(ke.max()), 1.0)
            out["emissiveFactor"] = (np.clip(ke, 0, None) / strength).tolist()
            if strength > 1.0:
                out.setdefault("extensions", {})["KHR_materials_emissive_strength"] = {"emissiveStrength": strength}
                builder.extensions.add("KHR_materials_emissive_strength")
        else:
            strength = max(float(material.emissive.data.detach().max()), 1.0)
            out["emissiveFactor"] = [1.0, 1.0, 1.0]
            out["emissiveTexture"] = _texture_info(
                builder, material.emissive, lambda data: linear_to_srgb(np.clip(data, 0, None) / strength), "emissive",
                linear=False)
            if strength > 1.0:
                out.setdefault("extensions", {})["KHR_materials_emissive_strength"] = {"emissiveStrength": strength}
                builder.extensions.add("KHR_materials_emissive_strength")
    if material.occlusion is not None and has_uv and "occlusionTexture" not in out:
        value = constant_texel(material.occlusion)
        if value is None or value[0] < 1.0:  # occlusion 1 everywhere is no occlusion
            out["occlusionTexture"] = _texture_info(builder, material.occlusion,
                                                    lambda data: np.clip(data[..., :1], 0, 1), "occlusion")
    if material.alpha_mode != "OPAQUE":
        out["alphaMode"] = material.alpha_mode
    if material.alpha_mode == "MASK":
        out["alphaCutoff"] = float(material.alpha_cutoff)
    if material.double_sided:
        out["doubleSided"] = True
    if material.displacement is not None and has_uv:
        out["extras"] = {"displacement": _displacement(builder, material.displacement)}
    return out


def _displacement(builder: GlbBuilder, displacement: Displacement) -> dict:
    """The material's ``extras.displacement``: its 16-bit height texture (UV set 0), ``scale``
    and ``offset`` (a vertex moves by ``scale * (h - offset)`` along its normal) and the
    ``level`` the file's model is drawn at, and its ``detail_level`` where it has one."""
    data = displacement.heights.data
    index = builder.texture(np.clip(data.detach().numpy()[..., :1], 0, 1), "clamp", (data, "displacement"), bits=16)
    entry = {"texture": {"index": index}, "scale": float(displacement.scale), "offset": float(displacement.offset),
             "level": int(displacement.level), "shading": displacement.shading}
    if displacement.detail_level is not None:
        entry["detail_level"] = int(displacement.detail_level)
    return entry


def _unit(x: np.ndarray) -> np.ndarray:
    """``[n, 3]`` float32 rows of ``x`` scaled to unit length (computed in float64)."""
    x = x.astype(np.float64)
    return (x / np.maximum(np.linalg.norm(x, axis=1, keepdims=True), 1e-30)).astype(np.float32)


def _to_mesh_frame(mesh_to_world: np.ndarray, positions: np.ndarray, normals: np.ndarray,
                   tangents: np.ndarray | None, indices: np.ndarray):
    """Vertex data in the asset's frame moved into the frame a skin's inverse bind matrices expect,
    by ``inv(mesh_to_world)`` (``[4, 4]`` float64, linear part ``L``): positions ``[n, 3]``
    (float64, then float32), normals ``[n, 3]`` by ``L^T`` and tangents ``[n, 4]`` xyz by
    ``inv(L)``, both renormalised. A mirroring ``L`` (negative determinant) also flips the
    tangents' handedness and the winding of ``indices [t, 3]``, undoing the reader's flip on load.
    Returns ``(positions, normals, tangents, indices)``."""
    linear = mesh_to_world[:3, :3]
    to_mesh = np.linalg.inv(mesh_to_world)
    positions = (positions.astype(np.float64) @ to_mesh[:3, :3].T + to_mesh[:3, 3]).astype(np.float32)
    normals = _unit(normals @ linear)
    mirror = np.linalg.det(linear) < 0
    if tangents is not None:
        handedness = -tangents[:, 3:] if mirror else tangents[:, 3:]
        tangents = np.concatenate([_unit(tangents[:, :3] @ to_mesh[:3, :3].T), handedness], axis=1)
    return positions, normals, tangents, indices[:, [0, 2, 1]] if mirror else indices


def _normalized_weights(weights: np.ndarray) -> np.ndarray:
    """``[n, K]`` float32 skinning weights whose rows sum to 1: rows that do to float32 rounding
    (within 1e-7 per non-zero weight, half the Khronos validator's tolerance) are kept as given,
    the others divided by their sum in float64; all-zero rows stay zero."""
    sums = weights.astype(np.float64).sum(axis=1, keepdims=True)
    off = (np.abs(sums - 1.0) > 1e-7 * np.count_nonzero(weights, axis=1)[:, None]) & (sums > 0)
    return np.where(off, weights / np.where(off, sums, 1.0), weights).astype(np.float32)


def _skin(builder: GlbBuilder, asset: Asset) -> list[dict]:
    """Write skin 0 and the animations to ``builder``; returns the JSON of the skin's nodes
    (the caller appends the mesh node). Joints, inverse bind matrices, node TRS and animation
    samplers are written as held (float32), unchanged from a file read with one skin. glTF joints
    are distinct nodes: a node that is the joint of several slots (skins joined on load with
    different inverse bind matrices) gets, for each repeat, a child node with no transform."""
    skin = asset.skin
    nodes = [{"name": n.name, "translation": n.translation.tolist(), "rotation": n.rotation.tolist(),
              "scale": n.scale.tolist()} for n in skin.nodes]
    for i, node in enumerate(skin.nodes):
        if node.parent >= 0:
            nodes[node.parent].setdefault("children", []).append(i)
    joints, seen = skin.joints.tolist(), set()
    for k, j in enumerate(joints):
        if j in seen:
            nodes.append({"name": nodes[j]["name"]})
            nodes[j].setdefault("children", []).append(len(nodes) - 1)
            joints[k] = len(nodes) - 1
        seen.add(j)
    ibm = skin.inverse_bind.detach().float().numpy().transpose(0, 2, 1)  # column-major
    out = {"joints": joints, "inverseBindMatrices": builder.accessor(ibm.reshape(-1, 16), _FLOAT, matrix=True)}
    if skin.skeleton is not None:
        out["skeleton"] = skin.skeleton
    if skin.name:
        out["name"] = skin.name
    builder.doc["skins"] = [out]
    animations = []
    for anim in asset.animations:
        samplers, channels = [], []
        for ch in anim.channels:
            times = ch.times.detach().numpy().astype(np.float32)
            samplers.append({"input": builder.accessor(times, _FLOAT, bounds=True),
                             "output": builder.accessor(ch.values.detach().numpy(), _FLOAT),
                             "interpolation": ch.interpolation})
            channels.append({"sampler": len(samplers) - 1, "target": {"node": ch.node, "path": ch.path}})
        if channels:
            animations.append({"name": anim.name, "samplers": samplers, "channels": channels})
    if animations:
        builder.doc["animations"] = animations
    return nodes


def add_mesh(builder: GlbBuilder, asset: Asset, name: str, skinned: bool = False) -> int:
    """Append ``asset``'s mesh (a primitive per material its triangles use, named ``name``) and
    those materials to ``builder``; returns the mesh's index. ``skinned`` writes JOINTS/WEIGHTS in
    the frame of the skin's inverse bind matrices (the caller writes the skin)."""
    mesh = asset.mesh.detach()
    v_nrm, t_nrm_idx = mesh.normals()
    n_tris = mesh.num_triangles
    corner_keys = [t.numpy().reshape(-1, 1) for t in (mesh.t_pos_idx, t_nrm_idx, *(t for _, t in mesh.uv))]
    corner_pos = mesh.v_pos.float()[mesh.t_pos_idx].numpy()
    corner_nrm = v_nrm.float()[t_nrm_idx].numpy()
    has_uv = bool(mesh.uv)
    materials = list(asset.materials)
    tangents = None
    if has_uv and any(m.normal is not None for m in materials):
        tangent_set = next(m.normal.uv_set for m in materials if m.normal is not None)
        corner_uv = mesh.uv[tangent_set][0].float()[mesh.uv[tangent_set][1]].numpy()
        tangents = mikktspace_tangents(corner_pos, corner_nrm, corner_uv).reshape(-1, 4)
        corner_keys.append(tangents.view(np.int32).astype(np.int64))
        materials = export_normal_maps(mesh, materials)
    first, inverse = unique_rows(np.concatenate(corner_keys, axis=1))
    indices = inverse.reshape(n_tris, 3)
    positions, normals = corner_pos.reshape(-1, 3)[first], corner_nrm.reshape(-1, 3)[first]
    if tangents is not None:
        tangents = tangents[first]
    if skinned:
        positions, normals, tangents, indices = _to_mesh_frame(
            asset.skin.mesh_to_world.detach().double().numpy(), positions, normals, tangents, indices)

    attributes = {"POSITION": builder.accessor(positions, _FLOAT, _ARRAY_BUFFER, bounds=True),
                  "NORMAL": builder.accessor(normals, _FLOAT, _ARRAY_BUFFER)}
    if tangents is not None:
        attributes["TANGENT"] = builder.accessor(tangents, _FLOAT, _ARRAY_BUFFER)
    for k, (v_tex, t_tex_idx) in enumerate(mesh.uv):
        attributes[f"TEXCOORD_{k}"] = builder.accessor(v_tex.float()[t_tex_idx].numpy().reshape(-1, 2)[first],
                                                       _FLOAT, _ARRAY_BUFFER)
    corner_vertex = mesh.t_pos_idx.numpy().reshape(-1)[first]
    if mesh.v_color is not None:
        color = np.clip(mesh.v_color.float().numpy()[corner_vertex], 0, 1)
        attributes["COLOR_0"] = builder.accessor(color, _FLOAT, _ARRAY_BUFFER)
    if skinned:
        pad = (0, -mesh.v_joints.shape[1] % 4)  # glTF holds influences in sets of 4: pad with weight 0
        joints = np.pad(mesh.v_joints.numpy()[corner_vertex], ((0, 0), pad))
        weights = np.pad(_normalized_weights(mesh.v_weights.float().numpy()[corner_vertex]), ((0, 0), pad))
        for s in range(joints.shape[1] // 4):
            attributes[f"JOINTS_{s}"] = builder.accessor(joints[:, 4 * s:4 * s + 4], _UNSIGNED_SHORT, _ARRAY_BUFFER)
            attributes[f"WEIGHTS_{s}"] = builder.accessor(weights[:, 4 * s:4 * s + 4], _FLOAT, _ARRAY_BUFFER)

    t_mat_idx = mesh.t_mat_idx.numpy()
    first_material = len(builder.doc.get("materials", []))
    primitives, used_materials = [], []
    for m_index in np.unique(t_mat_idx):
        used_materials.append(int(m_index))
        primitives.append({"attributes": attributes, "mode": 4, "material": first_material + len(used_materials) - 1,
                           "indices": builder.accessor(indices[t_mat_idx == m_index].reshape(-1), _UNSIGNED_INT,
                                                       _ELEMENT_ARRAY_BUFFER)})
    written = [_material(builder, materials[i], has_uv) for i in used_materials]
    builder.doc.setdefault("materials", []).extend(written)
    builder.doc.setdefault("meshes", []).append({"name": name, "primitives": primitives})
    return len(builder.doc["meshes"]) - 1


def _lights(builder: GlbBuilder, asset: Asset, nodes: list[dict], roots: list[int]) -> None:
    """``asset.lights`` as ``KHR_lights_punctual`` point lights, each on a root node of its own
    placed at its position: colour the intensity over its largest channel, intensity (candela)
    that channel, which viewers with physical light units render as our irradiance
    ``intensity / d^2``."""
    if not asset.lights:
        return
    written = []
    for k, light in enumerate(asset.lights):
        intensity = light.intensity.detach().double().cpu().numpy()
        strength = float(intensity.max())
        colour = (intensity / strength).tolist() if strength > 0 else [1.0, 1.0, 1.0]
        written.append({"name": f"light_{k}", "type": "point", "color": colour, "intensity": strength})
        nodes.append({"name": f"light_{k}", "translation": light.position.detach().double().cpu().tolist(),
                      "extensions": {"KHR_lights_punctual": {"light": k}}})
        roots.append(len(nodes) - 1)
    builder.doc.setdefault("extensions", {})["KHR_lights_punctual"] = {"lights": written}
    builder.extensions.add("KHR_lights_punctual")


@writer(".glb")
def write_glb(asset: Asset, path: Path, ktx2_only: bool = False) -> None:
    """Write ``asset`` as one ``.glb`` file (see the module docstring); ``ktx2_only``: a
    texture with mip levels is its KTX2 chain alone, without the PNG fallback (``ConfigError``
    where the encoder is missing)."""
    skinned = asset.skin is not None and asset.mesh.v_joints is not None
    builder = GlbBuilder(ktx2_only)
    empty = asset.mesh.num_triangles == 0  # glTF has no empty mesh: a node without one shows the nothing it is
    if not empty:
        add_mesh(builder, asset, asset.name, skinned)
    if empty:
        nodes, roots = [{"name": asset.name}], [0]
    elif skinned:
        nodes = _skin(builder, asset)
        roots = [i for i, n in enumerate(asset.skin.nodes) if n.parent < 0]
        home = asset.skin.mesh_node
        if home is not None and home < len(asset.skin.nodes) and "children" not in nodes[home]:
            nodes[home] = {"name": nodes[home]["name"], "mesh": 0, "skin": 0}
        else:
            nodes.append({"name": asset.name, "mesh": 0, "skin": 0})
            roots.append(len(nodes) - 1)
    else:
        nodes, roots = [{"name": asset.name, "mesh": 0}], [0]
    _lights(builder, asset, nodes, roots)
    builder.doc["nodes"] = nodes
    builder.doc["scenes"] = [{"nodes": roots}]
    builder.doc["scene"] = 0
    builder.write(Path(path))


def _flat(normal: Texture) -> bool:
    """Whether every texel of the tangent-space ``normal`` map is ``(0, 0, 1)`` (within 1e-6):
    a map that changes nothing, left out of the file."""
    value = constant_texel(normal)
    return value is not None and bool(np.allclose(value, (0.0, 0.0, 1.0), atol=1e-6))
