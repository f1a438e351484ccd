"""OBJ + MTL reading and writing."""

from __future__ import annotations

import time

import numpy as np
import pytest
import torch

from io_factory import covered_texels, two_material_asset
from lookalike import io
from lookalike.asset import Texture
from lookalike.errors import AssetError
from lookalike.io.image_files import srgb_to_linear, write_png
from log_capture import expect_warning

OBJ = """# a quad, a pentagon with negative indices, a triangle without vt
mtllib m.mtl
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 1
usemtl red
f 1/1/1 2/2/1 3/3/1 4/4/1
v 2 0 0
v 3 0 0
v 3 1 0
v 2.5 1.5 0
v 2 1 0
usemtl textured
f -5/1 -4/2 -3/3 -2/4 -1/1
g other
usemtl red
f 1//1 2//1 4//1
"""

MTL = """newmtl red
Kd 1 0 0
d 0.5
Pr 0.3
Pm 0.7
Ke 0.1 0.2 0.3

newmtl textured
Kd 0.2 0.2 0.2
Tr 0.0
map_Kd -s 1 1 1 tex.png
map_Pr rough.png
map_Bump -bm 0.5 normal.png
"""


@pytest.fixture
def obj_dir(tmp_path):
    (tmp_path / "m.obj").write_text(OBJ)
    (tmp_path / "m.mtl").write_text(MTL)
    write_png(np.full((4, 4, 3), 0.5, np.float32), tmp_path / "tex.png")
    write_png(np.full((4, 4, 1), 0.6, np.float32), tmp_path / "rough.png")
    write_png(np.tile(np.array([0.75, 0.5, 1.0], np.float32), (4, 4, 1)), tmp_path / "normal.png")
    return tmp_path


def test_reads_polygons_negative_indices_and_materials(obj_dir):
    asset = io.load(obj_dir / "m.obj")
    mesh = asset.mesh
    assert mesh.num_triangles == 2 + 3 + 1
    assert mesh.t_mat_idx.tolist() == [0, 0, 1, 1, 1, 0]
    # Fan triangulation of the pentagon 5..9 (0-based 4..8).
    assert mesh.t_pos_idx[2:5].tolist() == [[4, 5, 6], [4, 6, 7], [4, 7, 8]]
    # v flipped: OBJ vt (1, 1) -> (1, 0); the triangle without vt points at a zero UV.
    uv = mesh.uv[0][0][mesh.uv[0][1]]
    assert uv[0].tolist() == [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0]]
    assert uv[5].abs().sum() == 0
    assert mesh.v_nrm is not None and mesh.t_nrm_idx.shape == (6, 3)
    red, textured = asset.materials
    assert red.name == "red" and red.alpha_mode == "BLEND"
    assert torch.allclose(red.kd.data.reshape(-1), torch.tensor([1.0, 0, 0, 0.5]))
    assert torch.allclose(red.ks.data.reshape(-1), torch.tensor([0.0, 0.3, 0.7]))
    assert torch.allclose(red.emissive.data.reshape(-1), torch.tensor([0.1, 0.2, 0.3]))
    assert textured.alpha_mode == "OPAQUE"
    assert torch.allclose(textured.kd.data[0, 0, :3], torch.tensor(float(srgb_to_linear(np.float32(128 / 255)))))
    assert textured.ks.data.shape == (4, 4, 3) and torch.allclose(textured.ks.data[..., 1], torch.tensor(153 / 255))
    # Normal map (0.5, 0, 1) scaled by -bm 0.5 in x, y: (0.25, 0, 1) normalised. On this flat
    # pentagon both tangent frames share n = +z, so the conversion to our frame only turns x, y.
    expected = torch.tensor([0.25, 0.0, 1.0]) / torch.tensor([0.25, 0.0, 1.0]).norm()
    n = textured.normal.data.reshape(-1, 3)
    assert torch.allclose(n[:, 2], expected[2], atol=0.01)
    assert torch.allclose(n[:, :2].norm(dim=-1), expected[0], atol=0.01)


def test_nvdiffmodeling_pbr_ks(tmp_path):
    (tmp_path / "a.obj").write_text("mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m\nf 1 2 3\n")
    (tmp_path / "a.mtl").write_text("newmtl m\nbsdf pbr\nKs 0.1 0.25 0.5\n")
    asset = io.load(tmp_path / "a.obj")
    assert torch.allclose(asset.materials[0].ks.data.reshape(-1), torch.tensor([0.1, 0.25, 0.5]))


