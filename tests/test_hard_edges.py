"""Hard edges survive simplification: decimation splits its normals at creases, the bake decodes
in the split frames, the latent keeps the slots and recomputes the normals from its moving
positions, and the exported model carries them; a sphere stays smooth throughout. A model fitted
on smooth normals is written on crease normals, shading as it did."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from io_factory import box, bumpy_normal_map, covered_texels
from lookalike import io
from lookalike.asset import Asset, Material, Mesh, Texture
from lookalike.asset.normals import face_normals, safe_normalize
from lookalike.settings import ClampConfig
from lookalike.fit.textured_mesh import TexturedMesh
from lookalike.init import decimate
from lookalike.init.projection_bake import bake
from lookalike.init.initial_guess import Ranges, initial_guess, initial_guess_from_mesh, smooth_shaded
from lookalike.io.normal_frames import on_crease_normals
from mesh_factory import icosphere


def normals_per_position(mesh: Mesh) -> torch.Tensor:
    """``[V]`` int64 number of distinct shading normals (slots) at each position."""
    _, t_nrm_idx = mesh.normals()
    pairs = torch.stack([mesh.t_pos_idx.reshape(-1), t_nrm_idx.reshape(-1)], 1).unique(dim=0)
    return torch.bincount(pairs[:, 0], minlength=mesh.num_vertices)


def faces_met(mesh: Mesh) -> torch.Tensor:
    """``[V]`` int64 number of the cube's faces each position of a mesh on it lies on (3 at a
    corner, 2 on an edge, 1 inside a face)."""
    return (mesh.v_pos.abs() > 1 - 1e-4).sum(-1)


def grey(mesh: Mesh) -> Asset:
    return Asset(mesh=mesh, materials=[Material(kd=Texture.constant([0.5, 0.5, 0.5, 1.0]))])


def start_of(asset: Asset, low: Mesh, size: int = 32) -> Asset:
    """The start of an "average" initial guess on ``low`` (``size``-texel atlas)."""
    return initial_guess(asset, low, "average", size, Ranges(), np.random.default_rng(0)).start


def latent_of(asset: Asset, start: Asset) -> TexturedMesh:
    centre, radius = asset.mesh.bounding_sphere()
    return TexturedMesh.from_asset(start, centre, radius, ClampConfig(), msaa=1, train_alpha=False)


@pytest.fixture(scope="module")
def cube() -> tuple[Asset, Mesh]:
    """A finely tessellated cube without authored normals and its decimation to 12 triangles."""
    fine = box(6, flat_normals=False)
    return grey(fine), decimate(fine, 12)


def test_decimated_cube_splits_its_normals_at_the_edges_and_a_sphere_does_not(cube):
    _, low = cube
    assert low.v_nrm is None and torch.equal(normals_per_position(low), faces_met(low))
    sphere = decimate(icosphere(3), 200)
    assert (normals_per_position(sphere) == 1).all()


def test_bake_onto_the_decimated_cube_is_flat(cube):
    """The reference's flat faces seen in the split frames need no normal map at all."""
    asset, low = cube
    start = start_of(asset, low, 64)
    normal = bake(grey(box(4)), start.mesh, texture_size=64).material.normal.data
    inside = covered_texels(start.mesh, 0, 64, 64)
    assert normal[inside][:, 2].min() > 0.999


def test_latent_recomputes_split_normals_from_its_positions(cube):
    asset, low = cube
    latent = latent_of(asset, start_of(asset, low))
    assert torch.equal(normals_per_position(latent.as_asset().mesh), faces_met(low))
    with torch.no_grad():
        latent.v_pos.mul_(torch.tensor([1.5, 0.5, 1.0]))  # a box: its faces stay flat
    mesh = latent.as_asset().mesh
    v_nrm, t_nrm_idx = mesh.normals()
    faces = safe_normalize(face_normals(mesh.v_pos, mesh.t_pos_idx))
    assert torch.allclose(v_nrm[t_nrm_idx], faces[:, None].expand(-1, 3, -1), atol=1e-5)
    v_nrm.pow(3).sum().backward()
    assert latent.v_pos.grad.abs().sum() > 0  # differentiable through the normals


def test_latent_normal_slots_survive_a_state_round_trip(cube):
    asset, low = cube
    start = start_of(asset, low)
    latent = latent_of(asset, start)
    smooth = latent_of(asset, dataclasses.replace(start, mesh=dataclasses.replace(start.mesh, t_nrm_idx=None)))
    assert not torch.equal(smooth.t_nrm_idx, latent.t_nrm_idx)
    smooth.load_state_dict(latent.state_dict())
    assert torch.equal(smooth.t_nrm_idx, latent.t_nrm_idx)


