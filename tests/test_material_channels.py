"""Emission and ambient occlusion end to end: glTF and OBJ in and out, material merging, the
bake, the latent (emission fitted, occlusion carried), and ``simplify`` and ``bake`` outputs."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
import torch

from io_factory import gradient_texture, uv_sphere
from log_capture import expect_warning
from lookalike import io
from lookalike.asset import Asset, Material, Mesh, Texture
from lookalike.fit.from_settings import loop_settings
from lookalike.settings import Config
from lookalike.settings import config_from_dict
from lookalike.fit.textured_mesh import TexturedMesh
from lookalike.init import decimate, unwrap
from lookalike.init.atlas import merge_materials
from lookalike.init.projection_bake import atlas_texels, bake
from lookalike.init.initial_guess import Ranges, initial_guess, resample, surface_mean_channel
from lookalike.io.image_files import encode_png
from lookalike.jobs.bake import bake_asset
from lookalike.jobs.simplify import simplify
from lookalike.shading import render
from lookalike.shading.light import PointLight
from lookalike.shading.view_sampling import random_views
from test_io_gltf import Doc, QUAD, _glb_json, assert_valid, quad_doc

PEAK = torch.tensor([3.0, 1.5, 0.25])
"""Emission of the glowing patch: above 1, so KHR_materials_emissive_strength is needed."""


def glow_texture(size: int = 32) -> torch.Tensor:
    """``[size, size, 3]`` black with a glowing rectangle of ``PEAK`` (rows 10..19, cols 4..11 of 32:
    on ``uv_sphere`` a patch south of the equator's northern band, 45-135 degrees east)."""
    data = torch.zeros(size, size, 3)
    s = size / 32
    data[int(10 * s):int(20 * s), int(4 * s):int(12 * s)] = PEAK
    return data


def occlusion_texture(size: int = 32) -> torch.Tensor:
    """``[size, size, 1]`` smooth occlusion in [0.3, 1]."""
    return 0.65 + 0.35 * (2 * gradient_texture(size, 1, seed=7) - 1) / 0.8


def glowing_sphere(n_lat: int = 16, n_lon: int = 32) -> Asset:
    """A UV sphere with a textured base colour, a glowing patch and an occlusion map."""
    material = Material(
        name="glow", kd=Texture(torch.cat([gradient_texture(32, 3, 3), torch.ones(32, 32, 1)], -1)),
        ks=Texture(torch.cat([torch.zeros(32, 32, 1), gradient_texture(32, 2, 4)], -1)),
        emissive=Texture(glow_texture()), occlusion=Texture(occlusion_texture()))
    return Asset(mesh=uv_sphere(n_lat, n_lon), materials=[material])


DARK = PointLight(position=torch.zeros(1, 3), intensity=torch.zeros(1, 3))


def pictures(asset: Asset, channel: str, views: int = 6, resolution: int = 64) -> torch.Tensor:
    """``[B, H, W, 3]`` renders in the dark, so that only emission shows: of ``channel``
    (``"emissive"``, or ``"occlusion"`` shown as grey emission, 1 where a material has none)."""
    materials = []
    for m in asset.materials:
        texture = getattr(m, channel)
        if channel == "occlusion":  # a material without an occlusion map is unoccluded
            texture = (Texture.constant([1.0, 1.0, 1.0]) if texture is None
                       else dataclasses.replace(texture, data=texture.data.expand(-1, -1, 3), mips=None))
        materials.append(dataclasses.replace(m, emissive=texture, occlusion=None))
    camera = random_views(torch.zeros(3), 1.0, views, np.random.default_rng(11))
    with torch.no_grad():
        image = render(Asset(mesh=asset.mesh, materials=materials), camera, DARK, resolution, spp=2)
    return image[..., :3]


def relative_difference(ours: torch.Tensor, theirs: torch.Tensor) -> float:
    """Mean absolute difference over the mean value of ``theirs``."""
    return float((ours - theirs).abs().mean() / theirs.abs().mean())


# ----------------------------------------------------------------------------------------------
# Files.

def test_gltf_reads_occlusion_red_channel_with_its_own_uv_set_and_strength(tmp_path):
    doc, prim = quad_doc()
    prim["attributes"]["TEXCOORD_0"] = doc.accessor(np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32))
    prim["attributes"]["TEXCOORD_1"] = doc.accessor(np.array([[1, 1], [0, 1], [0, 0], [1, 0]], np.float32))
    prim["material"] = 0
    doc.mesh_node([prim])
    orm = np.zeros((2, 2, 3), np.float32)
    orm[..., 0] = [[0.2, 0.4], [0.6, 1.0]]
    orm[..., 1:] = 0.9  # G and B are roughness and metalness, not occlusion
    (tmp_path / "orm.png").write_bytes(encode_png(orm))
    doc.json["images"] = [{"uri": "orm.png"}]
    doc.json["textures"] = [{"source": 0}]
    doc.json["materials"] = [{"occlusionTexture": {"index": 0, "texCoord": 1, "strength": 0.5}}]
    material = io.load(doc.write(tmp_path / "o.gltf")).materials[0]
    assert material.occlusion.uv_set == 1 and material.occlusion.data.shape == (2, 2, 1)
    red = torch.from_numpy(np.round(orm[..., :1] * 255) / 255)
    assert torch.allclose(material.occlusion.data, 1 + 0.5 * (red - 1), atol=1e-6)
    assert material.emissive is None
    doc.json["materials"] = [{}]
    assert io.load(doc.write(tmp_path / "none.gltf")).materials[0].occlusion is None


