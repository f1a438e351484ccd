"""glTF reading (accessors, primitives, materials, skins, animations, errors) and GLB writing
(round trips, the Khronos validator)."""

from __future__ import annotations

import base64
import json
import math
import struct
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest
import torch
from io_factory import covered_texels, npm_package, plane, two_material_asset
from log_capture import expect_warning

from lookalike import io
from lookalike.asset import Animation, Asset, Channel, Material, Mesh, Node, Skin, Texture
from lookalike.asset.skinning import node_world_matrices
from lookalike.errors import AssetError
from lookalike.io.gltf_data import GltfData, parse_gltf
from lookalike.io.image_files import encode_png

pytestmark = pytest.mark.timeout(300)
"""Each test's limit, far above its seconds (the validator's first npm install included): node
never holds up the suite."""

VALIDATOR = Path(__file__).with_name("gltf_validate.js")


# ----------------------------------------------------------------------------------------------
# A tiny glTF document builder for hand-made test files.

class Doc:
    """Builds a glTF JSON document with one binary buffer (embedded as a data: URI or a .bin)."""

    def __init__(self):
        self.json = {"asset": {"version": "2.0"}, "buffers": [], "bufferViews": [], "accessors": [],
                     "meshes": [], "nodes": [], "scenes": [{"nodes": []}], "scene": 0}
        self.blob = bytearray()

    def view(self, data: bytes, stride: int | None = None) -> int:
        self.blob += b"\0" * (-len(self.blob) % 4)
        view = {"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data)}
        if stride:
            view["byteStride"] = stride
        self.blob += data
        self.json["bufferViews"].append(view)
        return len(self.json["bufferViews"]) - 1

    def accessor(self, values, component: int = 5126, kind: str | None = None, **extra) -> int:
        dtype = {5126: np.float32, 5125: np.uint32, 5123: np.uint16, 5121: np.uint8, 5120: np.int8}[component]
        values = np.asarray(values, dtype=dtype)
        rows = values.reshape(len(values), -1)
        kind = kind or {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4", 16: "MAT4"}[rows.shape[1]]
        acc = {"bufferView": self.view(values.tobytes()), "componentType": component, "count": len(values),
               "type": kind, **extra}
        if kind == "VEC3" and component == 5126:
            acc["min"], acc["max"] = rows.min(0).tolist(), rows.max(0).tolist()
        self.json["accessors"].append(acc)
        return len(self.json["accessors"]) - 1

    def mesh_node(self, primitives: list[dict], **node) -> int:
        self.json["meshes"].append({"primitives": primitives})
        self.json["nodes"].append({"mesh": len(self.json["meshes"]) - 1, **node})
        self.json["scenes"][0]["nodes"].append(len(self.json["nodes"]) - 1)
        return len(self.json["nodes"]) - 1

    def write(self, path: Path, bin_file: bool = False) -> Path:
        if bin_file:
            (path.parent / "data.bin").write_bytes(bytes(self.blob))
            self.json["buffers"] = [{"uri": "data.bin", "byteLength": len(self.blob)}]
        else:
            uri = "data:application/octet-stream;base64," + base64.b64encode(bytes(self.blob)).decode()
            self.json["buffers"] = [{"uri": uri, "byteLength": len(self.blob)}]
        path.write_text(json.dumps(self.json))
        return path


QUAD = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)


def quad_doc() -> tuple[Doc, dict]:
    doc = Doc()
    prim = {"attributes": {"POSITION": doc.accessor(QUAD)}, "indices": doc.accessor([0, 1, 2, 0, 2, 3], 5123)}
    return doc, prim


# ----------------------------------------------------------------------------------------------
# Reading.

def test_accessors_strided_normalized_and_sparse(tmp_path):
    doc = Doc()
    # Interleaved POSITION (12 bytes) + normalized uint8 TEXCOORD_0 (2 bytes, padded to 4): stride 16.
    uv8 = np.array([[0, 255], [255, 255], [255, 0], [0, 0]], np.uint8)
    inter = b"".join(QUAD[i].tobytes() + uv8[i].tobytes() + b"\0\0" for i in range(4))
    view = doc.view(inter, stride=16)
    doc.json["accessors"] += [
        {"bufferView": view, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
        {"bufferView": view, "byteOffset": 12, "componentType": 5121, "normalized": True, "count": 4, "type": "VEC2"},
    ]
    # A sparse accessor without bufferView: zeros with two substituted colours.
    colour = {"componentType": 5126, "count": 4, "type": "VEC3", "sparse": {
        "count": 2, "indices": {"bufferView": doc.view(np.array([1, 3], np.uint16).tobytes()), "componentType": 5123},
        "values": {"bufferView": doc.view(np.array([[1, 0, 0], [0, 0, 1]], np.float32).tobytes())}}}
    doc.json["accessors"].append(colour)
    doc.mesh_node([{"attributes": {"POSITION": 0, "TEXCOORD_0": 1, "COLOR_0": 2},
                    "indices": doc.accessor([0, 1, 2, 0, 2, 3], 5125)}])
    asset = io.load(doc.write(tmp_path / "a.gltf"))
    uv = asset.mesh.uv[0][0][asset.mesh.uv[0][1]]
    assert torch.allclose(uv[0], torch.tensor([[0.0, 1], [1, 1], [1, 0]]))
    colours = asset.mesh.v_color[asset.mesh.t_pos_idx]
    assert torch.equal(colours[0, :, :3], torch.tensor([[0.0, 0, 0], [1, 0, 0], [0, 0, 0]]))
    assert torch.equal(colours[1, 2, :3], torch.tensor([0.0, 0, 1]))


def test_strips_fans_and_skipped_lines(tmp_path, caplog):
    doc = Doc()
    pos = doc.accessor(QUAD)
    doc.mesh_node([{"attributes": {"POSITION": pos}, "indices": doc.accessor([0, 1, 3, 2], 5123), "mode": 5},
                   {"attributes": {"POSITION": pos}, "indices": doc.accessor([0, 1, 2, 3], 5123), "mode": 6},
                   {"attributes": {"POSITION": pos}, "indices": doc.accessor([0, 1], 5123), "mode": 1}])
    with expect_warning(caplog, "points or lines"):
        asset = io.load(doc.write(tmp_path / "s.gltf"))
    corners = asset.mesh.v_pos[asset.mesh.t_pos_idx]
    normals = torch.linalg.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0], dim=-1)
    assert asset.mesh.num_triangles == 4
    assert (normals[:, 2] > 0).all()  # strip and fan keep counter-clockwise winding
    assert asset.mesh.num_vertices == 4  # equal positions of the primitives are welded