def test_faces_without_material_library_get_default(tmp_path, caplog):
    (tmp_path / "a.obj").write_text("mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with expect_warning(caplog, "not found"):
        asset = io.load(tmp_path / "a.obj")
    assert [m.name for m in asset.materials] == ["default"] and asset.mesh.uv == []


def test_vertex_colours(tmp_path):
    (tmp_path / "c.obj").write_text("v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n")
    mesh = io.load(tmp_path / "c.obj").mesh
    assert torch.equal(mesh.v_color, torch.tensor([[1.0, 0, 0, 1], [0, 1, 0, 1], [0, 0, 1, 1]]))


def test_bad_obj_inputs(tmp_path):
    def fails(text, match, mtl=None):
        path = tmp_path / "bad.obj"
        path.write_text(text)
        if mtl is not None:
            (tmp_path / "bad.mtl").write_text(mtl)
        with pytest.raises(AssetError, match=match) as info:
            io.load(path)
        assert str(path.with_suffix("")) in str(info.value)  # names bad.obj or its bad.mtl

    tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
    fails("v 0 0 0\n", "no faces")
    fails("", "no vertices")
    fails(tri + "f 1 2 4\n", "only 3 exist")
    fails(tri + "f 1 2 -4\n", "only 3 exist")
    fails("v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "NaN or infinite")
    fails("v 0 0 x\nf 1 2 3\n", "malformed 'v'")
    fails(tri + "f 1 2\n", "fewer than three")
    fails("mtllib bad.mtl\n" + tri + "usemtl m\nf 1 2 3\n", "texture 'nothere.png' is missing",
          mtl="newmtl m\nmap_Kd nothere.png\n")


def test_degenerate_and_non_manifold_obj_loads(tmp_path):
    (tmp_path / "d.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 2 0 0\n"
                                    "f 1 2 6\nf 1 2 3\nf 2 1 4\nf 1 2 5\nf 1 1 1\n")
    assert io.load(tmp_path / "d.obj").mesh.num_triangles == 5


def test_obj_round_trip_keeps_geometry_uvs_and_materials(tmp_path, caplog):
    asset = two_material_asset(normal_map=True)
    asset.materials[1].alpha_mode = "OPAQUE"
    asset.materials[1].kd = Texture.constant([0.2, 0.4, 0.6, 1.0])
    with expect_warning(caplog, "gamma"):
        io.save(asset, tmp_path / "rt.obj")
    assert (tmp_path / "rt.mtl").is_file() and (tmp_path / "rt_textured_basecolor.png").is_file()
    back = io.load(tmp_path / "rt.obj")
    src, dst = asset.mesh, back.mesh
    order = torch.argsort(src.t_mat_idx, stable=True)
    assert torch.allclose(src.v_pos[src.t_pos_idx][order], dst.v_pos[dst.t_pos_idx], atol=1e-6)
    assert torch.allclose(src.uv[0][0][src.uv[0][1]][order], dst.uv[0][0][dst.uv[0][1]], atol=1e-6)
    assert torch.equal(src.t_mat_idx[order], dst.t_mat_idx)
    a, b = asset.materials, back.materials
    assert [m.name for m in b] == ["textured", "blended"]
    assert torch.allclose(b[0].kd.data, a[0].kd.data, atol=0.01)
    assert torch.allclose(b[0].ks.data[..., 1:], a[0].ks.data[..., 1:], atol=0.5 / 255 + 1e-6)
    assert torch.allclose(b[1].kd.data, a[1].kd.data, atol=1e-6)
    assert torch.allclose(b[1].ks.data[..., 1:], a[1].ks.data[..., 1:], atol=1e-6)
    inside = covered_texels(asset.mesh, 0, *a[0].normal.data.shape[:2])
    assert (b[0].normal.data - a[0].normal.data).norm(dim=-1)[inside].max() < 0.03


@pytest.mark.parametrize("name, triangles, seconds", [
    ("spot/spot.obj", 5856, 2.0), ("stanford-bunny/stanford-bunny.obj", 69451, 2.0),
    ("nefertiti/nefertiti.obj", 99938, 2.0)])
def test_real_obj_assets_load_fast(shared_assets, name, triangles, seconds):
    io.load(shared_assets / name)  # warm caches (numba, file system)
    start = time.perf_counter()
    asset = io.load(shared_assets / name)
    elapsed = time.perf_counter() - start
    assert asset.mesh.num_triangles == triangles
    assert elapsed < seconds, f"{name} took {elapsed:.2f} s"
    if name.startswith("spot"):
        assert asset.materials[0].kd.data.shape[:2] == (1024, 1024) or asset.materials[0].kd.data.shape[0] > 1
        assert torch.allclose(asset.materials[0].ks.data.reshape(-1), torch.tensor([0.0, 0.25, 0.0]))
        assert len(asset.mesh.uv) == 1


def test_alpha_metalness_and_emission_maps(tmp_path):
    (tmp_path / "a.obj").write_text("mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
                                    "usemtl m\nf 1/1 2/2 3/3\n")
    (tmp_path / "a.mtl").write_text("newmtl m\nd 0.8\nmap_d alpha.png\nmap_Pm metal.png\nKe 2 2 2\nmap_Ke glow.png\n")
    write_png(np.full((2, 2, 1), 0.5, np.float32), tmp_path / "alpha.png")
    write_png(np.full((2, 2, 1), 1.0, np.float32), tmp_path / "metal.png")
    write_png(np.full((2, 2, 3), 1.0, np.float32), tmp_path / "glow.png")
    m = io.load(tmp_path / "a.obj").materials[0]
    assert m.alpha_mode == "BLEND" and torch.allclose(m.kd.data[..., 3], torch.tensor(0.8 * 128 / 255))
    assert torch.allclose(m.ks.data[..., 2], torch.tensor(1.0))
    assert torch.allclose(m.ks.data[..., 1], torch.tensor(0.45))
    assert torch.allclose(m.emissive.data, torch.tensor(2.0))