def test_glb_round_trip_keeps_emission_above_one_and_occlusion_packed_in_orm(tmp_path):
    asset = glowing_sphere()
    io.save(asset, tmp_path / "glow.glb")
    gltf = json.loads(_glb_json(tmp_path / "glow.glb"))
    written = gltf["materials"][0]
    assert written["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"] == pytest.approx(3.0)
    assert "KHR_materials_emissive_strength" in gltf["extensionsUsed"]
    # same size, UV set and wrap as the metallic-roughness texture: one ORM image
    assert written["occlusionTexture"]["index"] == written["pbrMetallicRoughness"]["metallicRoughnessTexture"]["index"]
    back = io.load(tmp_path / "glow.glb").materials[0]
    original = asset.materials[0]
    # 8-bit sRGB of emission / 3: a level is at most ~1.3 % of the value at the top
    assert torch.allclose(back.emissive.data, original.emissive.data, rtol=0.02, atol=1e-3)
    assert float(back.emissive.data.max()) == pytest.approx(3.0, rel=1e-3)
    assert torch.allclose(back.occlusion.data, original.occlusion.data, atol=1 / 255 + 1e-6)  # 8 bits, dithered
    assert torch.allclose(back.ks.data, original.ks.data, atol=1 / 255 + 1e-6)  # ORM's G and B untouched
    assert_valid(tmp_path / "glow.glb")


def test_occlusion_gets_an_image_of_its_own_where_it_cannot_share_the_orm_image(tmp_path):
    asset = glowing_sphere()
    m = asset.materials[0]
    asset.materials[0] = dataclasses.replace(m, ks=Texture.constant([0.0, 0.5, 0.0]),
                                             occlusion=Texture(occlusion_texture(16)))
    io.save(asset, tmp_path / "own.glb")
    written = json.loads(_glb_json(tmp_path / "own.glb"))["materials"][0]
    assert "metallicRoughnessTexture" not in written["pbrMetallicRoughness"] and "occlusionTexture" in written
    back = io.load(tmp_path / "own.glb").materials[0]
    assert torch.allclose(back.occlusion.data, occlusion_texture(16), atol=1 / 255 + 1e-6)  # 8 bits, dithered
    assert_valid(tmp_path / "own.glb")
    asset.materials[0] = dataclasses.replace(m, occlusion=Texture.constant([1.0]))  # no occlusion at all
    io.save(asset, tmp_path / "none.glb")
    assert "occlusionTexture" not in json.loads(_glb_json(tmp_path / "none.glb"))["materials"][0]


