"""MikkTSpace: our vectorised implementation against the reference (npm ``mikktspace``, a WASM
build of the reference C algorithm), and normal maps surviving the conversion to and from it."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest
import torch

from io_factory import box, bumpy_normal_map, mirrored_plane, npm_package, uv_sphere
from lookalike.asset import Texture
from lookalike.asset.frames import our_corner_frame
from lookalike.asset.normals import crease_normal_index
from lookalike.io.mikktspace import mikktspace_tangents
from lookalike.io.normal_frames import reexpress_normal_map, reexpress_normal_map_python

pytestmark = pytest.mark.timeout(120)
"""Each test's limit, far above its second or so (the npm package's first install included): node
never holds up the suite."""

SCRIPT = Path(__file__).with_name("mikktspace_oracle.js")


def reference_tangents(positions, normals, uvs) -> np.ndarray:
    """``[T, 3, 4]`` tangents from the npm reference, with w converted to glTF's convention (the
    reference is given glTF UVs, so its sign is negated; see ``lookalike.io.mikktspace``)."""
    modules = npm_package("mikktspace")
    payload = json.dumps({"position": positions.reshape(-1).tolist(), "normal": normals.reshape(-1).tolist(),
                          "texcoord": uvs.reshape(-1).tolist()})
    result = subprocess.run(["node", str(SCRIPT), str(modules)], input=payload, capture_output=True, text=True,
                            timeout=120, check=True)
    out = np.array(json.loads(result.stdout), dtype=np.float32).reshape(-1, 3, 4)
    out[..., 3] *= -1
    return out


def corner_arrays(mesh):
    v_nrm, t_nrm_idx = mesh.normals()
    return (mesh.v_pos.float()[mesh.t_pos_idx].numpy(), v_nrm.float()[t_nrm_idx].numpy(),
            mesh.uv[0][0].float()[mesh.uv[0][1]].numpy())


def bumpy(mesh, amount=0.05):
    """The mesh with positions pushed along a smooth pattern (unequal triangles, curved)."""
    p = mesh.v_pos
    offset = amount * torch.sin(5 * p[:, :1] + 3 * p[:, 1:2] + 2 * p[:, 2:])
    mesh.v_pos = p + offset * torch.tensor([0.3, 1.0, 0.6])
    return mesh


def creased(mesh):
    """The mesh with its normals split at creases (``crease_normal_index``)."""
    mesh.t_nrm_idx = crease_normal_index(mesh.v_pos, mesh.t_pos_idx)
    return mesh


def with_degenerate_triangles(mesh):
    """The mesh with zero-UV-area triangles (all corners, or two corners, on one UV) and a
    triangle with two equal positions."""
    v_tex, t_tex_idx = mesh.uv[0]
    t_tex_idx = t_tex_idx.clone()
    t_tex_idx[5] = t_tex_idx[5, 0]
    t_tex_idx[40, 1] = t_tex_idx[40, 0]
    t_pos_idx = mesh.t_pos_idx.clone()
    t_pos_idx[60, 1] = t_pos_idx[60, 0]
    t_tex_idx[60, 1] = t_tex_idx[60, 0]
    mesh.uv = [(v_tex, t_tex_idx)]
    mesh.t_pos_idx = t_pos_idx
    return mesh


@pytest.mark.parametrize("make", [lambda: uv_sphere(10, 20), lambda: bumpy(uv_sphere(7, 11)),
                                  lambda: with_degenerate_triangles(bumpy(uv_sphere(7, 11))),
                                  lambda: bumpy(mirrored_plane(5), 0.2), lambda: bumpy(mirrored_plane(6), 0.2),
                                  lambda: bumpy(creased(box(4, flat_normals=False)), 0.1)],
                         ids=["sphere", "bumpy-sphere-with-seam", "degenerate", "mirrored-uvs",
                              "mirror-inside-triangles", "hard-edged-box"])
def test_matches_reference_implementation(make):
    positions, normals, uvs = corner_arrays(make())
    ours = mikktspace_tangents(positions, normals, uvs)
    reference = reference_tangents(positions, normals, uvs)
    assert np.array_equal(ours[..., 3], reference[..., 3])
    assert np.abs(ours[..., :3] - reference[..., :3]).max() < 1e-4


def test_mirrored_uvs_split_groups_on_the_mirror_line():
    positions, normals, uvs = corner_arrays(mirrored_plane(5))
    t = mikktspace_tangents(positions, normals, uvs)
    centre_x = positions.mean(1)[:, 0]
    assert (t[centre_x < 0.5][..., 3] == 1).all() and (t[centre_x > 0.5][..., 3] == -1).all()
    assert np.allclose(t[centre_x > 0.5][..., :3], [-1, 0, 0], atol=1e-6)


def test_normal_map_round_trip_through_mikktspace_keeps_shading_normals():
    """A map authored in MikkTSpace, imported into our frame and exported back, decodes to the
    same shading normals (texels inside the triangles' UV footprint)."""
    mesh = bumpy(uv_sphere(10, 20), 0.1)
    positions, normals, uvs = corner_arrays(mesh)
    mikk = (normals.astype(np.float64), mikktspace_tangents(positions, normals, uvs).astype(np.float64))
    ours = our_corner_frame(mesh, 0)
    authored = bumpy_normal_map(64).numpy()
    imported = reexpress_normal_map(authored, uvs, mikk, ours)
    exported = reexpress_normal_map(imported, uvs, ours, mikk)
    assert np.abs(imported - authored).max() > 1e-3  # the frames really differ
    assert np.abs(exported - authored).max() < 1e-4


def test_flat_map_stays_flat_where_frames_share_the_normal():
    mesh = uv_sphere(8, 16)
    positions, normals, uvs = corner_arrays(mesh)
    mikk = (normals.astype(np.float64), mikktspace_tangents(positions, normals, uvs).astype(np.float64))
    flat = np.tile(np.array([0.0, 0.0, 1.0], np.float32), (32, 32, 1))
    converted = reexpress_normal_map(flat, uvs, mikk, our_corner_frame(mesh, 0))
    assert np.allclose(converted, flat, atol=1e-5)
    assert isinstance(Texture(torch.from_numpy(converted)), Texture)


def test_compiled_conversion_matches_numpy_twin():
    """Kernel vs plain NumPy on a sphere (UV triangles do not overlap) with tiling UVs shifted
    past 1 (wrapping), random frames on both sides."""
    mesh = bumpy(uv_sphere(6, 10), 0.1)
    positions, normals, uvs = corner_arrays(mesh)
    uvs = uvs * np.float32(1.5) + np.float32(0.25)
    g = np.random.default_rng(0)
    handedness = np.sign(g.normal(size=(*normals.shape[:2], 1)))
    random_tangents = np.concatenate([g.normal(size=normals.shape), handedness], -1)
    src = (normals.astype(np.float64), random_tangents)
    dst = our_corner_frame(mesh, 0)
    pixels = bumpy_normal_map(48).numpy()
    fast = reexpress_normal_map(pixels, uvs, src, dst, gutter=2)
    slow = reexpress_normal_map_python(pixels, uvs, src, dst, gutter=2)
    assert np.abs(fast - pixels).max() > 0.1
    assert np.abs(fast - slow).max() < 1e-5


def test_authored_gltf_tangents_agree_with_ours(shared_assets):
    """FlightHelmet ships MikkTSpace TANGENTs (glTF convention): ours agree, handedness included."""
    from lookalike.io.gltf_data import GltfData, parse_gltf

    path = shared_assets / "flight-helmet" / "FlightHelmet.gltf"
    data = GltfData(parse_gltf(path), path)
    prim = data.gltf.meshes[0].primitives[0]
    attrs = vars(prim.attributes)
    tri = data.accessor(prim.indices).reshape(-1, 3)
    corners = [data.accessor(attrs[k])[tri] for k in ("POSITION", "NORMAL", "TEXCOORD_0", "TANGENT")]
    ours = mikktspace_tangents(*corners[:3])
    assert np.array_equal(ours[..., 3], np.sign(corners[3][..., 3]))
    cosine = (ours[..., :3] * corners[3][..., :3]).sum(-1)
    assert np.median(cosine) > 0.9995 and (cosine > 0.99).mean() > 0.99  # the exporter's float noise
