"""PLY reading (ASCII and binary, via plyfile): faces, vertex colours, UVs, errors."""

from __future__ import annotations

import numpy as np
import plyfile
import pytest
import torch

from lookalike import io
from lookalike.errors import AssetError


def write_ply(path, text: bool, faces, colours=True, positions=None):
    positions = np.array([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0)]) if positions is None else positions
    fields = [("x", "f4"), ("y", "f4"), ("z", "f4")]
    if colours:
        fields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    vertex = np.zeros(len(positions), dtype=fields)
    vertex["x"], vertex["y"], vertex["z"] = positions.T
    if colours:
        vertex["red"] = [255, 0, 0, 128, 0]
        vertex["blue"] = [0, 0, 255, 0, 0]
    face = np.empty(len(faces), dtype=[("vertex_indices", "O")])
    face["vertex_indices"] = [np.array(f, np.int32) for f in faces]
    plyfile.PlyData([plyfile.PlyElement.describe(vertex, "vertex"), plyfile.PlyElement.describe(face, "face")],
                    text=text).write(str(path))
    return path


@pytest.mark.parametrize("text", [True, False], ids=["ascii", "binary"])
def test_reads_faces_and_vertex_colours(tmp_path, text):
    asset = io.load(write_ply(tmp_path / "a.ply", text, [[0, 1, 2, 3], [1, 4, 2]]))
    mesh = asset.mesh
    assert mesh.t_pos_idx.tolist() == [[0, 1, 2], [0, 2, 3], [1, 4, 2]]
    assert torch.allclose(mesh.v_color[0], torch.tensor([1.0, 0, 0, 1]))
    assert torch.allclose(mesh.v_color[3, 0], torch.tensor(((128 / 255 + 0.055) / 1.055) ** 2.4), atol=1e-6)
    assert [m.name for m in asset.materials] == ["default"]


def test_bad_ply_inputs(tmp_path):
    with pytest.raises(AssetError, match="out of range"):
        io.load(write_ply(tmp_path / "r.ply", True, [[0, 1, 9]]))
    with pytest.raises(AssetError, match="empty"):
        io.load(write_ply(tmp_path / "e.ply", True, []))
    nan = np.array([(0, 0, 0), (1, 0, np.nan), (1, 1, 0), (0, 1, 0), (2, 0, 0)])
    with pytest.raises(AssetError, match="NaN"):
        io.load(write_ply(tmp_path / "n.ply", False, [[0, 1, 2]], positions=nan))
    header = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nend_header\n"
    (tmp_path / "g.ply").write_bytes(header)
    with pytest.raises(AssetError, match="g.ply"):
        io.load(tmp_path / "g.ply")