def test_node_transforms_and_mirroring(tmp_path):
    doc, prim = quad_doc()
    doc.mesh_node([prim], translation=[0, 0, 5], scale=[2, 2, 2])
    doc.mesh_node([dict(prim)], matrix=[-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1])
    asset = io.load(doc.write(tmp_path / "n.gltf"))
    corners = asset.mesh.v_pos[asset.mesh.t_pos_idx]
    assert torch.allclose(corners[:2].reshape(-1, 3).max(0).values, torch.tensor([2.0, 2, 5]))
    assert corners[2:, :, 0].max() <= 0
    normals = torch.linalg.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0], dim=-1)
    assert (normals[:, 2] > 0).all()  # the mirrored copy's winding was flipped back


def test_materials_factors_textures_and_extensions(tmp_path):
    doc, prim = quad_doc()
    doc.json["accessors"].append(doc.json["accessors"][0] | {})  # unused copy: harmless
    uv = doc.accessor(np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32))
    prim["attributes"]["TEXCOORD_1"] = uv
    prim["attributes"]["TEXCOORD_0"] = uv
    prim["material"] = 0
    second = dict(prim, material=None)
    doc.mesh_node([prim, second])
    srgb_half = 0.5
    mr = np.zeros((2, 2, 3), np.float32)
    mr[..., 1], mr[..., 2] = 0.5, 1.0
    (tmp_path / "base.png").write_bytes(encode_png(np.full((2, 2, 4), srgb_half, np.float32)))
    (tmp_path / "mr.png").write_bytes(encode_png(mr))
    doc.json["images"] = [{"uri": "base.png"}, {"uri": "mr.png"}]
    doc.json["samplers"] = [{"wrapS": 33071, "wrapT": 33071}]
    doc.json["textures"] = [{"source": 0, "sampler": 0}, {"source": 1}]
    doc.json["materials"] = [{
        "name": "m",
        "pbrMetallicRoughness": {
            "baseColorFactor": [1, 0.5, 1, 1],
            "baseColorTexture": {"index": 0, "texCoord": 1, "extensions": {"KHR_texture_transform": {
                "offset": [0.5, 0], "rotation": math.pi / 2, "scale": [2, 3]}}},
            "metallicRoughnessTexture": {"index": 1}, "roughnessFactor": 0.8, "metallicFactor": 0.5},
        "alphaMode": "MASK", "alphaCutoff": 0.3, "doubleSided": True, "emissiveFactor": [1, 0, 0],
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.25}, "KHR_materials_emissive_strength": {
            "emissiveStrength": 3.0}}}]
    doc.json["extensionsUsed"] = ["KHR_texture_transform", "KHR_materials_specular", "KHR_materials_emissive_strength"]
    asset = io.load(doc.write(tmp_path / "m.gltf"))
    m, default = asset.materials
    assert default.name == "default" and asset.mesh.t_mat_idx.tolist() == [0, 0, 1, 1]
    linear_half = ((0.5 + 0.055) / 1.055) ** 2.4
    assert m.kd.data.shape == (2, 2, 4) and m.kd.uv_set == 1 and m.kd.wrap == "clamp"
    assert torch.allclose(m.kd.data[0, 0], torch.tensor([linear_half, 0.5 * linear_half, linear_half, 0.5]),
                          atol=3e-3)
    # T(offset) R(pi/2) S(2, 3) applied to (u, v, 1) = (1, 0, 1): R S (1, 0) = (0, -2) -> (0.5, -2).
    assert torch.allclose(m.kd.transform @ torch.tensor([1.0, 0, 1]), torch.tensor([0.5, -2, 1]), atol=1e-6)
    assert torch.allclose(m.ks.data[0, 0], torch.tensor([0.75, 0.8 * 128 / 255, 0.5]), atol=1e-6)
    assert (m.alpha_mode, m.alpha_cutoff, m.double_sided) == ("MASK", pytest.approx(0.3), True)
    assert torch.allclose(m.emissive.data.reshape(-1), torch.tensor([3.0, 0, 0]))


def _skinned_quad_doc() -> Doc:
    """A quad skinned to a two-joint chain (root, tip), its mesh node moved to z = 2."""
    doc, prim = quad_doc()
    prim["attributes"]["JOINTS_0"] = doc.accessor(np.array([[0, 1, 0, 0]] * 4, np.uint8), 5121)
    prim["attributes"]["WEIGHTS_0"] = doc.accessor(np.array([[0.25, 0.75, 0, 0]] * 4, np.float32))
    doc.json["nodes"] = [{"name": "root", "children": [1], "translation": [1, 0, 0]},
                         {"name": "tip", "rotation": [0, 0, math.sin(0.3), math.cos(0.3)]}]
    doc.json["scenes"][0]["nodes"] = [0]
    ibm = np.tile(np.eye(4, dtype=np.float32), (2, 1, 1))
    ibm[1, 3, 0] = -1.0  # column-major: translation x of joint 1
    doc.json["skins"] = [{"joints": [0, 1], "inverseBindMatrices": doc.accessor(ibm.reshape(2, 16), kind="MAT4")}]
    doc.mesh_node([prim], skin=0, translation=[0, 0, 2])
    return doc


def test_skin_and_animations(tmp_path):
    doc = _skinned_quad_doc()
    times = doc.accessor(np.array([0, 1], np.float32))
    cubic = np.array([[0, 0, 0], [1, 2, 3], [0, 0, 0], [0, 0, 0], [4, 5, 6], [0, 0, 0]], np.float32)
    doc.json["animations"] = [{"name": "walk", "samplers": [
        {"input": times, "output": doc.accessor(np.array([[0, 0, 0, 1], [0, 0, 1, 0]], np.float32)),
         "interpolation": "STEP"},
        {"input": times, "output": doc.accessor(cubic), "interpolation": "CUBICSPLINE"}],
        "channels": [{"sampler": 0, "target": {"node": 1, "path": "rotation"}},
                     {"sampler": 1, "target": {"node": 0, "path": "translation"}}]}]
    asset = io.load(doc.write(tmp_path / "skin.gltf"))
    skin = asset.skin
    assert [n.name for n in skin.nodes[:2]] == ["root", "tip"] and skin.nodes[1].parent == 0
    assert skin.joints.tolist() == [0, 1]
    assert torch.allclose(skin.inverse_bind[1, 0, 3], torch.tensor(-1.0))
    assert torch.allclose(skin.mesh_to_world[:3, 3], torch.tensor([0.0, 0, 2]))
    assert asset.mesh.v_joints.shape == (4, 4) and torch.allclose(asset.mesh.v_weights[:, 1], torch.tensor(0.75))
    (rot, trans), = [asset.animations[0].channels]
    assert rot.interpolation == "STEP" and rot.values.shape == (2, 4)
    assert trans.interpolation == "CUBICSPLINE" and torch.equal(trans.values, torch.from_numpy(cubic))