def test_obj_keeps_emission_above_one_and_drops_occlusion_with_a_warning(tmp_path, caplog):
    asset = glowing_sphere()
    with expect_warning(caplog, "occlusion dropped"):
        io.save(asset, tmp_path / "glow.obj")
    back = io.load(tmp_path / "glow.obj").materials[0]
    assert back.occlusion is None
    assert torch.allclose(back.emissive.data, asset.materials[0].emissive.data, rtol=0.02, atol=1e-3)


# ----------------------------------------------------------------------------------------------
# Initial guess: material merging and the bake.

def test_merged_materials_keep_emission_and_occlusion():
    asset = glowing_sphere(8, 16)
    mesh = asset.mesh
    mesh.t_mat_idx = (mesh.v_pos[mesh.t_pos_idx].mean(1)[:, 2] < 0).to(torch.int64)
    plain = Material(name="plain", kd=Texture.constant([0.5, 0.5, 0.5, 1.0]))
    asset = Asset(mesh=mesh, materials=[asset.materials[0], plain])
    merged = merge_materials(asset, size=128, padding=2)
    assert len(merged.materials) == 1
    ours, theirs = pictures(merged, "emissive"), pictures(asset, "emissive")
    assert relative_difference(ours, theirs) < 0.15
    ours, theirs = pictures(merged, "occlusion"), pictures(asset, "occlusion")
    assert relative_difference(ours, theirs) < 0.03  # the plain half is unoccluded: 1


def test_bake_copies_emission_and_occlusion():
    reference = glowing_sphere()
    low = unwrap(Mesh(v_pos=reference.mesh.v_pos, t_pos_idx=reference.mesh.t_pos_idx), texture_size=128)
    baked = bake(reference, low, texture_size=128).material
    assert baked.emissive.channels == 3 and baked.occlusion.channels == 1
    texels = atlas_texels(low, 128)
    values = baked.occlusion.data.numpy()[texels.rows, texels.cols]
    assert 0.25 < values.min() and values.max() <= 1.0 and values.std() > 0.05
    result = Asset(mesh=low, materials=[baked])
    assert relative_difference(pictures(result, "emissive"), pictures(reference, "emissive")) < 0.15
    assert relative_difference(pictures(result, "occlusion"), pictures(reference, "occlusion")) < 0.03


@pytest.mark.parametrize("init", ["source", "average", "random"])
def test_every_texture_start_carries_emission_and_occlusion(init):
    asset = glowing_sphere()
    low = decimate(asset.mesh, 300)
    start = initial_guess(asset, low, init, 64, Ranges(), np.random.default_rng(0)).start.materials[0]
    assert start.emissive.data.shape == (64, 64, 3) and start.occlusion.channels == 1
    glow, occlusion = asset.materials[0].emissive.data, asset.materials[0].occlusion.data
    if init == "source":  # the input's own maps, resampled
        assert relative_difference(start.emissive.data, resample(glow, 64)) < 1e-6
        assert torch.allclose(start.occlusion.data, resample(occlusion, 64))
    else:
        assert 0 < float(start.occlusion.data.mean()) < 1 and start.occlusion.data.numel() == 1
    if init == "average":
        assert torch.allclose(start.emissive.data[0, 0], surface_mean_channel(asset, "emissive", 3, (0, 0, 0)))
    if init == "random":
        assert float(start.emissive.data.min()) >= 0 and 1.0 < float(start.emissive.data[..., 0].max()) <= 3.0


# ----------------------------------------------------------------------------------------------
# The latent.

def _latent(asset: Asset) -> TexturedMesh:
    return TexturedMesh.from_asset(asset, torch.zeros(3), 1.0, Config().clamp, msaa=1, train_alpha=False)


