"""``lookalike convert``: formats, the overwrite guard, the atlas option, errors."""

from __future__ import annotations

import numpy as np
import torch

from io_factory import two_material_asset
from lookalike import io
from lookalike.asset.skinning import trs_matrix
from lookalike.cli import main
from lookalike.io.transforms import matrix_to_trs


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