def _single_triangle_doc(positions, indices) -> Doc:
    doc = Doc()
    acc = {"bufferView": doc.view(np.asarray(positions, np.float32).tobytes()), "componentType": 5126,
           "count": len(positions), "type": "VEC3"}
    doc.json["accessors"].append(acc)
    doc.mesh_node([{"attributes": {"POSITION": 0}, "indices": doc.accessor(indices, 5123)}])
    return doc


def test_bad_inputs_raise_asset_errors_naming_the_file(tmp_path):
    def fails(path, match):
        with pytest.raises(AssetError, match=match) as info:
            io.load(path)
        assert str(path) in str(info.value)

    fails(tmp_path / "absent.glb", "no such file")
    (tmp_path / "garbage.gltf").write_text("{not json")
    fails(tmp_path / "garbage.gltf", "not a valid glTF")

    doc, prim = quad_doc()
    prim["material"] = 0
    doc.mesh_node([prim])
    doc.json["images"] = [{"uri": "missing.png"}]
    doc.json["textures"] = [{"source": 0}]
    doc.json["materials"] = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]
    fails(doc.write(tmp_path / "tex.gltf"), "texture 'missing.png' is missing")

    doc, prim = quad_doc()
    doc.mesh_node([prim])
    doc.json["extensionsRequired"] = doc.json["extensionsUsed"] = ["KHR_draco_mesh_compression"]
    fails(doc.write(tmp_path / "ext.gltf"), "unsupported glTF extension.*KHR_draco_mesh_compression")

    doc = Doc()
    doc.json["buffers"] = []
    (tmp_path / "empty.gltf").write_text(json.dumps(doc.json))
    fails(tmp_path / "empty.gltf", "no triangles")

    fails(_single_triangle_doc([[0, 0, 0], [1, 0, np.nan], [0, 1, 0]], [0, 1, 2]).write(tmp_path / "nan.gltf"),
          "NaN or infinite")
    fails(_single_triangle_doc([[0, 0, 0], [1, 0, np.inf], [0, 1, 0]], [0, 1, 2]).write(tmp_path / "inf.gltf"),
          "NaN or infinite")
    fails(_single_triangle_doc(QUAD, [0, 1, 7]).write(tmp_path / "range.gltf"), "out of range")

    doc, prim = quad_doc()
    doc.mesh_node([prim])
    path = doc.write(tmp_path / "trunc.gltf", bin_file=True)
    (tmp_path / "data.bin").write_bytes(bytes(doc.blob[:20]))
    fails(path, "truncated")
    (tmp_path / "data.bin").unlink()
    fails(path, "missing or unreadable")

    io.save(Asset(mesh=plane(3)), tmp_path / "whole.glb")
    data = (tmp_path / "whole.glb").read_bytes()
    (tmp_path / "cut.glb").write_bytes(data[: len(data) - 40])
    fails(tmp_path / "cut.glb", "truncated")
    (tmp_path / "stub.glb").write_bytes(data[:10])
    fails(tmp_path / "stub.glb", "not a valid glTF")


def test_degenerate_and_non_manifold_geometry_loads(tmp_path):
    positions = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [2, 0, 0]]
    # A zero-area triangle, and three triangles sharing edge (0, 1).
    doc = _single_triangle_doc(positions, [0, 1, 5, 0, 1, 2, 1, 0, 3, 0, 1, 4])
    asset = io.load(doc.write(tmp_path / "nm.gltf"))
    assert asset.mesh.num_triangles == 4


# ----------------------------------------------------------------------------------------------
# Writing.

def _by_material(mesh):
    return torch.argsort(mesh.t_mat_idx, stable=True)


def test_glb_round_trip_keeps_geometry_uvs_and_materials(tmp_path):
    asset = two_material_asset(normal_map=True)
    asset.materials[0].ks.data[..., 0] = torch.linspace(0, 0.5, 16)[None, :]  # varying gamma
    asset.materials[1].ks.data[..., 0] = 0.25
    io.save(asset, tmp_path / "rt.glb")
    back = io.load(tmp_path / "rt.glb")
    order = _by_material(asset.mesh)
    src, dst = asset.mesh, back.mesh
    assert torch.equal(src.v_pos[src.t_pos_idx][order], dst.v_pos[dst.t_pos_idx])
    assert torch.equal(src.uv[0][0][src.uv[0][1]][order], dst.uv[0][0][dst.uv[0][1]])
    assert torch.equal(src.t_mat_idx[order], dst.t_mat_idx)
    assert dst.num_vertices == src.num_vertices  # positions welded again on load
    a, b = asset.materials, back.materials
    assert [m.name for m in b] == ["textured", "blended"]
    assert b[1].alpha_mode == "BLEND" and b[1].double_sided and b[0].alpha_mode == "OPAQUE"
    assert torch.allclose(b[1].kd.data, a[1].kd.data) and torch.allclose(b[1].ks.data, a[1].ks.data, atol=1e-6)
    assert torch.allclose(b[0].kd.data, a[0].kd.data, atol=0.01)  # 8-bit sRGB quantisation
    assert torch.allclose(b[0].ks.data, a[0].ks.data, atol=1 / 255 + 1e-6)  # 8-bit, dithered within a level
    inside = covered_texels(asset.mesh, 0, *a[0].normal.data.shape[:2])
    assert (b[0].normal.data - a[0].normal.data).norm(dim=-1)[inside].max() < 0.03  # ours -> MikkTSpace -> ours


