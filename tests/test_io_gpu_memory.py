"""GPU memory of a written glTF: buffers as the accessors lay them out, textures with mips."""

from __future__ import annotations

import torch
from pygltflib import GLTF2

from lookalike import io
from lookalike.asset import Asset, Material, Mesh, Texture
from lookalike.io.gpu_memory import gpu_bytes


def test_gpu_memory_counts_every_vertex_buffer_once_and_each_texture_with_its_mips(tmp_path):
    v_pos = torch.tensor([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    faces = torch.tensor([[0, 1, 2], [0, 2, 3]])
    mesh = Mesh(v_pos=v_pos, t_pos_idx=faces, uv=[(v_pos[:, :2].clone(), faces.clone())],
                t_mat_idx=torch.zeros(2, dtype=torch.long))
    material = Material(kd=Texture(torch.rand(16, 32, 4)), ks=Texture(torch.rand(16, 32, 3)))
    io.save(Asset(mesh=mesh, materials=[material]), tmp_path / "quad.glb")
    memory = gpu_bytes(tmp_path / "quad.glb")
    gltf = GLTF2().load(str(tmp_path / "quad.glb"))
    image_views = {image.bufferView for image in gltf.images}
    assert len(gltf.images) >= 2
    assert memory["textures"] == len(gltf.images) * round(16 * 32 * 4 * 4 / 3)
    assert memory["buffers"] == sum(view.byteLength for i, view in enumerate(gltf.bufferViews) if i not in image_views)
    assert memory["buffers"] >= 4 * 12 + 6 * 2 and memory["total"] == memory["buffers"] + memory["textures"]
