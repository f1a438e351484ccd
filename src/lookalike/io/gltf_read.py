"""glTF 2.0 reader (``.gltf`` with ``.bin``/images or ``data:`` URIs, and ``.glb``).

Every triangle primitive of the default scene is transformed by its node's world matrix and
merged into one ``Mesh`` (positions welded where position and skinning data are identical;
``t_mat_idx`` selects the material). Strips and fans become triangle lists; points and lines are
skipped with a warning. A primitive without a material gets the default ``Material``.

Materials follow glTF's metallic-roughness model: ``kd = baseColorFactor * baseColorTexture``
(sRGB decoded), ``ks = (gamma, roughness, metalness)`` with ``roughness = roughnessFactor * G``,
``metalness = metallicFactor * B`` and ``gamma = 1 - specularFactor * specularTexture.A``
(KHR_materials_specular). The mesh keeps the file's normals: NORMAL, or the flat triangle normal
where a primitive has none (glTF 2.0, Sec. 3.7.2.1), welded into slots per (position, normal)
(``lookalike.asset.normals.weld_normals``). Normal maps are scaled by ``normalTexture.scale`` and
re-expressed from the file's tangent frame (TANGENT, or MikkTSpace where absent, on those normals)
into ours (``lookalike.io.normal_frames``). Emission is
``emissiveFactor * emissiveStrength * emissiveTexture`` (sRGB decoded; KHR_materials_emissive_strength);
occlusion is ``1 + strength * (occlusionTexture.R - 1)``, with its own ``texCoord``. A
``KHR_materials_unlit`` material's base colour becomes its emission over a black ``kd``
(``Material.unlit``). ``KHR_lights_punctual`` point lights become ``Asset.lights``. Morph targets
are ignored. A ``KHR_texture_basisu`` texture is read from its PNG fallback, its mip levels from
the KTX2 chain; one with no fallback from the KTX2 alone (both decoded by ``basisu``,
``io.ktx2``). A file whose buffers are ``EXT_meshopt_compression``-compressed is decoded by
gltfpack first (``io.meshopt``); quantised attributes (``KHR_mesh_quantization``) are read with
their dequantising transforms.

Skins: the asset has one ``Skin`` over every node of the document (file order, so node indices,
joint indices and animation targets keep their meaning). Several skins over one skeleton (a
multi-mesh character, one skin per mesh) are joined: a joint slot per (joint node, inverse bind
matrix as it applies to the loaded positions), each primitive's JOINTS remapped into the slots
before welding. ``mesh_to_world`` is the world matrix ``W_0`` of the first skinned mesh node; a
skinned node with another world matrix ``W_n`` has ``inv(W_n) @ W_0`` folded into its inverse
bind matrices (glTF ignores a skinned mesh node's transform), so where all skinned nodes share
``W_0`` the matrices are the file's float32 values. A mesh without a skin in a skinned scene (a
prop on a bone) is bound rigidly to its node. Name and skeleton root are the first skin's;
animations of TRS properties are kept with the skin (other paths are skipped with a warning).
"""

from __future__ import annotations

import dataclasses
import logging
import tempfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from ..asset import Animation, Asset, Channel, Material, Mesh, Node, PunctualLight, Skin, Texture
from ..asset.material import Displacement, unlit_material
from ..settings import SHADING_CONVENTIONS
from ..asset.normals import weld_normals
from ..asset.skinning import trs_matrix
from ..errors import AssetError, ConfigError
from ..threads import available_cores
from .arrays import unique_rows
from .gltf_data import GltfData, parse_gltf
from .image_files import resize, srgb_to_linear
from .ktx2 import IDENTIFIER as KTX2_IDENTIFIER
from .ktx2 import ENCODER_HINT, decode_mip_chain, find_encoder
from .meshopt import decompress_glb
from .normal_frames import import_normal_maps
from .registry import reader
from .transforms import matrix_to_trs

log = logging.getLogger(__name__)

SUPPORTED_EXTENSIONS = frozenset({
    "KHR_texture_transform", "KHR_materials_specular", "KHR_materials_emissive_strength", "KHR_mesh_quantization",
    "KHR_materials_unlit", "KHR_lights_punctual", "KHR_texture_basisu", "EXT_meshopt_compression",
})
_WRAP_MODES = {10497: "wrap", 33071: "clamp", 33648: "wrap"}
_TRS_PATHS = ("translation", "rotation", "scale")