def test_glb_writes_constants_as_factors_and_unwelds_per_corner(tmp_path):
    mesh = plane(3)
    io.save(Asset(mesh=mesh, materials=[Material(name="flat")]), tmp_path / "c.glb")
    gltf = json.loads(_glb_json(tmp_path / "c.glb"))
    assert "images" not in gltf and "TANGENT" not in gltf["meshes"][0]["primitives"][0]["attributes"]
    assert gltf["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] == pytest.approx([0.75, 0.72, 0.68, 1.0])
    position = gltf["accessors"][gltf["meshes"][0]["primitives"][0]["attributes"]["POSITION"]]
    assert position["min"] == [0, 0, 0] and position["max"] == [1, 1, 0] and position["count"] == 9


def test_a_constant_normal_map_is_left_out_only_where_it_is_flat(tmp_path):
    from lookalike.asset import Texture

    tilt = [0.6, 0.0, 0.8]
    for value, kept in (([0.0, 0.0, 1.0], False), (tilt, True)):
        io.save(Asset(mesh=plane(3), materials=[Material(normal=Texture.constant(value))]), tmp_path / "n.glb")
        assert ("normalTexture" in json.loads(_glb_json(tmp_path / "n.glb"))["materials"][0]) == kept, value
    normal = io.load(tmp_path / "n.glb").materials[0].normal.data.reshape(-1, 3)
    assert (normal - torch.tensor(tilt)).abs().max() < 0.01                 # the plane's frame is ours: the tilt comes back


def _glb_json(path: Path) -> str:
    data = path.read_bytes()
    length, = struct.unpack_from("<I", data, 12)
    return data[20:20 + length].decode()


def validate(path: Path) -> dict:
    """The Khronos glTF validator's report on ``path`` (npm ``gltf-validator``)."""
    modules = npm_package("gltf-validator")
    result = subprocess.run(["node", str(VALIDATOR), str(path), str(modules)], capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)


def assert_valid(path: Path):
    report = validate(path)
    errors = [m for m in report["issues"]["messages"] if m["severity"] == 0]
    assert report["issues"]["numErrors"] == 0, errors


def test_validator_accepts_normal_mapped_multi_material_glb(tmp_path):
    asset = two_material_asset(normal_map=True)
    asset.materials[0].ks.data[..., 0] = torch.linspace(0, 0.5, 16)[None, :]
    asset.materials[0].kd.transform = torch.tensor([[0.0, 2, 0.5], [-2, 0, 0.25], [0, 0, 1]])
    io.save(asset, tmp_path / "v.glb")
    report = validate(tmp_path / "v.glb")
    assert report["issues"]["numErrors"] == 0, report["issues"]["messages"]
    info = report["info"]
    assert info["materialCount"] == 2 and info["hasTextures"] and info["totalTriangleCount"] == asset.mesh.num_triangles
    assert set(report["info"]["extensionsUsed"]) == {"KHR_materials_specular", "KHR_texture_transform"}
    assert report["issues"]["numWarnings"] == 0, report["issues"]["messages"]
    assert torch.allclose(io.load(tmp_path / "v.glb").materials[0].kd.transform, asset.materials[0].kd.transform,
                          atol=1e-6)


def test_validator_sees_a_broken_file(tmp_path):
    """The validator check can fail: a GLB with a bad accessor reference has errors."""
    io.save(Asset(mesh=plane(3)), tmp_path / "ok.glb")
    data = bytearray((tmp_path / "ok.glb").read_bytes())
    text = _glb_json(tmp_path / "ok.glb")
    broken = text.replace('"indices":', '"indices":9', 1)
    assert len(broken) != len(text)
    doc = json.loads(broken)
    blob = data[20 + len(text) :]
    body = json.dumps(doc, separators=(",", ":")).encode()
    body += b" " * (-len(body) % 4)
    out = struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(body) + len(blob)) + struct.pack("<I4s", len(body), b"JSON")
    (tmp_path / "bad.glb").write_bytes(out + body + blob)
    assert validate(tmp_path / "bad.glb")["issues"]["numErrors"] > 0


