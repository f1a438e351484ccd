"""``lookalike convert``: formats, the overwrite guard, the atlas option, errors, and the input's
normals (hard edges) kept."""

from __future__ import annotations

import dataclasses

import numpy as np
import torch

from io_factory import box, bumpy_normal_map, gradient_texture, two_material_asset
from lookalike import io
from lookalike.asset import Asset, Material, Mesh, Texture
from lookalike.asset.skinning import trs_matrix
from lookalike.cli import main
from lookalike.io.transforms import matrix_to_trs
from lookalike.report.metrics import psnr
from lookalike.shading.pipeline import render
from lookalike.shading.view_sampling import random_lights, random_views


def test_convert_obj_to_glb_and_back(tmp_path, capsys):
    asset = two_material_asset(normal_map=False)
    asset.materials[0].ks.data[..., 0] = 0.0
    io.save(asset, tmp_path / "in.glb")
    assert main(["convert", str(tmp_path / "in.glb"), str(tmp_path / "out.obj")]) == 0
    assert "in.glb -> " in capsys.readouterr().out
    back = io.load(tmp_path / "out.obj")
    assert back.mesh.num_triangles == asset.mesh.num_triangles and len(back.materials) == 2


def test_convert_refuses_to_overwrite_without_force(tmp_path, capsys):
    io.save(two_material_asset(), tmp_path / "in.glb")
    (tmp_path / "out.glb").write_bytes(b"keep me")
    assert main(["convert", str(tmp_path / "in.glb"), str(tmp_path / "out.glb")]) == 2
    assert "--force" in capsys.readouterr().err and (tmp_path / "out.glb").read_bytes() == b"keep me"
    assert main(["convert", str(tmp_path / "in.glb"), str(tmp_path / "out.glb"), "--force"]) == 0
    assert io.load(tmp_path / "out.glb").mesh.num_triangles == two_material_asset().mesh.num_triangles


def test_convert_with_atlas_gives_one_material(tmp_path):
    io.save(two_material_asset(), tmp_path / "in.glb")
    assert main(["convert", str(tmp_path / "in.glb"), str(tmp_path / "one.glb"), "--atlas", "64"]) == 0
    back = io.load(tmp_path / "one.glb")
    assert len(back.materials) == 1 and back.materials[0].kd.data.shape == (64, 64, 4)


def test_convert_errors_name_the_problem(tmp_path, capsys):
    assert main(["convert", str(tmp_path / "absent.obj"), str(tmp_path / "o.glb")]) == 2
    assert "absent.obj: no such file" in capsys.readouterr().err
    io.save(two_material_asset(), tmp_path / "in.glb")
    assert main(["convert", str(tmp_path / "in.glb"), str(tmp_path / "o.fbx")]) == 2
    assert "'.fbx'" in capsys.readouterr().err


def test_matrix_to_trs_inverts_trs_matrix():
    rotation = torch.tensor([0.1, -0.5, 0.3, 0.8], dtype=torch.float64)
    rotation /= rotation.norm()
    for scale in ([2.0, 0.5, 1.5], [-1.0, 2.0, 3.0]):
        translation = torch.tensor([1.0, 2, 3], dtype=torch.float64)
        m = trs_matrix(translation, rotation, torch.tensor(scale, dtype=torch.float64))
        t, r, s = matrix_to_trs(m.numpy())
        back = trs_matrix(*(torch.from_numpy(np.asarray(v, np.float64)) for v in (t, r, s)))
        assert torch.allclose(back, m, atol=1e-12)


def normals_per_position(mesh: Mesh) -> torch.Tensor:
    """``[V]`` int64 number of distinct shading normals (slots) at each position."""
    _, t_nrm_idx = mesh.normals()
    pairs = torch.stack([mesh.t_pos_idx.reshape(-1), t_nrm_idx.reshape(-1)], 1).unique(dim=0)
    return torch.bincount(pairs[:, 0], minlength=mesh.num_vertices)


def smooth(asset: Asset) -> Asset:
    """``asset`` with its normals replaced by smooth ones computed from positions."""
    return dataclasses.replace(asset, mesh=dataclasses.replace(asset.mesh, v_nrm=None, t_nrm_idx=None))


def views_psnr(reference: Asset, *tests: Asset) -> list[float]:
    """PSNR (dB) of each of ``tests`` against ``reference``, rendered by our pipeline from four
    random views with point lights (three depth layers, for blending)."""
    centre, radius = reference.mesh.bounding_sphere()
    rng = np.random.default_rng(0)
    camera = random_views(centre, radius, 4, rng)
    light = random_lights(camera, centre, rng)
    with torch.no_grad():
        images = [render(a, camera, light, 96, spp=2, layers=3) for a in (reference, *tests)]
    return [psnr(images[0], image) for image in images[1:]]


def test_convert_keeps_the_hard_edges_of_a_cube(tmp_path):
    """A normal-mapped cube with flat faces (three normals at each corner, two along each edge)
    keeps them through .glb and .obj (and a merged atlas), and renders as the input does; with
    smooth normals it would not."""
    material = Material(name="painted", kd=Texture(torch.cat([gradient_texture(32, 3), torch.ones(32, 32, 1)], -1)),
                        ks=Texture.constant([0.0, 0.4, 0.0]), normal=Texture(bumpy_normal_map(32)))
    io.save(Asset(mesh=box(3), materials=[material]), tmp_path / "in.glb")
    original = io.load(tmp_path / "in.glb")
    assert torch.bincount(normals_per_position(original.mesh)).tolist() == [0, 6, 12, 8]
    for name in ("out.glb", "out.obj"):
        assert main(["convert", str(tmp_path / "in.glb"), str(tmp_path / name)]) == 0
        converted = io.load(tmp_path / name)
        assert torch.equal(normals_per_position(converted.mesh), normals_per_position(original.mesh))
        same, rounded = views_psnr(original, converted, smooth(original))
        assert same >= 50 and rounded < same - 15, (name, same, rounded)
    assert main(["convert", str(tmp_path / "in.glb"), str(tmp_path / "atlas.glb"), "--atlas", "64"]) == 0
    assert torch.equal(normals_per_position(io.load(tmp_path / "atlas.glb").mesh), normals_per_position(original.mesh))


def test_convert_keeps_the_normals_of_alpha_blend_mode_test(shared_assets, tmp_path):
    """The Khronos AlphaBlendModeTest (flat-faced boxes, up to five normals at a position) keeps
    its normals and its look; rendered with smooth normals it loses them."""
    source = shared_assets / "alpha-blend-mode-test" / "AlphaBlendModeTest.glb"
    assert main(["convert", str(source), str(tmp_path / "out.glb")]) == 0
    original, converted = io.load(source), io.load(tmp_path / "out.glb")
    counts = normals_per_position(original.mesh)
    assert counts.max() >= 3 and torch.equal(normals_per_position(converted.mesh), counts)
    same, rounded = views_psnr(original, converted, smooth(original))
    assert same >= 50 and rounded < 40, (same, rounded)