@dataclass
class _Primitive:
    """One triangle primitive in the asset frame; ``n`` vertices, ``t`` triangles."""

    positions: np.ndarray  # [n, 3] float64, world matrix applied
    triangles: np.ndarray  # [t, 3] int64 local indices, counter-clockwise
    normals: np.ndarray | None  # [n, 3] float32 unit
    tangents: np.ndarray | None  # [n, 4] float32 (xyz, handedness w)
    uvs: list[np.ndarray]  # per set: [n, 2] float32
    colors: np.ndarray | None  # [n, 4] float32 linear RGBA
    joints: np.ndarray | None  # [n, K] int64
    weights: np.ndarray | None  # [n, K] float32
    material: int  # index into the asset's materials
    node: int  # glTF node that places it (its world matrix was applied)
    skin: int | None  # glTF skin index of its node


def _node_world_matrices(gltf) -> tuple[list[int], np.ndarray, np.ndarray]:
    """Nodes of the default scene in depth-first order, all nodes' world matrices ``[N, 4, 4]``
    float64 and parent indices ``[N]`` (-1 for roots)."""
    n = len(gltf.nodes)
    parents = np.full(n, -1, dtype=np.int64)
    for i, node in enumerate(gltf.nodes):
        for child in node.children or []:
            parents[child] = i
    locals_ = np.stack([_local_matrix(node) for node in gltf.nodes]) if n else np.zeros((0, 4, 4))
    world = np.zeros_like(locals_)
    if gltf.scenes:
        roots = list(gltf.scenes[gltf.scene or 0].nodes or [])
    else:
        roots = [i for i in range(n) if parents[i] < 0]
    order, stack = [], [(r, np.eye(4)) for r in reversed(roots)]
    seen = np.zeros(n, dtype=bool)
    while stack:
        i, parent_world = stack.pop()
        if seen[i]:
            continue
        seen[i] = True
        world[i] = parent_world @ locals_[i]
        order.append(i)
        stack.extend((c, world[i]) for c in reversed(gltf.nodes[i].children or []))
    unvisited = ~seen
    world[unvisited] = locals_[unvisited]
    return order, world, parents


def _local_matrix(node) -> np.ndarray:
    if node.matrix is not None:
        return np.asarray(node.matrix, dtype=np.float64).reshape(4, 4).T  # glTF stores column-major
    trs = (node.translation or [0, 0, 0], node.rotation or [0, 0, 0, 1], node.scale or [1, 1, 1])
    return trs_matrix(*(torch.tensor(v, dtype=torch.float64) for v in trs)).numpy()


