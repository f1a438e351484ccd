"""write_lod_chain: levels of detail in one .glb, linked by the MSFT_lod extension."""

from __future__ import annotations

import pytest
import torch
from io_factory import two_material_asset, uv_sphere
from mesh_factory import icosphere
from pygltflib import GLTF2
from test_io_gltf import assert_valid

from lookalike import io
from lookalike.asset import Asset, Material, Node, Skin, Texture
from lookalike.io.gltf_lod_chain import write_lod_chain


def _sphere_chain() -> list[Asset]:
    """Three icospheres, finest first, sharing one constant material."""
    stone = Material(name="stone", kd=Texture.constant([0.5, 0.45, 0.4, 1.0]), ks=Texture.constant([0.0, 0.6, 0.0]))
    return [Asset(mesh=icosphere(s), materials=[stone]) for s in (3, 2, 1)]


def _triangles(gltf: GLTF2, node: int) -> int:
    mesh = gltf.meshes[gltf.nodes[node].mesh]
    return sum(gltf.accessors[p.indices].count for p in mesh.primitives) // 3


def test_chain_loads_as_level_0_and_links_the_lower_levels(tmp_path):
    levels = _sphere_chain()
    path = write_lod_chain(levels, tmp_path / "rock.glb", "rock", [0.5, 0.2, 0.01])
    assert path == tmp_path / "rock.glb"
    assert io.load(path).mesh.num_triangles == levels[0].mesh.num_triangles == 1280
    gltf = GLTF2().load(str(path))
    assert gltf.scenes[gltf.scene].nodes == [0] and len(gltf.nodes) == 3
    top = gltf.nodes[0]
    assert top.name == "rock_LOD0" and _triangles(gltf, 0) == 1280
    ids = top.extensions["MSFT_lod"]["ids"]
    assert [gltf.nodes[i].name for i in ids] == ["rock_LOD1", "rock_LOD2"]
    assert [_triangles(gltf, i) for i in ids] == [level.mesh.num_triangles for level in levels[1:]] == [320, 80]
    assert all(not gltf.nodes[i].extensions for i in ids)
    coverage = top.extras["MSFT_screencoverage"]
    assert coverage == [0.5, 0.2, 0.01] and len(coverage) == len(ids) + 1
    assert gltf.extensionsUsed == ["MSFT_lod"] and not gltf.extensionsRequired
    assert_valid(path)


def test_textured_levels_keep_their_materials_and_share_their_textures(tmp_path):
    fine = two_material_asset(normal_map=True)
    mesh = uv_sphere(4, 8)
    mesh.t_mat_idx = (mesh.v_pos[mesh.t_pos_idx].mean(1)[:, 2] < 0).to(torch.int64)
    coarse = Asset(mesh=mesh, materials=fine.materials)
    path = write_lod_chain([fine, coarse], tmp_path / "ball.glb", "ball", [0.3, 0.05])
    gltf = GLTF2().load(str(path))
    meshes = [gltf.meshes[node.mesh] for node in gltf.nodes]
    assert [m.name for m in meshes] == ["ball_LOD0", "ball_LOD1"]
    assert {p.material for p in meshes[0].primitives}.isdisjoint(p.material for p in meshes[1].primitives)
    materials = [[gltf.materials[p.material] for p in m.primitives] for m in meshes]
    assert [[m.name for m in level] for level in materials] == [["textured", "blended"]] * 2
    fine_textured, coarse_textured = materials[0][0], materials[1][0]
    # The base colour image is one texture of both levels; each level's normal map is its own
    # (converted to the MikkTSpace frame of that level's mesh).
    assert (fine_textured.pbrMetallicRoughness.baseColorTexture.index
            == coarse_textured.pbrMetallicRoughness.baseColorTexture.index)
    assert fine_textured.normalTexture.index != coarse_textured.normalTexture.index
    back = io.load(path)  # level 0 alone (the reader also lists the lower levels' materials, unused)
    assert back.mesh.num_triangles == fine.mesh.num_triangles
    assert [back.materials[i].name for i in back.mesh.t_mat_idx.unique().tolist()] == ["textured", "blended"]
    assert_valid(path)


def test_one_level_is_a_plain_file(tmp_path):
    path = write_lod_chain(_sphere_chain()[:1], tmp_path / "one.glb", "one", [0.1])
    gltf = GLTF2().load(str(path))
    assert [n.name for n in gltf.nodes] == ["one_LOD0"] and not gltf.nodes[0].extensions
    assert gltf.nodes[0].extras["MSFT_screencoverage"] == [0.1] and not gltf.extensionsUsed
    assert_valid(path)


def test_a_skinned_level_is_refused(tmp_path):
    levels = _sphere_chain()
    mesh = levels[1].mesh
    mesh.v_joints = torch.zeros(mesh.num_vertices, 4, dtype=torch.int64)
    mesh.v_weights = torch.tensor([[1.0, 0, 0, 0]]).repeat(mesh.num_vertices, 1)
    root = Node("root", -1, torch.zeros(3), torch.tensor([0.0, 0, 0, 1]), torch.ones(3))
    levels[1].skin = Skin(nodes=[root], joints=torch.tensor([0]), inverse_bind=torch.eye(4)[None],
                          mesh_to_world=torch.eye(4))
    with pytest.raises(ValueError, match="a level has a skin"):
        write_lod_chain(levels, tmp_path / "skinned.glb", "skinned", [0.5, 0.2, 0.01])


@pytest.mark.parametrize("count, coverages, message", [
    (0, [], "at least one level"),
    (3, [0.5, 0.1], "3 levels need 3 screen coverages"),
    (2, [0.5, 0.2, 0.1], "2 levels need 2 screen coverages"),
    (2, [0.2, 0.5], "descend strictly"),
    (2, [0.5, 0.5], "descend strictly"),
    (2, [1.5, 0.5], "within \\[0, 1\\]"),
])
def test_bad_chains_are_refused(tmp_path, count, coverages, message):
    with pytest.raises(ValueError, match=message):
        write_lod_chain(_sphere_chain()[:count], tmp_path / "bad.glb", "bad", coverages)
    assert not (tmp_path / "bad.glb").exists()