def test_the_latent_fits_emission_in_its_own_group_and_carries_occlusion():
    start = glowing_sphere(8, 16)
    start.materials[0].emissive = Texture(glow_texture() * 0.5)  # dimmer than the target
    target = glowing_sphere(8, 16)
    latent = _latent(start)
    groups = latent.parameter_groups()
    assert set(groups) == {"positions", "textures", "emissive"}
    assert {id(p) for p in groups["emissive"]}.isdisjoint(id(p) for p in groups["textures"])
    assert float(latent.emission().detach().max()) == pytest.approx(1.5)
    assert "emissive" in loop_settings(Config(), outline=True).learning_rates

    camera = random_views(torch.zeros(3), 1.0, 4, np.random.default_rng(3))
    with torch.no_grad():
        wanted = render(target, camera, DARK, 48)
    optimizer = torch.optim.Adam(groups["emissive"], lr=0.05)
    losses = []
    for _ in range(30):
        optimizer.zero_grad()
        loss = (latent.render(camera, DARK, 48) - wanted).abs().mean()
        loss.backward()
        if not losses:
            gradient = torch.cat([p.grad.reshape(-1) for p in groups["emissive"]])
            assert gradient.abs().max() > 0
            assert all(p.grad is None or not p.grad.any() for p in groups["textures"])  # dark: no light to shade
        optimizer.step()
        latent.clamp_()
        losses.append(float(loss.detach()))
    assert losses[-1] < 0.5 * losses[0]
    emission = latent.emission().detach()
    assert float(emission.min()) >= 0 and float(emission.max()) > 1.5  # above 1, and brighter than the start

    model = latent.export()
    assert torch.equal(model.materials[0].occlusion.data, start.materials[0].occlusion.data)
    again = _latent(start)
    again.load_state_dict(latent.state_dict())
    assert torch.equal(again.emission(), latent.emission())


def test_a_latent_without_emission_has_no_emissive_group():
    asset = glowing_sphere(8, 16)
    asset.materials[0].emissive = None
    asset.materials[0].occlusion = None
    latent = _latent(asset)
    assert set(latent.parameter_groups()) == {"positions", "textures"}
    model = latent.export().materials[0]
    assert model.emissive is None and model.occlusion is None


# ----------------------------------------------------------------------------------------------
# The jobs.

TINY = {"views": {"pool_size": 6, "refresh_every": 2, "heldout": 2, "validation": 0, "batch_size": 1},
        "render": {"resolution": 64}, "latent": {"texture_size": 128}, "optim": {"checkpoint_seconds": 1e9}}


@pytest.mark.parametrize("job", ["simplify", "bake"])
def test_simplify_and_bake_write_the_inputs_emission_and_occlusion(tmp_path, job):
    asset = glowing_sphere()
    source = tmp_path / "glow.glb"
    io.save(asset, source)
    asset = io.load(source)  # what the job reads
    if job == "simplify":
        result = simplify(source, tmp_path / "out", triangles=300, iterations=4, config=config_from_dict(TINY),
                          progress=False)
    else:
        result = bake_asset(source, tmp_path / "out", triangles=300, texture_size=128)
    model = io.load(result.model)
    assert model.mesh.num_triangles == 300
    material = model.materials[0]
    assert material.emissive is not None and material.occlusion is not None
    ours, theirs = pictures(model, "emissive"), pictures(asset, "emissive")
    assert relative_difference(ours, theirs) < 0.15  # measured 0.05 (simplify), 0.03 (bake)
    glowing = theirs.amax(dim=-1) > 1.0
    brightness = [float(image.amax(dim=-1)[glowing].mean()) for image in (ours, theirs)]
    assert glowing.sum() > 50 and brightness[0] > 0.8 * brightness[1]  # the glowing patch stays bright
    assert relative_difference(pictures(model, "occlusion"), pictures(asset, "occlusion")) < 0.04  # measured 0.02
    written = json.loads(_glb_json(result.model))
    assert "KHR_materials_emissive_strength" in written["extensionsUsed"]
    assert "occlusionTexture" in written["materials"][0]
    assert_valid(result.model)