def _triangles(mode: int, indices: np.ndarray) -> np.ndarray | None:
    """``[t, 3]`` triangle list from glTF primitive ``mode`` (4 list, 5 strip, 6 fan), or ``None``
    for points and lines."""
    if mode == 4:
        return indices[: len(indices) // 3 * 3].reshape(-1, 3)
    i = np.arange(max(len(indices) - 2, 0))
    if mode == 5:  # strip: {v_i, v_(i+1+i%2), v_(i+2-i%2)}
        return np.stack([indices[i], indices[i + 1 + i % 2], indices[i + 2 - i % 2]], axis=1)
    if mode == 6:  # fan: {v_(i+1), v_(i+2), v_0}
        return np.stack([indices[i + 1], indices[i + 2], np.full_like(i, indices[0])], axis=1)
    return None


def _read_primitive(data: GltfData, prim, node: int, world: np.ndarray, material: int, skin: int | None,
                    where: str) -> _Primitive | None:
    """One triangle primitive of glTF node ``node`` placed by its world matrix ``world [4, 4]``,
    or ``None`` for points and lines; joints and weights are kept only where the node has a skin."""
    attrs = {k: v for k, v in vars(prim.attributes).items() if v is not None}
    if "POSITION" not in attrs:
        raise AssetError(data.path, f"{where} has no POSITION attribute")
    local = data.accessor(attrs["POSITION"]).astype(np.float64)
    n = len(local)
    indices = data.accessor(prim.indices) if prim.indices is not None else np.arange(n, dtype=np.int64)
    if indices.size and (indices.min() < 0 or indices.max() >= n):
        raise AssetError(data.path, f"{where}: index {int(indices.max())} out of range for {n} vertices")
    triangles = _triangles(prim.mode if prim.mode is not None else 4, indices)
    if triangles is None:
        log.warning(f"{data.path}: {where} has mode {prim.mode} (points or lines); skipped")
        return None
    if prim.targets:
        log.warning(f"{data.path}: {where} has morph targets; they are ignored (base shape kept)")
    linear = world[:3, :3]
    with np.errstate(invalid="ignore", over="ignore"):  # non-finite input is reported by _merge
        positions = local @ linear.T + world[:3, 3]
    if np.linalg.det(linear) < 0:  # a mirroring transform flips the winding (glTF 2.0, Sec. 3.7.4)
        triangles = triangles[:, [0, 2, 1]]
    normal_matrix = np.linalg.inv(linear).T if abs(np.linalg.det(linear)) > 0 else linear

    def unit(x):
        return (x / np.maximum(np.linalg.norm(x, axis=1, keepdims=True), 1e-30)).astype(np.float32)

    normals = unit(data.accessor(attrs["NORMAL"]) @ normal_matrix.T) if "NORMAL" in attrs else None
    tangents = None
    if "TANGENT" in attrs:
        t = data.accessor(attrs["TANGENT"])
        tangents = np.concatenate([unit(t[:, :3] @ linear.T), np.where(t[:, 3:] < 0, -1.0, 1.0)], axis=1)
        tangents = tangents.astype(np.float32)
    uvs = []
    while f"TEXCOORD_{len(uvs)}" in attrs:
        uvs.append(data.accessor(attrs[f"TEXCOORD_{len(uvs)}"]).astype(np.float32))
    colors = None
    if "COLOR_0" in attrs:
        c = data.accessor(attrs["COLOR_0"]).astype(np.float32)
        colors = np.concatenate([c, np.ones((n, 1), np.float32)], axis=1) if c.shape[1] == 3 else c
    joints = weights = None
    if skin is not None and "JOINTS_0" in attrs and "WEIGHTS_0" in attrs:
        sets = [k for k in range(2) if f"JOINTS_{k}" in attrs and f"WEIGHTS_{k}" in attrs]
        joints = np.concatenate([data.accessor(attrs[f"JOINTS_{k}"]) for k in sets], axis=1).astype(np.int64)
        weights = np.concatenate([data.accessor(attrs[f"WEIGHTS_{k}"]) for k in sets], axis=1).astype(np.float32)
        n_joints = len(data.gltf.skins[skin].joints)
        if joints.size and (joints.min() < 0 or joints.max() >= n_joints):
            raise AssetError(data.path, f"{where}: joint index {int(joints.max())} out of range for skin {skin} "
                                        f"with {n_joints} joints")
    return _Primitive(positions, triangles.astype(np.int64), normals, tangents, uvs, colors, joints, weights,
                      material, node, skin)


def _stack(parts: list[_Primitive], name: str, width: int, dtype) -> np.ndarray | None:
    """Concatenate one per-vertex attribute over primitives, zero-filled where a primitive lacks
    it (or is narrower); ``None`` when no primitive has it."""
    values = [getattr(p, name) for p in parts]
    if all(v is None for v in values):
        return None
    width = max(width, *(v.shape[1] for v in values if v is not None))
    out = []
    for p, v in zip(parts, values):
        block = np.zeros((len(p.positions), width), dtype=dtype)
        if v is not None:
            block[:, : v.shape[1]] = v
        out.append(block)
    return np.concatenate(out)


def _stack_nan(parts: list[_Primitive], name: str, width: int) -> np.ndarray:
    """``[n, width]`` float32 concatenation of a per-vertex attribute, NaN where a primitive lacks it."""
    return np.concatenate([np.full((len(p.positions), width), np.nan, np.float32) if getattr(p, name) is None
                           else getattr(p, name).astype(np.float32) for p in parts])


def _file_corner_normals(positions: np.ndarray, parts: list[_Primitive], corners: np.ndarray) -> np.ndarray:
    """``[T, 3, 3]`` float32 normals a glTF client uses at each corner: NORMAL where the primitive
    has it, else the flat triangle normal (glTF 2.0, Sec. 3.7.2.1) of the float32 ``positions``
    ``[n, 3]`` (the concatenated per-vertex arrays), computed in float64 for the triangles that
    need it."""
    normals = _stack_nan(parts, "normals", 3)[corners]
    missing = np.flatnonzero(np.isnan(normals).any(axis=(1, 2)))
    if len(missing):
        p = positions.astype(np.float64)[corners[missing]]
        flat = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        flat /= np.maximum(np.linalg.norm(flat, axis=-1, keepdims=True), 1e-30)
        normals[missing] = np.where(np.isnan(normals[missing]), flat[:, None, :], normals[missing])
    return normals


def _merge(parts: list[_Primitive], path: Path) -> tuple[Mesh, np.ndarray]:
    """One welded ``Mesh`` from primitives, and the ``[T, 3]`` int64 global corner-vertex indices
    (into the concatenated, unwelded per-vertex arrays) of every triangle."""
    offsets = np.cumsum([0] + [len(p.positions) for p in parts])
    corners = np.concatenate([p.triangles + o for p, o in zip(parts, offsets[:-1])])
    if len(corners) == 0:
        raise AssetError(path, "the mesh has no triangles")
    positions = np.concatenate([p.positions for p in parts]).astype(np.float32)
    if not np.isfinite(positions[corners.reshape(-1)]).all():
        raise AssetError(path, "vertex positions contain NaN or infinite values")
    colors = _stack(parts, "colors", 4, np.float32)
    joints = _stack(parts, "joints", 4, np.int64)
    weights = _stack(parts, "weights", 4, np.float32)
    # Weld vertices whose position and per-position attributes are equal (bitwise, after + 0.0
    # has turned -0.0 into 0.0).
    weld_key = [(a + np.float32(0.0)).view(np.int32) if a.dtype == np.float32 else a.astype(np.int32)
                for a in (positions, colors, joints, weights) if a is not None]
    first, inverse = unique_rows(np.concatenate(weld_key, axis=1))
    t_pos_idx = torch.from_numpy(inverse[corners])
    n_sets = max(len(p.uvs) for p in parts)
    corner_idx = torch.from_numpy(corners)
    uv = []
    for k in range(n_sets):
        v_tex = np.concatenate([p.uvs[k] if k < len(p.uvs) else np.zeros((len(p.positions), 2), np.float32)
                                for p in parts])
        uv.append((torch.from_numpy(v_tex), corner_idx.clone()))
    v_nrm, t_nrm_idx = weld_normals(t_pos_idx, torch.from_numpy(_file_corner_normals(positions, parts, corners)))
    mesh = Mesh(
        v_pos=torch.from_numpy(positions[first]),
        t_pos_idx=t_pos_idx,
        uv=uv,
        v_nrm=v_nrm,
        t_nrm_idx=t_nrm_idx,
        v_color=None if colors is None else torch.from_numpy(colors[first]),
        t_mat_idx=torch.from_numpy(np.concatenate([np.full(len(p.triangles), p.material) for p in parts])),
        v_joints=None if joints is None else torch.from_numpy(joints[first]),
        v_weights=None if weights is None else torch.from_numpy(weights[first]),
    )
    return mesh, corners


def _texture_info(info) -> dict:
    """A textureInfo as a dict (pygltflib gives objects for core fields, dicts inside extensions)."""
    if isinstance(info, dict):
        return info
    return {k: v for k, v in vars(info).items() if v is not None}


def _texture_transform(info: dict) -> tuple[int, torch.Tensor | None]:
    """``(texCoord, [3, 3] KHR_texture_transform matrix or None)``; the matrix is
    ``T(offset) @ R(rotation) @ S(scale)`` with ``R = [[cos, sin], [-sin, cos]]`` (glTF spec)."""
    tex_coord = info.get("texCoord") or 0
    ext = (info.get("extensions") or {}).get("KHR_texture_transform")
    if not ext:
        return tex_coord, None
    ox, oy = ext.get("offset", [0.0, 0.0])
    sx, sy = ext.get("scale", [1.0, 1.0])
    r = ext.get("rotation", 0.0)
    c, s = np.cos(r), np.sin(r)
    m = np.array([[1, 0, ox], [0, 1, oy], [0, 0, 1]]) @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]]) \
        @ np.diag([sx, sy, 1.0])
    return ext.get("texCoord", tex_coord), torch.tensor(m, dtype=torch.float32)