@pytest.mark.parametrize("shape", ["cube", "sphere"])
def test_exported_model_keeps_the_hard_edges(cube, tmp_path, shape):
    """The 12-triangle cube is written with three normals at each corner (24 normal vertices);
    a decimated sphere with one per position."""
    if shape == "cube":
        asset, low = cube
    else:
        asset = grey(icosphere(3))
        low = decimate(asset.mesh, 200)
    io.save(latent_of(asset, start_of(asset, low)).export(), tmp_path / "model.glb")
    written = io.load(tmp_path / "model.glb").mesh
    counts = normals_per_position(written)
    if shape == "cube":
        assert written.num_vertices == 8 and written.num_normals == 24 and (counts == 3).all()
    else:
        assert written.num_normals == written.num_vertices and (counts == 1).all()


def with_bumps(model: Asset) -> Asset:
    """``model`` with a bumpy normal map in place of its own."""
    material = model.materials[0]
    bumps = dataclasses.replace(material.normal, data=bumpy_normal_map(material.normal.data.shape[0]))
    return dataclasses.replace(model, materials=[dataclasses.replace(material, normal=bumps)])


def test_a_model_on_smooth_normals_is_written_on_crease_normals_shading_as_it_did(cube):
    """The 12-triangle cube shaded smooth (its corner normals lean 55 degrees from the faces)
    under a bumpy map: on crease normals, the map re-expressed, it draws the same picture; the
    map as it was on those normals draws another."""
    from lookalike.report.metrics import psnr
    from lookalike.shading.camera import Camera
    from lookalike.shading.light import PointLight
    from lookalike.shading.pipeline import render

    asset, low = cube
    smooth = with_bumps(smooth_shaded(asset, start_of(asset, low, 64), 64))
    assert (normals_per_position(smooth.mesh) == 1).all()
    written = on_crease_normals(smooth)
    assert torch.equal(normals_per_position(written.mesh), faces_met(low))
    eyes = torch.tensor([[3.0, 1.2, 0.8], [-1.0, 2.6, 1.9], [0.7, -1.5, -3.0]])
    cameras = Camera.looking_at(eyes, torch.zeros(3, 3), fovy=np.radians(45.0))
    light = PointLight(eyes * 1.5 + torch.tensor([1.0, 1.5, 0.0]), torch.full((3, 3), 20.0))
    picture = render(smooth, cameras, light, 96)
    unconverted = dataclasses.replace(written, materials=smooth.materials)
    assert psnr(picture, render(written, cameras, light, 96)) > 40.0
    assert psnr(picture, render(unconverted, cameras, light, 96)) < 30.0


def test_a_users_lod_on_its_own_smooth_normals_starts_drawing_what_it_draws(cube):
    """A user's LOD as Blender writes one: the cube shaded smooth, its normals authored in the
    file, a bumpy map made on them. The start offered on its own positions keeps the map,
    re-expressed onto crease normals, and draws what the LOD draws; the map read on those
    frames as it was draws another picture (the start was 15 dB off a user's LOD)."""
    from lookalike.report.metrics import psnr
    from lookalike.shading.camera import Camera
    from lookalike.shading.light import PointLight
    from lookalike.shading.pipeline import render

    asset, low = cube
    smooth = with_bumps(smooth_shaded(asset, start_of(asset, low, 64), 64))
    v_nrm, t_nrm_idx = smooth.mesh.normals()
    lod = dataclasses.replace(smooth, mesh=dataclasses.replace(smooth.mesh, v_nrm=v_nrm, t_nrm_idx=t_nrm_idx))
    guess = initial_guess_from_mesh(asset, lod, "lod.glb", 64)
    (label, given), = guess.alternatives
    assert label == "lod.glb on its own positions" and guess.baseline is lod
    assert guess.own_start() == "lod.glb fitted onto the input's surface"
    assert torch.equal(given.mesh.v_pos, lod.mesh.v_pos)
    assert torch.equal(normals_per_position(given.mesh), faces_met(low))
    assert torch.equal(guess.start.mesh.t_nrm_idx, given.mesh.t_nrm_idx)   # the fitted start keeps the slots too
    eyes = torch.tensor([[3.0, 1.2, 0.8], [-1.0, 2.6, 1.9], [0.7, -1.5, -3.0]])
    cameras = Camera.looking_at(eyes, torch.zeros(3, 3), fovy=np.radians(45.0))
    light = PointLight(eyes * 1.5 + torch.tensor([1.0, 1.5, 0.0]), torch.full((3, 3), 20.0))
    picture = render(lod, cameras, light, 96)
    assert psnr(picture, render(given, cameras, light, 96)) > 40.0
    assert psnr(picture, render(dataclasses.replace(given, materials=lod.materials), cameras, light, 96)) < 30.0


def test_a_model_already_on_crease_normals_is_written_as_it_is(cube):
    asset, low = cube
    start = with_bumps(start_of(asset, low))
    assert on_crease_normals(start) is start