def test_animation_sampler_with_the_wrong_number_of_values_is_a_one_line_error(tmp_path):
    doc = _skinned_quad_doc()
    times = doc.accessor(np.array([0, 1], np.float32))
    values = doc.accessor(np.array([[0, 0, 0], [1, 2, 3]], np.float32))  # 2 rows; CUBICSPLINE needs 6
    doc.json["animations"] = [{"samplers": [{"input": times, "output": values, "interpolation": "CUBICSPLINE"}],
                               "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}]}]
    with pytest.raises(AssetError, match="CUBICSPLINE sampler with 2 key times and 2 output values"):
        io.load(doc.write(tmp_path / "bad.gltf"))


def test_skinned_asset_round_trip_keeps_skin_and_animations(tmp_path):
    mesh = plane(3)
    mesh.v_joints = torch.tensor([[0, 1, 0, 0]] * mesh.num_vertices)
    mesh.v_weights = torch.tensor([[0.5, 0.5, 0, 0]] * mesh.num_vertices)
    nodes = [Node("root", -1, torch.tensor([1.0, 0, 0]), torch.tensor([0.0, 0, 0, 1]), torch.ones(3)),
             Node("tip", 0, torch.zeros(3), torch.tensor([0.0, 0, 0.6, 0.8]), torch.ones(3))]
    mesh_to_world = torch.eye(4)
    mesh_to_world[:3, 3] = torch.tensor([0.0, 0, 2])
    skin = Skin(nodes=nodes, joints=torch.tensor([0, 1]), inverse_bind=torch.eye(4).repeat(2, 1, 1),
                mesh_to_world=mesh_to_world)
    cubic = torch.tensor([[0.0, 0, 0], [1, 0, 0], [0.5, 0, 0], [0.25, 0, 0], [2, 0, 0], [0, 0, 0]])
    anim = Animation("wave", [Channel(1, "rotation", torch.tensor([0.0, 1.0]),
                                      torch.tensor([[0.0, 0, 0, 1], [0, 0, 0.6, 0.8]]), "STEP"),
                              Channel(0, "translation", torch.tensor([0.0, 1.0]), cubic, "CUBICSPLINE")])
    asset = Asset(mesh=mesh, skin=skin, animations=[anim])
    io.save(asset, tmp_path / "s.glb")
    assert_valid(tmp_path / "s.glb")
    back = io.load(tmp_path / "s.glb")
    assert back.skin.joints.tolist() == [0, 1] and len(back.animations) == 1
    ch, spline = back.animations[0].channels
    assert (ch.node, ch.path, ch.interpolation) == (1, "rotation", "STEP")
    assert spline.interpolation == "CUBICSPLINE" and torch.equal(spline.values, cubic)  # tangents kept
    # The mesh is written in the frame the inverse bind matrices expect (the baked mesh transform
    # undone), the matrices as they were; the posed mesh is unchanged.
    assert torch.equal(back.skin.inverse_bind, skin.inverse_bind) and torch.equal(back.skin.mesh_to_world, torch.eye(4))
    assert torch.equal(back.mesh.v_pos[back.mesh.t_pos_idx], mesh.v_pos[mesh.t_pos_idx] - torch.tensor([0.0, 0, 2]))
    assert torch.allclose(_posed_corners(back, [0.0, 0.5]), _posed_corners(asset, [0.0, 0.5]), atol=1e-6)
    assert torch.allclose(back.mesh.v_weights[:, :2], torch.tensor(0.5))


# ----------------------------------------------------------------------------------------------
# Skins: several skins over one skeleton, and the rig kept byte for byte.

def _posed_corners(asset: Asset, times: list[float], clip: int = 0) -> torch.Tensor:
    """``[F, T, 3, 3]`` float64 corners of ``asset`` skinned at ``times`` of animation ``clip``
    (rest pose where it has none): ``sum_k w_k world(joint_k) @ IBM_k @ inv(mesh_to_world) @ p``."""
    skin, mesh = asset.skin, asset.mesh
    animation = asset.animations[clip] if asset.animations else None
    world = node_world_matrices(skin, animation, torch.tensor(times, dtype=torch.float64))[:, skin.joints]
    matrices = world.double() @ skin.inverse_bind.double() @ torch.linalg.inv(skin.mesh_to_world.double())
    dense = torch.zeros(mesh.num_vertices, len(skin.joints), dtype=torch.float64)
    dense.scatter_add_(1, mesh.v_joints, mesh.v_weights.double())
    points = torch.cat([mesh.v_pos.double(), torch.ones(mesh.num_vertices, 1, dtype=torch.float64)], dim=1)
    posed = torch.einsum("vj,fjrc,vc->fvr", dense, matrices[:, :, :3], points)
    return posed[:, mesh.t_pos_idx]


def _quaternion(axis, angle: float) -> list[float]:
    """Unit quaternion ``[x, y, z, w]`` of a rotation by ``angle`` about ``axis``."""
    axis = np.asarray(axis, np.float64) / np.linalg.norm(axis)
    return [*(axis * math.sin(angle / 2)).tolist(), math.cos(angle / 2)]


def _trs(translation=(0, 0, 0), rotation=(0, 0, 0, 1), scale=(1, 1, 1)) -> np.ndarray:
    """``[4, 4]`` float64 ``T @ R @ S`` of glTF node properties (rotation ``[x, y, z, w]``)."""
    x, y, z, w = rotation
    r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    m = np.eye(4)
    m[:3, :3] = r * np.asarray(scale, np.float64)
    m[:3, 3] = translation
    return m


# A three-node chain (root, mid, tip): the shared skeleton of the skinned test files.
CHAIN = [{"name": "root", "children": [1], "translation": [1, 0, 0]},
         {"name": "mid", "children": [2], "translation": [0, 1, 0], "rotation": _quaternion([0, 0, 1], 0.4)},
         {"name": "tip", "translation": [0, 1, 0], "scale": [1, 2, 1]}]
QUAD_TRIANGLES = [[0, 1, 2], [0, 2, 3]]


def _chain_rest_world() -> np.ndarray:
    """``[3, 4, 4]`` float64 rest world matrices of ``CHAIN``'s nodes."""
    local = [_trs(**{k: v for k, v in node.items() if k in ("translation", "rotation", "scale")}) for node in CHAIN]
    return np.stack([local[0], local[0] @ local[1], local[0] @ local[1] @ local[2]])


def _chain_ibm() -> np.ndarray:
    """``[3, 4, 4]`` float32 inverse bind matrix of each ``CHAIN`` node, not the inverse of its
    rest world matrix (so the rest pose moves the mesh)."""
    offsets = np.stack([_trs([0.1 * n, 0, -0.3], _quaternion([1, 0, 0], 0.2 * n + 0.1)) for n in range(3)])
    return (np.linalg.inv(_chain_rest_world()) @ offsets).astype(np.float32)


def _two_skin_doc(placement: dict) -> tuple[Doc, list[tuple]]:
    """Two quads on two mesh nodes, each with its own skin over ``CHAIN`` (per-node inverse bind
    matrices shared): skin A with joints [0, 1] on a node at z = 2, skin B with joints [2, 1, 0]
    on a node placed by ``placement``. Returns the document and, per mesh, its local positions
    ``[4, 3]``, the skin's joint nodes, JOINTS_0 and WEIGHTS_0 ``[4, 4]``."""
    doc = Doc()
    doc.json["nodes"] = [dict(n) for n in CHAIN]
    doc.json["scenes"][0]["nodes"] = [0]
    doc.json["skins"] = []
    ibm = _chain_ibm()
    meshes = [(QUAD, [0, 1], [[0, 1, 0, 0], [1, 0, 0, 0], [0, 1, 0, 0], [1, 0, 0, 0]],
               [[0.25, 0.75, 0, 0], [1, 0, 0, 0], [0.5, 0.5, 0, 0], [1, 0, 0, 0]]),
              (QUAD + np.float32([0, 0, 1]), [2, 1, 0], [[0, 1, 2, 0], [2, 0, 0, 0], [1, 2, 0, 0], [0, 1, 0, 0]],
               [[0.5, 0.25, 0.25, 0], [1, 0, 0, 0], [0.75, 0.25, 0, 0], [0.5, 0.5, 0, 0]])]
    for (positions, nodes, joints, weights), place in zip(meshes, [{"translation": [0, 0, 2]}, placement]):
        matrices = ibm[nodes].transpose(0, 2, 1).reshape(-1, 16)  # column-major
        doc.json["skins"].append({"joints": nodes, "inverseBindMatrices": doc.accessor(matrices, kind="MAT4")})
        prim = {"attributes": {"POSITION": doc.accessor(positions), "JOINTS_0": doc.accessor(joints, 5121),
                               "WEIGHTS_0": doc.accessor(weights)},
                "indices": doc.accessor(np.reshape(QUAD_TRIANGLES, -1), 5123)}
        doc.mesh_node([prim], skin=len(doc.json["skins"]) - 1, **place)
    return doc, meshes


def _gltf_posed(positions, nodes, joints, weights) -> np.ndarray:
    """``[n, 3]`` rest-pose glTF skinning of one skin's mesh by hand, from the file's data:
    ``sum_k w_k world(nodes[j_k]) @ IBM(nodes[j_k]) @ p`` (the mesh node's transform ignored)."""
    matrices = (_chain_rest_world() @ _chain_ibm().astype(np.float64))[np.asarray(nodes)[np.asarray(joints)]]
    points = np.concatenate([np.asarray(positions, np.float64), np.ones((len(positions), 1))], axis=1)
    return np.einsum("nk,nkrc,nc->nr", np.asarray(weights, np.float64), matrices, points)[:, :3]


MOVED = {"translation": [0.5, -1, 3], "rotation": _quaternion([1, 2, 3], 0.7), "scale": [1.5] * 3}


@pytest.mark.parametrize("placement", [{"translation": [0, 0, 2]}, MOVED], ids=["same-node-transform", "moved"])
def test_skins_over_one_skeleton_load_as_one_skin(tmp_path, placement):
    doc, meshes = _two_skin_doc(placement)
    asset = io.load(doc.write(tmp_path / "two.gltf"))
    skin = asset.skin
    expected = np.concatenate([_gltf_posed(*mesh)[QUAD_TRIANGLES] for mesh in meshes])
    assert torch.allclose(_posed_corners(asset, [0.0])[0], torch.from_numpy(expected), atol=1e-5)
    assert torch.equal(skin.mesh_to_world[:3, 3], torch.tensor([0.0, 0, 2]))
    if placement is MOVED:  # skin B's matrices differ once its node's transform is folded in
        assert skin.joints.tolist() == [0, 1, 2, 1, 0]
    else:  # one slot per node, the file's float32 matrices unchanged
        assert skin.joints.tolist() == [0, 1, 2] and torch.equal(skin.inverse_bind, torch.from_numpy(_chain_ibm()))
        b_first = asset.mesh.t_pos_idx[2, 0]  # skin B's vertex 0: file joints (0, 1, 2) are nodes (2, 1, 0)
        assert asset.mesh.v_joints[b_first].tolist() == [2, 1, 0, 0]
    io.save(asset, tmp_path / "two.glb")
    back = io.load(tmp_path / "two.glb")
    assert torch.allclose(_posed_corners(back, [0.0]), _posed_corners(asset, [0.0]), atol=1e-5)


def _animated_skin_doc() -> Doc:
    """A quad skinned to ``CHAIN`` (skin "rig", skeleton root 0) on a mesh node moved by a
    translation, rotation and uniform scale, with float32 inverse bind matrices
    ``inv(rest world) @ mesh node world``; clip "move" has LINEAR, STEP and CUBICSPLINE samplers
    (two sharing their key times), clip "still" one LINEAR key."""
    doc = Doc()
    doc.json["nodes"] = [dict(n) for n in CHAIN]
    doc.json["scenes"][0]["nodes"] = [0]
    placement = {"translation": [0.3, -0.2, 1.5], "rotation": _quaternion([1, 2, 3], 0.7), "scale": [0.8] * 3}
    ibm = (np.linalg.inv(_chain_rest_world()) @ _trs(**placement)).astype(np.float32)
    doc.json["skins"] = [{"name": "rig", "skeleton": 0, "joints": [0, 1, 2],
                          "inverseBindMatrices": doc.accessor(ibm.transpose(0, 2, 1).reshape(-1, 16), kind="MAT4")}]
    joints = np.array([[0, 1, 2, 0], [1, 2, 0, 0], [2, 0, 0, 0], [0, 1, 0, 0]], np.uint8)
    weights = np.array([[0.1, 0.2, 0.7, 0], [0.6, 0.4, 0, 0], [1, 0, 0, 0], [0.3, 0.7, 0, 0]], np.float32)
    prim = {"attributes": {"POSITION": doc.accessor(QUAD), "JOINTS_0": doc.accessor(joints, 5121),
                           "WEIGHTS_0": doc.accessor(weights)},
            "indices": doc.accessor(np.reshape(QUAD_TRIANGLES, -1), 5123)}
    doc.mesh_node([prim], name="body", skin=0, **placement)
    keys = doc.accessor(np.array([0, 0.5, 2], np.float32))
    rotations = np.array([_quaternion([0, 0, 1], 0), _quaternion([0, 0, 1], 0.8), _quaternion([1, 0, 0], 0.5)])
    cubic = np.array([[0, 0, 0], [1, 1, 1], [0.5, 0, 0], [0.1, 0.2, 0], [1.5, 0.5, 1], [0, 0, 0]], np.float32)
    doc.json["animations"] = [
        {"name": "move", "samplers": [
            {"input": keys, "output": doc.accessor(rotations.astype(np.float32))},
            {"input": keys, "output": doc.accessor(np.array([[1, 0, 0], [1.2, 0, 0], [1, 0.3, 0]], np.float32)),
             "interpolation": "STEP"},
            {"input": doc.accessor(np.array([0, 1.5], np.float32)), "output": doc.accessor(cubic),
             "interpolation": "CUBICSPLINE"}],
         "channels": [{"sampler": 0, "target": {"node": 1, "path": "rotation"}},
                      {"sampler": 1, "target": {"node": 0, "path": "translation"}},
                      {"sampler": 2, "target": {"node": 2, "path": "scale"}}]},
        {"name": "still", "samplers": [{"input": doc.accessor(np.array([0], np.float32)),
                                        "output": doc.accessor(np.array([[0, 1.1, 0]], np.float32))}],
         "channels": [{"sampler": 0, "target": {"node": 2, "path": "translation"}}]}]
    return doc


def _rig(path: Path, source: Path) -> tuple:
    """What a round trip of skinned glTF file ``source`` keeps of its rig, read from ``path``
    (``source`` or the written file): skin 0's joints, the float32 bytes of its inverse bind
    matrices, per animation per channel its target, interpolation and the float32 bytes of its
    sampler's input and output, and the name, parent and float32 TRS (where ``source`` has no
    matrix, and for nodes other than the skinned mesh's, whose transform glTF ignores and the
    writer drops) of each of ``source``'s nodes."""
    data = GltfData(parse_gltf(path), path)
    gltf = data.gltf
    skin = gltf.skins[0]
    animations = [[(c.target.node, c.target.path, a.samplers[c.sampler].interpolation or "LINEAR",
                    data.accessor(a.samplers[c.sampler].input).tobytes(),
                    data.accessor(a.samplers[c.sampler].output).tobytes()) for c in a.channels]
                  for a in gltf.animations]
    parents = [-1] * len(gltf.nodes)
    for i, node in enumerate(gltf.nodes):
        for child in node.children or []:
            parents[child] = i
    matrix = [n.matrix is not None or n.skin is not None for n in parse_gltf(source).nodes]
    nodes = [(n.name, parents[i], None if matrix[i] else np.float32(
        [*(n.translation or [0, 0, 0]), *(n.rotation or [0, 0, 0, 1]), *(n.scale or [1, 1, 1])]).tobytes())
        for i, n in enumerate(gltf.nodes[:len(matrix)])]
    return skin.joints, data.accessor(skin.inverseBindMatrices).tobytes(), animations, nodes


def test_skinned_gltf_round_trip_keeps_the_rig_byte_for_byte(tmp_path):
    source = _animated_skin_doc().write(tmp_path / "rig.gltf")
    asset = io.load(source)
    assert (asset.skin.name, asset.skin.skeleton) == ("rig", 0)
    io.save(asset, tmp_path / "rig.glb")
    assert _rig(tmp_path / "rig.glb", source) == _rig(source, source)
    written = json.loads(_glb_json(tmp_path / "rig.glb"))
    assert (written["skins"][0]["name"], written["skins"][0]["skeleton"]) == ("rig", 0)
    assert [a["name"] for a in written["animations"]] == ["move", "still"]
    # The mesh goes back on the node that held it, without its (ignored) transform: no node is added.
    source_nodes = json.loads(Path(source).read_text())["nodes"]
    home = next(i for i, n in enumerate(source_nodes) if "skin" in n)
    assert len(written["nodes"]) == len(source_nodes) and written["nodes"][home].keys() == {"name", "mesh", "skin"}
    assert home in written["scenes"][0]["nodes"]
    back = io.load(tmp_path / "rig.glb")
    assert torch.equal(back.skin.mesh_to_world, torch.eye(4))
    # Weights that sum to 1 to float32 rounding are written as given.
    assert torch.equal(back.mesh.v_weights[back.mesh.t_pos_idx], asset.mesh.v_weights[asset.mesh.t_pos_idx])
    times = [0.0, 0.3, 0.5, 1.1, 2.5]
    for clip in range(2):
        assert torch.allclose(_posed_corners(back, times, clip), _posed_corners(asset, times, clip), atol=1e-5)


def test_validator_accepts_round_tripped_skinned_glbs(tmp_path):
    io.save(io.load(_animated_skin_doc().write(tmp_path / "rig.gltf")), tmp_path / "rig.glb")
    io.save(io.load(_two_skin_doc(MOVED)[0].write(tmp_path / "two.gltf")), tmp_path / "two.glb")
    for name in ("rig.glb", "two.glb"):
        report = validate(tmp_path / name)
        assert report["issues"]["numErrors"] == 0, report["issues"]["messages"]
        assert report["issues"]["numWarnings"] == 0, report["issues"]["messages"]
    # The joined skin repeats joint nodes 1 and 0: written as untransformed children of theirs.
    written = json.loads(_glb_json(tmp_path / "two.glb"))
    joints = written["skins"][0]["joints"]
    assert joints[:3] == [0, 1, 2] and len(set(joints)) == 5
    assert [written["nodes"][j].keys() == {"name"} for j in joints[3:]] == [True, True]


# ----------------------------------------------------------------------------------------------
# Real assets.

@pytest.mark.parametrize("name, triangles", [
    ("flight-helmet/FlightHelmet.gltf", 94722), ("cesium-man/CesiumMan.glb", 4672), ("fox/Fox.glb", 576),
    ("alpha-blend-mode-test/AlphaBlendModeTest.glb", 61)])
def test_real_gltf_assets_load(shared_assets, name, triangles):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        asset = io.load(shared_assets / name)
    mesh = asset.mesh
    assert mesh.num_triangles == triangles
    assert torch.isfinite(mesh.v_pos).all() and mesh.t_pos_idx.max() < mesh.num_vertices
    assert int(mesh.t_mat_idx.max()) < len(asset.materials)
    for m in asset.materials:
        for tex in (m.kd, m.ks):
            assert torch.isfinite(tex.data).all() and tex.data.min() >= 0 and tex.data.max() <= 1
        if m.normal is not None:
            assert torch.allclose(m.normal.data.norm(dim=-1), torch.tensor(1.0), atol=1e-4)
    if name.startswith("flight"):
        # Six glTF materials; HoseMat reuses RubberWood's textures: five distinct texture sets.
        assert len(asset.materials) == 6
        assert len({tuple(m.kd.data.flatten()[:64].tolist()) for m in asset.materials}) == 5
        assert sum(m.normal is not None for m in asset.materials) == 6
        assert asset.materials[5].alpha_mode == "BLEND"
    if name.startswith("cesium"):
        assert len(asset.skin.joints) == 19 and len(asset.animations) == 1
    if name.startswith("fox"):
        assert len(asset.skin.joints) == 24 and sorted(a.name for a in asset.animations) == ["Run", "Survey", "Walk"]
    if name.startswith("alpha"):
        assert {m.alpha_mode for m in asset.materials} == {"OPAQUE", "MASK", "BLEND"}


@pytest.mark.parametrize("name", ["fox/Fox.glb", "cesium-man/CesiumMan.glb", "soldier/Soldier.glb",
                                  "flight-helmet/FlightHelmet.gltf"])
def test_real_assets_written_as_glb_validate(shared_assets, tmp_path, name):
    asset = io.load(shared_assets / name)
    io.save(asset, tmp_path / "out.glb")
    assert_valid(tmp_path / "out.glb")
    back = io.load(tmp_path / "out.glb")
    assert back.mesh.num_triangles == asset.mesh.num_triangles
    assert (back.skin is None) == (asset.skin is None) and len(back.animations) == len(asset.animations)
    order = _by_material(asset.mesh)
    if asset.skin is not None:  # the animated pose is unchanged by the round trip
        assert torch.allclose(_posed_corners(back, [0.7]), _posed_corners(asset, [0.7])[:, order], atol=1e-5)
    else:
        assert torch.equal(back.mesh.v_pos[back.mesh.t_pos_idx], asset.mesh.v_pos[asset.mesh.t_pos_idx][order])


@pytest.mark.parametrize("name", ["cesium-man/CesiumMan.glb", "fox/Fox.glb", "soldier/Soldier.glb"])
def test_real_skinned_assets_keep_their_rig_byte_for_byte(shared_assets, tmp_path, name):
    """Soldier has two meshes sharing one skin, under a node that scales them by about 0.0012."""
    asset = io.load(shared_assets / name)
    io.save(asset, tmp_path / "out.glb")
    assert _rig(tmp_path / "out.glb", shared_assets / name) == _rig(shared_assets / name, shared_assets / name)
    back = io.load(tmp_path / "out.glb")
    times = [0.0, 0.4, 1.3]
    for clip in range(len(asset.animations)):
        expected = _posed_corners(asset, times, clip)[:, _by_material(asset.mesh)]
        assert torch.allclose(_posed_corners(back, times, clip), expected, atol=1e-5)


def test_influences_not_a_multiple_of_four_are_padded_with_zero_weights(tmp_path):
    from skin_factory import bent_cylinder

    asset = bent_cylinder()
    mesh = asset.mesh
    mesh.v_joints, mesh.v_weights = mesh.v_joints[:, :2].contiguous(), mesh.v_weights[:, :2].contiguous()
    io.save(asset, tmp_path / "two.glb")
    back = io.load(tmp_path / "two.glb")
    assert back.mesh.v_joints.shape[1] == 4 and (back.mesh.v_weights[:, 2:] == 0).all()
    dense = torch.zeros(back.mesh.num_vertices, 2).scatter_add(1, back.mesh.v_joints.clamp(max=1), back.mesh.v_weights)
    assert torch.allclose(dense.sum(1), torch.ones(back.mesh.num_vertices))
    assert validate(tmp_path / "two.glb")["issues"]["numErrors"] == 0


def test_an_unskinned_prop_on_a_bone_moves_with_it(tmp_path):
    """A skinned quad and an unskinned quad placed by a child node of the tip joint: the prop is
    bound rigidly to its node, so the tip's animation carries it."""
    doc = _skinned_quad_doc()
    prop = {"attributes": {"POSITION": doc.accessor(QUAD + np.float32([0, 0, 5]))},
            "indices": doc.accessor([0, 1, 2, 0, 2, 3], 5123)}
    doc.json["meshes"].append({"primitives": [prop]})
    doc.json["nodes"].append({"name": "prop", "mesh": len(doc.json["meshes"]) - 1, "translation": [0, 3, 0]})
    doc.json["nodes"][1]["children"] = [len(doc.json["nodes"]) - 1]
    quarter = [0, 0, math.sin(math.pi / 4), math.cos(math.pi / 4)]
    doc.json["animations"] = [{"name": "turn", "samplers": [
        {"input": doc.accessor(np.float32([0, 1])), "output": doc.accessor(np.float32([[0, 0, 0, 1], quarter]))}],
        "channels": [{"sampler": 0, "target": {"node": 1, "path": "rotation"}}]}]
    asset = io.load(doc.write(tmp_path / "prop.gltf"))
    prop_tris = asset.mesh.v_pos[asset.mesh.t_pos_idx][..., 2].mean(-1) > 4  # the prop's, at z = 5 in its node
    assert prop_tris.sum() == 2
    prop_node = next(i for i, n in enumerate(asset.skin.nodes) if n.name == "prop")
    local = torch.cat([torch.from_numpy(QUAD).double() + torch.tensor([0.0, 0, 5]), torch.ones(4, 1, dtype=torch.float64)], 1)
    for time in (0.0, 0.5, 1.0):  # the tip's rotation animated: the prop, 3 up its y axis, is carried round
        world = node_world_matrices(asset.skin, asset.animations[0], torch.tensor([time], dtype=torch.float64))[0]
        expected = (world[prop_node].double() @ local.T).T[:, :3]
        turned = _posed_corners(asset, [time])[0][prop_tris]
        gap = torch.cdist(turned.reshape(-1, 3), expected)
        assert gap.min(1).values.max() < 1e-5 and gap.min(0).values.max() < 1e-5
    io.save(asset, tmp_path / "prop.glb")
    assert torch.allclose(_posed_corners(io.load(tmp_path / "prop.glb"), [1.0])[0][prop_tris], turned, atol=1e-5)


def test_a_model_with_no_triangles_is_written_as_a_node_without_a_mesh(tmp_path):
    """Plain decimation of foliage can leave nothing: the file shows nothing, and validates
    (glTF has no empty mesh)."""
    mesh = plane(3)
    empty = Asset(mesh=Mesh(v_pos=mesh.v_pos[:0], t_pos_idx=mesh.t_pos_idx[:0]))
    io.save(empty, tmp_path / "empty.glb")
    doc = json.loads(_glb_json(tmp_path / "empty.glb"))
    assert "meshes" not in doc and doc["nodes"] == [{"name": empty.name}] and doc["scenes"] == [{"nodes": [0]}]
    assert_valid(tmp_path / "empty.glb")


def test_a_written_smooth_roughness_map_keeps_its_local_means(tmp_path):
    asset = two_material_asset(normal_map=False)
    roughness = torch.linspace(0.30, 0.31, 32)[None, :, None].expand(32, 32, 1)  # under three levels of 8 bits
    asset.materials[0].ks = Texture(torch.cat([torch.zeros(32, 32, 1), roughness, torch.full((32, 32, 1), 0.5)], -1))
    io.save(asset, tmp_path / "smooth.glb")
    back = io.load(tmp_path / "smooth.glb").materials[0].ks.data[..., 1]
    error = (back - roughness[..., 0]) * 255
    assert error.abs().max() < 1.0 and error.reshape(4, 8, 4, 8).mean(dim=(1, 3)).abs().max() < 0.06
    assert len(torch.unique(back[:, 0])) > 1  # dithered: a column of one value is not one level