class _MaterialReader:
    """Builds ``Material``s from glTF materials, decoding each image once."""

    def __init__(self, data: GltfData):
        self.data = data
        self.images: dict[int, np.ndarray] = {}
        self.chains: dict[int, list[np.ndarray] | None] = {}
        self.decoder = find_encoder()
        if self.decoder is not None:  # every KTX2 image at once, a transcoder process per core
            sources = {(t.extensions or {}).get("KHR_texture_basisu", {}).get("source") for t in data.gltf.textures}
            sources.discard(None)
            with ThreadPoolExecutor(max_workers=available_cores()) as pool:
                list(pool.map(self._ktx2_levels, sorted(sources)))

    def _pixels(self, info: dict) -> np.ndarray:
        """``[H, W, 4]`` raw RGBA of the image behind a textureInfo."""
        textures = self.data.gltf.textures
        index = info.get("index")
        if index is None or not 0 <= index < len(textures):
            raise AssetError(self.data.path, f"texture {index} does not exist")
        texture = textures[index]
        source = texture.source
        for ext in (texture.extensions or {}).values():
            if source is None and isinstance(ext, dict):
                source = ext.get("source")
        if source is None:
            raise AssetError(self.data.path, f"texture {index} has no image source")
        if source not in self.images:
            encoded = self.data.image_bytes(source)
            if encoded[:len(KTX2_IDENTIFIER)] == KTX2_IDENTIFIER:  # KTX2 alone (no PNG fallback): its level 0
                self.images[source] = self._ktx2_levels(source)[0]
            else:
                self.images[source] = self.data.image(source)
        return self.images[source]

    def _ktx2_levels(self, source: int) -> list[np.ndarray]:
        """Every level ``[h, w, 4]`` raw RGBA in [0, 1], finest first, of the KTX2 image
        ``source``, decoded by the ``basisu`` transcoder (``io.ktx2``); ``AssetError`` where
        there is none or it fails."""
        if source not in self.chains:
            if self.decoder is None:
                raise AssetError(self.data.path, f"image {source} is KTX2 (KHR_texture_basisu) with no PNG fallback; "
                                 f"reading it needs {ENCODER_HINT}")
            try:
                levels = decode_mip_chain(self.data.image_bytes(source), self.decoder)
            except ValueError as e:
                raise AssetError(self.data.path, f"image {source}: {e}") from None
            self.chains[source] = [level.astype(np.float32) / 255.0 for level in levels]
        return self.chains[source]

    def _mip_chain(self, info: dict) -> list[np.ndarray] | None:
        """Levels 1.. ``[h, w, 4]`` raw RGBA of the KTX2 mip chain (``KHR_texture_basisu``)
        behind a textureInfo, decoded where the ``basisu`` transcoder is found
        (``io.ktx2``); ``None`` without one, or where the texture has no KTX2 source. An engine
        that reads KTX2 samples these levels instead of building mips from the PNG."""
        basisu = (self.data.gltf.textures[info["index"]].extensions or {}).get("KHR_texture_basisu")
        source = basisu.get("source") if isinstance(basisu, dict) else None
        if source is None or self.decoder is None:
            return None
        return self._ktx2_levels(source)[1:]

    def _texture(self, info: dict, convert, pixels: np.ndarray | None = None) -> Texture:
        """The texture behind ``info``, its texels ``convert([h, w, 4] raw RGBA)`` (of
        ``pixels`` where given, else of its image), with its KTX2 mip levels converted alike
        where it has them (``_mip_chain``) and ``pixels`` is not given."""
        uv_set, transform = _texture_transform(info)
        textures = self.data.gltf.textures
        sampler_index = textures[info["index"]].sampler
        wrap = "wrap"
        if sampler_index is not None and 0 <= sampler_index < len(self.data.gltf.samplers):
            wrap = _WRAP_MODES.get(self.data.gltf.samplers[sampler_index].wrapS or 10497, "wrap")
        chain = self._mip_chain(info) if pixels is None else None

        def tensor(raw: np.ndarray) -> torch.Tensor:
            return torch.from_numpy(np.ascontiguousarray(convert(raw), dtype=np.float32))

        return Texture(tensor(self._pixels(info) if pixels is None else pixels), uv_set=uv_set, transform=transform,
                       wrap=wrap, mips=[tensor(level) for level in chain] if chain else None)

    def material(self, m) -> Material:
        pbr = m.pbrMetallicRoughness
        base_factor = np.asarray(pbr.baseColorFactor if pbr and pbr.baseColorFactor else [1, 1, 1, 1], np.float32)
        rough_factor = pbr.roughnessFactor if pbr and pbr.roughnessFactor is not None else 1.0
        metal_factor = pbr.metallicFactor if pbr and pbr.metallicFactor is not None else 1.0
        if pbr and pbr.baseColorTexture is not None:
            kd = self._texture(_texture_info(pbr.baseColorTexture),
                               lambda px: np.concatenate([srgb_to_linear(px[..., :3]), px[..., 3:]], -1) * base_factor)
        else:
            kd = Texture.constant(base_factor)
        specular = (m.extensions or {}).get("KHR_materials_specular", {})
        spec_factor = float(specular.get("specularFactor", 1.0))
        spec_info = specular.get("specularTexture")
        mr_info = _texture_info(pbr.metallicRoughnessTexture) if pbr and pbr.metallicRoughnessTexture else None
        if mr_info is None and spec_info is None:
            ks = Texture.constant([1.0 - spec_factor, rough_factor, metal_factor])
        elif mr_info is not None and spec_info is not None and spec_info.get("index") == mr_info.get("index"):
            ks = self._texture(mr_info, lambda px: np.stack(  # one image, as lookalike writes it: mips kept
                [1.0 - spec_factor * px[..., 3], rough_factor * px[..., 1], metal_factor * px[..., 2]], axis=-1))
        else:
            layout = mr_info or spec_info
            h, w = self._pixels(layout).shape[:2]
            mr = self._pixels(mr_info) if mr_info else np.ones((h, w, 4), np.float32)
            spec = resize(self._pixels(spec_info), h, w)[..., 3] if spec_info else np.ones((h, w), np.float32)
            ks = self._texture(layout, lambda px: px, np.stack(
                [1.0 - spec_factor * spec, rough_factor * mr[..., 1], metal_factor * mr[..., 2]], axis=-1))
        normal = None
        if m.normalTexture is not None:
            info = _texture_info(m.normalTexture)
            scale = float(info.get("scale", 1.0) if info.get("scale") is not None else 1.0)

            def unit_normal(px: np.ndarray) -> np.ndarray:
                n = px[..., :3] * 2.0 - 1.0
                n[..., :2] *= scale
                return n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-12)

            normal = self._texture(info, unit_normal)
        emissive_factor = np.asarray(m.emissiveFactor or [0, 0, 0], np.float32)
        emissive_factor *= float((m.extensions or {}).get("KHR_materials_emissive_strength", {})
                                 .get("emissiveStrength", 1.0))
        emissive = None
        if m.emissiveTexture is not None and emissive_factor.any():
            info = _texture_info(m.emissiveTexture)
            emissive = self._texture(info, lambda px: srgb_to_linear(px[..., :3]) * emissive_factor)
        elif emissive_factor.any():
            emissive = Texture.constant(emissive_factor)
        occlusion = None
        if m.occlusionTexture is not None:  # R channel; strength s gives 1 + s * (R - 1)
            info = _texture_info(m.occlusionTexture)
            strength = float(info.get("strength", 1.0) if info.get("strength") is not None else 1.0)
            occlusion = self._texture(info, lambda px: 1.0 + strength * (px[..., :1] - 1.0))
        alpha_mode = m.alphaMode or "OPAQUE"
        if alpha_mode not in ("OPAQUE", "MASK", "BLEND"):
            raise AssetError(self.data.path, f"material {m.name!r} has unknown alphaMode {alpha_mode!r}")
        material = Material(
            name=m.name or "material", kd=kd, ks=ks, normal=normal, alpha_mode=alpha_mode,
            alpha_cutoff=0.5 if m.alphaCutoff is None else float(m.alphaCutoff),
            double_sided=bool(m.doubleSided), emissive=emissive, occlusion=occlusion,
            displacement=self.displacement(m.extras),
        )
        if "KHR_materials_unlit" in (m.extensions or {}):  # its colour is all it shows
            return unlit_material(material, dataclasses.replace(kd, data=kd.data[..., :3].clone(), mips=None))
        return material

    def displacement(self, extras) -> Displacement | None:
        """The ``Displacement`` in a material's ``extras.displacement`` as lookalike writes it
        (``io.gltf_write``), or ``None``."""
        entry = extras.get("displacement") if isinstance(extras, dict) else None
        if not isinstance(entry, dict):
            return None
        try:
            heights = self._texture(_texture_info(entry["texture"]), lambda px: px[..., :1])
            shading = entry.get("shading", "recomputed")  # files from before the engine convention
            if shading not in SHADING_CONVENTIONS:
                raise ValueError(f"shading {shading!r} is not one of {', '.join(SHADING_CONVENTIONS)}")
            detail = entry.get("detail_level")
            return Displacement(heights, float(entry["scale"]), float(entry.get("offset", 0.5)),
                                int(entry.get("level", 0)), shading, None if detail is None else int(detail))
        except (KeyError, TypeError, ValueError) as e:
            raise AssetError(self.data.path, f"material extras.displacement is malformed: {e}") from None


