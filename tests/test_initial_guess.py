"""The initial guess: triangle targets, texture starts, the decimation baseline, and a user's
own low-poly mesh as the start (``--init-mesh``)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch
from mesh_factory import icosphere
from test_conform import surface_distances

import lookalike.init.initial_guess as initial_guess_module
from lookalike.asset import Asset, Material, Mesh, Texture
from lookalike.asset.normals import vertex_normals
from lookalike.errors import ConfigError
from lookalike.settings import ClampConfig
from lookalike.fit.textured_mesh import TexturedMesh
from lookalike.init import decimate, unwrap
from lookalike.init.conform import SETTLE_ROUNDS
from lookalike.init.transfer import transfer_attributes
from lookalike.init.initial_guess import (
    UV_CHECK_SIZE,
    UV_OVERLAP_LIMIT,
    Ranges,
    decimation_baseline,
    guarded_fit,
    initial_guess,
    initial_guess_from_mesh,
    resample,
    surface_mean_material,
    target_triangle_count,
    uses_alpha,
    uv_overlap,
)
from lookalike.jobs.demo import knot_mesh

CLAMP = ClampConfig()
RANGES = Ranges(kd=CLAMP.kd, ks=(CLAMP.gamma, CLAMP.roughness, CLAMP.metalness))


def painted_knot(materials: int = 1) -> Asset:
    mesh = knot_mesh(segments=60, sides=10)
    kd = torch.rand(16, 64, 4)
    kd[..., 3] = 1
    painted = [Material(name=f"m{k}", kd=Texture(kd * (k + 1) / materials), ks=Texture.constant([0.0, 0.5, 0.0]))
               for k in range(materials)]
    mesh.t_mat_idx = torch.arange(mesh.num_triangles) % materials
    return Asset(mesh=mesh, materials=painted)


def latent_of(asset: Asset, start: Asset) -> TexturedMesh:
    """The latent ``simplify`` builds from the initial guess ``start`` of ``asset``."""
    centre, radius = asset.mesh.bounding_sphere()
    return TexturedMesh.from_asset(start, centre, radius, CLAMP, msaa=1, train_alpha=uses_alpha(asset))


def start(asset: Asset, init: str, size: int = 32):
    decimated = decimate(asset.mesh, 300)
    guess = initial_guess(asset, decimated, init, size, RANGES, np.random.default_rng(0))
    assert (guess.baked is not None) == (init == "bake")
    return decimated, latent_of(asset, guess.start)


def test_source_init_reuses_the_inputs_uvs_and_textures():
    asset = painted_knot()
    decimated, latent = start(asset, "source")
    assert torch.equal(latent.v_tex, decimated.uv[0][0]) and torch.equal(latent.t_tex_idx, decimated.uv[0][1])
    assert torch.allclose(latent.kd(), resample(asset.materials[0].kd.data, 32)[..., :3].clamp(0, 1))
    assert torch.allclose(latent.ks()[..., 1], torch.full((32, 32), 0.5))
    assert torch.equal(latent.unit_normal().data, torch.tensor([0.0, 0.0, 1.0]).expand(32, 32, 3))


def test_several_materials_get_a_fresh_atlas_with_their_mean_colour():
    asset = painted_knot(materials=2)
    decimated, latent = start(asset, "source", size=128)
    assert not torch.equal(latent.t_tex_idx, decimated.uv[0][1])  # a new atlas from unwrap
    kd_mean, _ = surface_mean_material(asset)
    assert torch.allclose(latent.kd(), kd_mean[:3].expand(128, 128, 3))


def test_random_init_is_uniform_noise_within_the_clamp_ranges():
    _, latent = start(painted_knot(), "random", size=128)
    assert latent.kd().std() > 0.2 and latent.ks()[..., 1].min() >= 0.08


def test_mean_material_weights_materials_by_area():
    asset = painted_knot(materials=2)
    asset.materials = [dataclasses.replace(m, kd=Texture.constant([float(k), 0.0, 0.0, 1.0])) for k, m in enumerate(asset.materials)]
    kd, ks = surface_mean_material(asset)
    assert 0.3 < float(kd[0]) < 0.7 and float(kd[3]) == pytest.approx(1.0) and float(ks[1]) == pytest.approx(0.5)


def test_triangle_targets():
    assert target_triangle_count(100, 0.5, 1000) == 100
    assert target_triangle_count(None, 0.25, 1000) == 250
    with pytest.raises(ConfigError, match="not below"):
        target_triangle_count(1000, 0.5, 1000)
    with pytest.raises(ConfigError, match="leaves no triangles"):
        target_triangle_count(None, 1e-6, 1000)


def test_the_baseline_keeps_the_inputs_materials_without_normal_maps():
    asset = painted_knot()
    asset.materials[0].normal = Texture.constant([0.0, 0.0, 1.0])
    decimated = decimate(asset.mesh, 300)
    baseline = decimation_baseline(asset, decimated)
    assert baseline.mesh is decimated and baseline.materials[0].normal is None
    assert baseline.materials[0].kd is asset.materials[0].kd and asset.materials[0].normal is not None


def test_a_baseline_coloured_at_its_vertices_draws_each_triangle_in_its_corners_material():
    """A field's palette: brass metal around a dark paint disc. The big triangle's centroid and
    one shrunk corner lie on the paint, so the transfer's vote gives it the paint; its corners'
    colours are brass, and brass lit as paint is the pale smear. The baseline gives it brass."""
    n = 40
    x, y = np.meshgrid(np.linspace(0, 1, n + 1), np.linspace(0, 1, n + 1), indexing="ij")
    v_pos = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], 1)
    cell = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
    t_pos_idx = np.concatenate([np.stack([cell, cell + n + 1, cell + n + 2], 1), np.stack([cell, cell + n + 2, cell + 1], 1)])
    paint = np.linalg.norm(v_pos[t_pos_idx].mean(1)[:, :2] - 1 / 3, axis=1) < 0.3
    on_paint = np.linalg.norm(v_pos[:, :2] - 1 / 3, axis=1) < 0.3
    colour = np.where(on_paint[:, None], [0.08, 0.07, 0.07, 1.0], [0.78, 0.58, 0.22, 1.0])
    source = Mesh(v_pos=torch.tensor(v_pos, dtype=torch.float32), t_pos_idx=torch.tensor(t_pos_idx),
                  v_color=torch.tensor(colour, dtype=torch.float32), t_mat_idx=torch.tensor(paint.astype(np.int64)))
    brass = Material(kd=Texture.constant([1.0, 1.0, 1.0, 1.0]), ks=Texture.constant([0.0, 0.3, 1.0]))
    paint_material = Material(kd=Texture.constant([1.0, 1.0, 1.0, 1.0]), ks=Texture.constant([0.0, 0.7, 0.3]))
    asset = Asset(mesh=source, materials=[brass, paint_material])
    decimated = transfer_attributes(source, np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    assert decimated.t_mat_idx.tolist() == [1]
    assert decimation_baseline(asset, decimated).mesh.t_mat_idx.tolist() == [0]


def test_bake_init_starts_from_the_classic_bake():
    """The default start: the latent's textures are the bake's, on the bake's atlas, and the
    bake comes back for the report."""
    asset = painted_knot()
    decimated = decimate(asset.mesh, 300)
    guess = initial_guess(asset, decimated, "bake", 128, RANGES, np.random.default_rng(0))
    baked, latent = guess.baked, latent_of(asset, guess.start)
    material = baked.materials[0]
    assert torch.equal(latent.v_tex, baked.mesh.v_tex) and torch.equal(latent.t_pos_idx, baked.mesh.t_pos_idx)
    assert torch.allclose(latent.kd(), material.kd.data[..., :3].clamp(0, 1))
    assert torch.allclose(latent.ks()[..., 1], material.ks.data[..., 1].clamp(0.08, 1))
    facing = material.normal.data[..., 2] > 1 / CLAMP.normal_max_slope
    assert torch.allclose(latent.unit_normal().data[facing], material.normal.data[facing], atol=1e-5)
    assert not torch.equal(latent.kd(), latent.kd().mean(dim=(0, 1)).expand_as(latent.kd()))


def test_the_bake_of_a_multi_material_input_is_one_material_asset():
    """Every triangle of the bake's asset uses its one baked material (the input's material
    indices and vertex colours are baked into it, not carried along)."""
    asset = painted_knot(materials=3)
    decimated = decimate(asset.mesh, 300)
    assert decimated.t_mat_idx.max() > 0
    baked = initial_guess(asset, decimated, "bake", 128, RANGES, np.random.default_rng(0)).baked
    assert len(baked.materials) == 1 and int(baked.mesh.t_mat_idx.max()) == 0 and baked.mesh.v_color is None


def scrambled(mesh):
    """``mesh`` with its UV corners shuffled among the triangles (overlapping, flipped charts)."""
    v_tex, t_tex_idx = mesh.uv[0]
    order = torch.from_numpy(np.random.default_rng(1).permutation(t_tex_idx.numel()))
    return dataclasses.replace(mesh, uv=[(v_tex, t_tex_idx.reshape(-1)[order].reshape(-1, 3))])


def test_an_atlas_barely_overlaps_and_scrambled_uvs_do():
    atlas = unwrap(decimate(painted_knot().mesh, 300), texture_size=256)
    assert uv_overlap(atlas) <= UV_OVERLAP_LIMIT
    assert uv_overlap(scrambled(atlas)) > 5 * UV_OVERLAP_LIMIT


def test_scrambled_uvs_are_measured_on_a_coarser_grid_with_the_same_share(monkeypatch):
    """Scrambled UVs cover the square many times over: the share is measured on a grid of at
    most ``UV_CHECK_TEXELS`` covered texels, and comes out as on the full grid."""
    mesh = scrambled(unwrap(decimate(painted_knot().mesh, 300), texture_size=256))
    texels = []
    original = initial_guess_module.rasterize_uv

    def counting(uv, height, width):
        texels.append(height * width)
        return original(uv, height, width)

    monkeypatch.setattr(initial_guess_module, "rasterize_uv", counting)
    coarse = uv_overlap(mesh)
    monkeypatch.setattr(initial_guess_module, "UV_CHECK_TEXELS", 1 << 40)
    full = uv_overlap(mesh)
    assert texels[0] < texels[1] == UV_CHECK_SIZE ** 2
    assert abs(coarse - full) < 0.01


def test_a_users_textured_atlas_is_kept_and_nothing_is_baked():
    asset = painted_knot()
    lod_mesh = unwrap(decimate(asset.mesh, 300), texture_size=256)
    lod = Asset(mesh=lod_mesh, materials=[Material(kd=Texture(torch.rand(64, 64, 4).clamp(0.1, 1)),
                                                   ks=Texture.constant([0.0, 0.5, 0.0]))])
    guess = initial_guess_from_mesh(asset, lod, "lod.glb", 32)
    assert guess.baked is None and guess.baseline is lod
    assert torch.equal(guess.start.mesh.uv[0][1], lod_mesh.uv[0][1])
    assert torch.allclose(guess.start.materials[0].kd.data, resample(lod.materials[0].kd.data, 32))
    assert any("kept lod.glb's UVs and textures" in note for note in guess.notes)


def test_a_users_mesh_with_overlapping_uvs_gets_a_fresh_atlas_and_the_bake():
    asset = painted_knot()
    lod_mesh = scrambled(unwrap(decimate(asset.mesh, 300), texture_size=256))
    lod = Asset(mesh=lod_mesh, materials=[Material(kd=Texture(torch.rand(64, 64, 4)), ks=Texture.constant([0.0, 0.5, 0.0]))])
    guess = initial_guess_from_mesh(asset, lod, "lod.glb", 256)
    assert guess.baked is not None and torch.equal(guess.start.mesh.t_pos_idx, lod_mesh.t_pos_idx)
    assert uv_overlap(guess.start.mesh) <= UV_OVERLAP_LIMIT
    assert torch.equal(guess.start.materials[0].kd.data, guess.baked.materials[0].kd.data)
    assert any("fresh atlas" in note for note in guess.notes)
    (label, given), = guess.alternatives                 # baked the same way on the mesh as it came
    assert label == "lod.glb on its own positions" and torch.equal(given.mesh.v_pos, lod_mesh.v_pos)
    assert uv_overlap(given.mesh) <= UV_OVERLAP_LIMIT and given.materials[0].kd.data.shape[0] == 256
    assert guess.own_start() == "lod.glb fitted onto the input's surface"


def test_a_model_fitted_to_the_input_is_settled_back_onto_its_surface_in_a_few_rounds(monkeypatch):
    """A fitted level, decimated, lies on the input's surface but for its decimation: a few
    rounds without unfolding put it back (``on_surface``; a user's LOD gets the full fit, above)."""
    asset = painted_knot()
    lod_mesh = unwrap(decimate(asset.mesh, 300), texture_size=256)
    lifted = dataclasses.replace(lod_mesh,
                                 v_pos=lod_mesh.v_pos + 0.1 * vertex_normals(lod_mesh.v_pos, lod_mesh.t_pos_idx))
    lod = Asset(mesh=lifted, materials=[Material(kd=Texture(torch.rand(64, 64, 4)), ks=Texture.constant([0.0, 0.5, 0.0]))])
    rounds, fit = [], initial_guess_module.conform_to_surface
    monkeypatch.setattr(initial_guess_module, "conform_to_surface",
                        lambda *args, **kw: rounds.append((kw["rounds"], kw["unfold_passes"])) or fit(*args, **kw))
    settled = initial_guess_from_mesh(asset, lod, "the level above", 256, on_surface=True)
    assert rounds == [(SETTLE_ROUNDS, 0)] and settled.alternatives == []
    own = max(surface_distances(lod_mesh, asset.mesh))
    assert min(surface_distances(lifted, asset.mesh)) > 2 * own
    assert max(surface_distances(settled.start.mesh, asset.mesh)) < 1.5 * own


def test_a_users_mesh_is_fitted_onto_the_inputs_surface():
    asset = painted_knot()
    lod_mesh = unwrap(decimate(asset.mesh, 300), texture_size=256)
    shrunk = dataclasses.replace(lod_mesh, v_pos=lod_mesh.v_pos * 0.9)
    lod = Asset(mesh=shrunk, materials=[Material(kd=Texture(torch.rand(64, 64, 4)), ks=Texture.constant([0.0, 0.5, 0.0]))])
    guess = initial_guess_from_mesh(asset, lod, "lod.glb", 256)
    own = max(surface_distances(lod_mesh, asset.mesh))
    assert min(surface_distances(shrunk, asset.mesh)) > 3 * own
    assert max(surface_distances(guess.start.mesh, asset.mesh)) < 1.5 * own
    assert guess.baseline is lod and torch.equal(guess.baseline.mesh.v_pos, shrunk.v_pos)
    distance = guess.start_distance                       # how far the fitted mesh strays, as measured
    assert distance["of"] == "lod.glb, fitted onto the input's surface" and distance["triangles"] == 300
    assert distance["far_area"] < 0.005 and distance["guard"]["snapped"] == distance["guard"]["removed"] == 0


def test_a_fitted_mesh_passes_the_decimations_guard():
    """A shard left after fitting is put back on the surface; a triangle spanning empty space,
    corners on the surface, is removed with the UV rows only it used."""
    sphere = icosphere(4)
    low = unwrap(decimate(sphere, 300), texture_size=256)
    v_pos = low.v_pos.clone()
    v_pos[low.t_pos_idx[5]] *= 1.5                              # one triangle's corners pulled outwards
    guarded, distance = guarded_fit(low.with_positions(v_pos), sphere, "a test")
    assert distance["guard"]["snapped"] >= 3 and distance["guard"]["removed"] == 0     # its corners and neighbours
    assert guarded.num_triangles == 300 and distance["far_area"] < 0.005
    chord = torch.tensor([[1.0, 0.0, 0.0], [-0.5, 0.8660254, 0.0], [-0.5, -0.8660254, 0.0]])
    corners = low.num_vertices + torch.arange(3)
    v_tex, t_tex_idx = low.uv[0]
    spanning = dataclasses.replace(low, v_pos=torch.cat([low.v_pos, chord]),
                                   t_pos_idx=torch.cat([low.t_pos_idx, corners[None]]),
                                   uv=[(torch.cat([v_tex, torch.zeros(3, 2)]),
                                        torch.cat([t_tex_idx, len(v_tex) + torch.arange(3)[None]]))],
                                   t_nrm_idx=None, t_mat_idx=torch.zeros(301, dtype=torch.int64))
    kept, distance = guarded_fit(spanning, sphere, "a test")
    assert distance["guard"]["removed"] == 1 and kept.num_triangles == 300
    assert kept.num_vertices == low.num_vertices and kept.uv[0][0].shape == v_tex.shape