def _scene_nodes(gltf, parents: np.ndarray) -> list[Node]:
    """Every node of the document, in file order, as a ``Node`` (a ``matrix`` decomposed into TRS)."""
    nodes = []
    for i, node in enumerate(gltf.nodes):
        if node.matrix is not None:
            t, r, s = matrix_to_trs(np.asarray(node.matrix, dtype=np.float64).reshape(4, 4).T)
        else:
            t, r, s = node.translation or [0, 0, 0], node.rotation or [0, 0, 0, 1], node.scale or [1, 1, 1]
        nodes.append(Node(name=node.name or f"node{i}", parent=int(parents[i]),
                          translation=torch.tensor(t, dtype=torch.float32),
                          rotation=torch.tensor(r, dtype=torch.float32),
                          scale=torch.tensor(s, dtype=torch.float32)))
    return nodes


def _inverse_binds(data: GltfData, skin_index: int) -> np.ndarray:
    """``[J, 4, 4]`` float32 inverse bind matrices of ``skins[skin_index]`` (identity where absent)."""
    skin = data.gltf.skins[skin_index]
    if skin.inverseBindMatrices is None:
        return np.tile(np.eye(4, dtype=np.float32), (len(skin.joints), 1, 1))
    ibm = data.accessor(skin.inverseBindMatrices).reshape(-1, 4, 4).transpose(0, 2, 1)  # column-major
    if len(ibm) < len(skin.joints):
        raise AssetError(data.path, f"skin {skin_index} has {len(skin.joints)} joints but {len(ibm)} inverse bind "
                                    f"matrices")
    return np.ascontiguousarray(ibm[: len(skin.joints)], np.float32)


def _slot(slots: list[tuple[int, np.ndarray]], by_node: dict[int, list[int]], node: int, ibm: np.ndarray) -> int:
    """Index in ``slots`` of joint ``node`` with inverse bind matrix ``ibm [4, 4]``: an existing
    slot of that node whose matrix equals it to float32 rounding, else a new one."""
    for i in by_node.setdefault(node, []):
        if np.allclose(slots[i][1], ibm, rtol=1e-6, atol=1e-6 * float(np.abs(ibm).max())):
            return i
    by_node[node].append(len(slots))
    slots.append((node, ibm))
    return len(slots) - 1


def _join_skins(data: GltfData, parts: list[_Primitive], world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One joint list for the skins of all skinned ``parts``, remapping each part's joints into it
    (in place). Its mesh frame is the world matrix ``W_0`` of the first skinned part's node: a
    part placed by another world matrix ``W_n`` gets ``IBM_j @ inv(W_n) @ W_0`` (float64), so that
    ``world(joint) @ IBM' @ inv(W_0)`` maps its loaded positions ``W_n p`` as glTF's
    ``world(joint) @ IBM_j`` maps ``p``; the others keep the file's float32 matrices. A slot is a
    (joint node, such matrix) pair: skins sharing a skeleton share its slots; a joint of zero
    weight becomes slot 0. A part without a skin (a prop on a node of the skeleton's scene) is
    bound rigidly to its node, so it moves with it. Returns joint node indices ``[J]`` int64 and inverse bind matrices
    ``[J, 4, 4]`` float32 (``world`` is ``[N, 4, 4]``)."""
    mesh_world = world[next(p.node for p in parts if p.skin is not None)]
    slots: list[tuple[int, np.ndarray]] = []
    by_node: dict[int, list[int]] = {}
    remaps: dict[tuple[int, int], np.ndarray] = {}
    for part in parts:
        if part.skin is None:  # rigidly bound to its own node: weight 1 on a slot (node, inv(W_n) @ W_0)
            if np.linalg.det(world[part.node]) == 0:
                raise AssetError(data.path, f"node {part.node} has a singular world matrix")
            ibm = (np.linalg.inv(world[part.node]) @ mesh_world).astype(np.float32)
            slot = _slot(slots, by_node, part.node, ibm)
            part.joints = np.tile(np.array([[slot, 0, 0, 0]], np.int64), (len(part.positions), 1))
            part.weights = np.tile(np.array([[1.0, 0, 0, 0]], np.float32), (len(part.positions), 1))
            continue
        key = (part.skin, part.node)
        if key not in remaps:
            ibm = _inverse_binds(data, part.skin)
            if not np.array_equal(world[part.node], mesh_world):
                if np.linalg.det(world[part.node]) == 0:
                    raise AssetError(data.path, f"skinned node {part.node} has a singular world matrix")
                ibm = (ibm.astype(np.float64) @ np.linalg.inv(world[part.node]) @ mesh_world).astype(np.float32)
            joint_nodes = data.gltf.skins[part.skin].joints
            remaps[key] = np.array([_slot(slots, by_node, n, m) for n, m in zip(joint_nodes, ibm)], dtype=np.int64)
        if part.joints is not None:  # joints of zero weight become 0
            part.joints = np.where(part.weights != 0, remaps[key][part.joints], 0)
    return np.array([n for n, _ in slots], dtype=np.int64), np.array([m for _, m in slots], np.float32).reshape(-1, 4, 4)


def _read_skin(data: GltfData, parts: list[_Primitive], world: np.ndarray, parents: np.ndarray) -> Skin:
    """The skin of the skinned ``parts``, joined into one over their joints (``_join_skins``;
    remaps the parts' joints), with every node of the document; name and skeleton root are the
    first skinned part's skin's."""
    first = next(p for p in parts if p.skin is not None)
    joints, ibm = _join_skins(data, parts, world)
    skin = data.gltf.skins[first.skin]
    return Skin(nodes=_scene_nodes(data.gltf, parents), joints=torch.from_numpy(joints),
                inverse_bind=torch.from_numpy(ibm), mesh_to_world=torch.from_numpy(world[first.node].astype(np.float32)),
                name=skin.name or "", skeleton=skin.skeleton, mesh_node=first.node)


def _read_animations(data: GltfData) -> list[Animation]:
    animations = []
    for a_index, anim in enumerate(data.gltf.animations or []):
        channels = []
        for ch in anim.channels:
            if ch.target.node is None or ch.target.path not in _TRS_PATHS:
                log.warning(f"{data.path}: animation {a_index} channel on {ch.target.path!r} skipped")
                continue
            sampler = anim.samplers[ch.sampler]
            times = data.accessor(sampler.input).astype(np.float32).reshape(-1)
            values = data.accessor(sampler.output).astype(np.float32)
            interpolation = sampler.interpolation or "LINEAR"
            rows = 3 * len(times) if interpolation == "CUBICSPLINE" else len(times)
            if interpolation not in ("LINEAR", "STEP", "CUBICSPLINE") or len(times) == 0 or len(values) != rows:
                raise AssetError(data.path, f"animation {a_index} has a {interpolation} sampler with {len(times)} key "
                                            f"times and {len(values)} output values")
            channels.append(Channel(node=int(ch.target.node), path=ch.target.path, times=torch.from_numpy(times),
                                    values=torch.from_numpy(np.ascontiguousarray(values)),
                                    interpolation=interpolation))
        animations.append(Animation(name=anim.name or f"animation{a_index}", channels=channels))
    return animations


@reader(".gltf", ".glb")
def read_gltf(path: Path) -> Asset:
    """Read a glTF 2.0 file into an ``Asset`` (see the module docstring)."""
    path = Path(path)
    gltf = parse_gltf(path)
    unknown = sorted(set(gltf.extensionsRequired or []) - SUPPORTED_EXTENSIONS)
    if unknown:
        raise AssetError(path, f"requires unsupported glTF extension(s): {', '.join(unknown)}")
    if "EXT_meshopt_compression" in (gltf.extensionsRequired or []):
        with tempfile.TemporaryDirectory(prefix="lookalike-meshopt-") as scratch:
            plain = Path(scratch) / f"{path.stem}.glb"
            try:
                decompress_glb(path, plain)
            except ConfigError as e:
                raise AssetError(path, str(e)) from None
            return dataclasses.replace(read_gltf(plain), source=path)
    data = GltfData(gltf, path)
    order, world, parents = _node_world_matrices(gltf)
    n_materials = len(gltf.materials)
    parts = []
    for node_index in order:
        node = gltf.nodes[node_index]
        if node.mesh is None:
            continue
        if not 0 <= node.mesh < len(gltf.meshes):
            raise AssetError(path, f"node {node_index} refers to missing mesh {node.mesh}")
        if node.skin is not None and not 0 <= node.skin < len(gltf.skins):
            raise AssetError(path, f"node {node_index} refers to missing skin {node.skin}")
        for p_index, prim in enumerate(gltf.meshes[node.mesh].primitives):
            material = n_materials if prim.material is None else prim.material
            if not 0 <= material <= n_materials:
                raise AssetError(path, f"mesh {node.mesh} primitive {p_index} refers to missing material {material}")
            part = _read_primitive(data, prim, node_index, world[node_index], material, node.skin,
                                   f"mesh {node.mesh} primitive {p_index}")
            if part is not None and len(part.triangles):
                parts.append(part)
    if not parts:
        raise AssetError(path, "the default scene contains no triangles")
    skin, animations = None, []
    if any(p.skin is not None for p in parts):
        skin = _read_skin(data, parts, world, parents)  # before _merge: welding sees the joined joints
        animations = _read_animations(data)
    elif gltf.animations:
        log.warning(f"{path}: animations of an unskinned scene are not kept")
    mesh, corners = _merge(parts, path)
    reader_ = _MaterialReader(data)
    materials = [reader_.material(m) for m in gltf.materials]
    if (mesh.t_mat_idx == n_materials).any() or not materials:
        materials.append(Material(name="default"))
    materials = import_normal_maps(mesh, materials, _stack_nan(parts, "tangents", 4)[corners])
    return Asset(mesh=mesh, materials=materials, skin=skin, animations=animations, source=path,
                 lights=_point_lights(gltf, order, world))


def _point_lights(gltf, order: list[int], world: np.ndarray) -> list[PunctualLight]:
    """The ``KHR_lights_punctual`` point lights on the default scene's nodes, at their nodes'
    world positions, intensity ``color * intensity`` (other kinds of light are not kept)."""
    lights = ((gltf.extensions or {}).get("KHR_lights_punctual") or {}).get("lights") or []
    found = []
    for node_index in order:
        light = ((gltf.nodes[node_index].extensions or {}).get("KHR_lights_punctual") or {}).get("light")
        if light is None or not 0 <= light < len(lights) or lights[light].get("type") != "point":
            continue
        colour = np.asarray(lights[light].get("color", [1.0, 1.0, 1.0]), dtype=np.float64)
        found.append(PunctualLight(position=torch.from_numpy(world[node_index][:3, 3].copy()).float(),
                                   intensity=torch.from_numpy(colour * float(lights[light].get("intensity", 1.0))).float()))
    return found
