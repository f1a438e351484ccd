"""How trained alpha is written (``lookalike.jobs.alpha_export``), disjoint parts and the
aggregate-geometry hint (``lookalike.asset.parts``), and the settings ``cards`` adds."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

from lookalike.asset import Asset, Material, Mesh, Texture
from lookalike.asset.parts import aggregate_traits, triangle_parts, triangle_parts_python
from lookalike.errors import ConfigError
from lookalike.settings import Config
from lookalike.settings import load_config, with_overrides
from lookalike.fit.losses import l2_tonemapped
from lookalike.jobs.alpha_export import CUTOFFS, filled_colour, finished_alpha, training_start
from lookalike.report.metrics import silhouette_iou
from mesh_factory import icosphere


def scattered_quads(count: int, seed: int = 0, shared_corner: bool = False) -> Mesh:
    """``count`` small disjoint quads at random places (two triangles each, own vertices;
    ``shared_corner``: the first two share a corner position, held by distinct vertices)."""
    rng = np.random.default_rng(seed)
    centres = rng.uniform(-1, 1, (count, 1, 3))
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float) * 0.05
    v_pos = (centres + square).reshape(-1, 3)
    if shared_corner:
        v_pos[4] = v_pos[2]
    quads = np.arange(count)[:, None] * 4
    t_pos_idx = np.concatenate([quads + [0, 1, 2], quads + [0, 2, 3]])
    return Mesh(v_pos=torch.from_numpy(v_pos).float(), t_pos_idx=torch.from_numpy(t_pos_idx).long())


def test_parts_match_their_union_find_twin_and_join_at_equal_positions():
    mesh = scattered_quads(40, shared_corner=True)
    fast = triangle_parts(mesh.v_pos.numpy(), mesh.t_pos_idx.numpy())
    slow = triangle_parts_python(mesh.v_pos.numpy(), mesh.t_pos_idx.numpy())
    np.testing.assert_array_equal(fast, slow)
    assert fast.max() + 1 == 39          # the first two quads touch at one corner position
    assert fast[0] == fast[1] == fast[40] == fast[41] == 0


def test_aggregate_hint_for_many_parts_and_not_for_one_solid():
    leaves = Asset(scattered_quads(300), [Material()])
    traits = aggregate_traits(leaves)
    assert traits is not None and "300 disjoint parts" in traits
    assert aggregate_traits(Asset(icosphere(2), [Material()])) is None


def test_cutoff_is_the_best_scored_and_ties_keep_the_models_own():
    kd = torch.rand(8, 8, 4)
    model = Asset(scattered_quads(2), [Material(kd=Texture(kd), alpha_mode="MASK", alpha_cutoff=0.5)])
    best = finished_alpha(model, "auto", lambda m: -abs(m.materials[0].alpha_cutoff - CUTOFFS[1]))
    assert best.materials[0].alpha_cutoff == CUTOFFS[1]
    tied = finished_alpha(model, "auto", lambda m: 1.0)
    assert tied.materials[0].alpha_cutoff == 0.5
    soft = Asset(scattered_quads(2), [Material(kd=Texture(kd), alpha_mode="BLEND")])
    assert finished_alpha(soft, "mask", None).materials[0].alpha_mode == "MASK"
    assert finished_alpha(soft, "blend", None).materials[0].alpha_mode == "BLEND"
    assert model.materials[0].alpha_cutoff == 0.5   # the input model is not changed


def test_colour_is_filled_only_under_texels_no_lookup_reaches():
    kd = torch.zeros(9, 9, 4)
    kd[4, 4] = torch.tensor([0.2, 0.7, 0.1, 1.0])       # one visible texel
    kd[0, 0, :3] = torch.tensor([0.9, 0.9, 0.9])         # far away, invisible
    kd[3, 4, :3] = torch.tensor([0.5, 0.5, 0.5])         # next to the visible one, invisible
    filled = filled_colour(kd, 0.5)
    assert torch.equal(filled[..., 3], kd[..., 3])
    assert torch.allclose(filled[0, 0, :3], kd[4, 4, :3])   # far texels take the nearest visible colour
    assert torch.equal(filled[3, 4], kd[3, 4])               # a bilinear neighbour keeps its trained colour
    assert torch.equal(filled[4, 4], kd[4, 4])


def test_alpha_mode_setting_leaves_opaque_materials_alone():
    asset = Asset(scattered_quads(2), [Material(alpha_mode="MASK"), Material()])
    trained = training_start(asset, "mask", 0.0)
    assert [m.alpha_mode for m in trained.materials] == ["BLEND", "OPAQUE"]
    annealed = training_start(asset, "mask", 0.75)
    assert [(m.alpha_mode, m.coverage_ramp) for m in annealed.materials] == [("MASK", 1.0), ("OPAQUE", 0.0)]
    assert training_start(asset, "auto", 0.75) is asset
    opaque = finished_alpha(Asset(scattered_quads(2), [Material()]), "mask", None)
    assert opaque.materials[0].alpha_mode == "OPAQUE"


def test_settings_of_layers_alpha_and_defaults(tmp_path):
    with pytest.raises(ConfigError, match="render.layers"):
        with_overrides(None, layers=0)
    with pytest.raises(ConfigError, match="latent.alpha_mode"):
        with_overrides(None, alpha_mode="dither")
    relit = Config()
    relit.views = dataclasses.replace(relit.views, relight=True)
    relit.render = dataclasses.replace(relit.render, layers=4)
    with pytest.raises(ConfigError, match="relight"):
        relit.validate()
    defaults = dataclasses.replace(Config(), latent=dataclasses.replace(Config().latent, ratio=0.01))
    settings = tmp_path / "run.toml"
    settings.write_text("[latent]\ntriangles = 500\n")
    cfg = load_config(settings, defaults)
    assert (cfg.latent.triangles, cfg.latent.ratio) == (500, None)     # the file's count replaces the default's
    assert with_overrides(None, defaults=defaults).latent.ratio == 0.01
    assert with_overrides(settings, defaults=defaults, ratio=0.02).latent.triangles is None


def test_l2_tonemapped_and_silhouette_iou():
    pred, target = torch.full((1, 2, 2, 3), 0.5), torch.zeros(1, 2, 2, 3)
    from lookalike.colour import tonemap

    assert torch.isclose(l2_tonemapped(pred, target), (tonemap(pred) ** 2).mean())
    a = torch.tensor([[[1.0, 1.0], [0.0, 0.5]]])
    b = torch.tensor([[[1.0, 0.0], [0.0, 1.0]]])
    assert silhouette_iou(a, b) == pytest.approx((1 + 0.5) / (1 + 1 + 1))
    assert silhouette_iou(torch.zeros(1, 2, 2), torch.zeros(1, 2, 2)) == 1.0


def test_dithered_alpha_keeps_the_mean_of_every_block_in_zeros_and_ones():
    from lookalike.jobs.alpha_export import dithered_alpha

    alpha = torch.rand(4, 4).repeat_interleave(8, 0).repeat_interleave(8, 1)   # constant over each 8 x 8 block
    binary = dithered_alpha(alpha)
    assert set(binary.unique().tolist()) <= {0.0, 1.0}
    blocks = binary.reshape(4, 8, 4, 8).mean(dim=(1, 3))
    assert torch.allclose(blocks, alpha[::8, ::8], atol=1 / 64 + 1e-6)


def test_a_soft_model_written_masked_may_take_the_dither():
    kd = torch.rand(16, 16, 4)
    soft = Asset(scattered_quads(2), [Material(kd=Texture(kd), alpha_mode="BLEND")])
    binary = lambda m: float(((m.materials[0].kd.data[..., 3] == 0) | (m.materials[0].kd.data[..., 3] == 1)).all())
    chosen = finished_alpha(soft, "mask", binary)
    assert chosen.materials[0].alpha_mode == "MASK" and binary(chosen) == 1.0
    assert finished_alpha(soft, "mask", lambda m: 0.0).materials[0].kd.data[..., 3].equal(kd[..., 3])


def test_the_alpha_label_says_how_the_written_model_draws_its_alpha():
    from lookalike.jobs.alpha_export import AlphaChoice, alpha_label, written_alpha

    soft = Asset(scattered_quads(2), [Material(kd=Texture(torch.rand(16, 16, 4)), alpha_mode="BLEND")])
    opaque = Asset(scattered_quads(2), [Material(kd=Texture(torch.rand(16, 16, 3)))])
    for choice, label in ((AlphaChoice(0.4), "cutoff 0.4"), (AlphaChoice(dither=True), "dithered")):
        assert alpha_label(soft, "mask", choice) == label
        written = written_alpha(soft, "mask", choice).materials[0]
        assert written.alpha_mode == "MASK" and f"cutoff {written.alpha_cutoff:g}" == (
            label if not choice.dither else "cutoff 0.5")
    assert alpha_label(soft, "blend", AlphaChoice()) == "blended"
    assert alpha_label(soft, "auto", AlphaChoice()) == "blended"
    masked = written_alpha(soft, "mask", AlphaChoice(0.6))
    assert alpha_label(masked, "auto", AlphaChoice()) == "cutoff 0.6"
    assert alpha_label(opaque, "mask", AlphaChoice(0.4)) is None


def _two_quads_with_glass() -> Asset:
    """Two unit quads side by side, one textured over the opaque left half of an RGBA texture
    and one over its translucent right half (alpha 0.4), one ``BLEND`` material."""
    v_pos = torch.tensor([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [1.2, 0, 0], [2.2, 0, 0], [2.2, 1, 0],
                          [1.2, 1, 0]])
    faces = torch.tensor([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
    v_tex = torch.tensor([[0.05, 0.05], [0.45, 0.05], [0.45, 0.95], [0.05, 0.95], [0.55, 0.05], [0.95, 0.05],
                          [0.95, 0.95], [0.55, 0.95]])
    mesh = Mesh(v_pos=v_pos, t_pos_idx=faces, uv=[(v_tex, faces.clone())], t_mat_idx=torch.zeros(4, dtype=torch.long))
    kd = torch.full((32, 32, 4), 0.6)
    kd[..., 3] = 1.0
    kd[:, 16:, 3] = 0.4
    return Asset(mesh=mesh, materials=[Material(kd=Texture(kd), alpha_mode="BLEND", double_sided=True)])


def test_a_blended_material_s_opaque_triangles_are_written_opaque_and_draw_alike():
    """Engines draw a blended material without depth writes: its opaque triangles move to an
    opaque copy of it (same texture), the translucent ones stay blended, our renderer draws the
    model as before; a blended material whose triangles are all opaque becomes opaque."""
    from lookalike.fit.textured_mesh import render_asset
    from lookalike.jobs.alpha_export import split_opaque
    from lookalike.shading.camera import Camera
    from lookalike.shading.light import PointLight

    asset = _two_quads_with_glass()
    split = split_opaque(asset)
    assert [m.alpha_mode for m in split.materials] == ["BLEND", "OPAQUE"]
    assert split.mesh.t_mat_idx.tolist() == [1, 1, 0, 0] and split.materials[1].kd is asset.materials[0].kd
    camera = Camera.looking_at(torch.tensor([[1.1, 0.5, 3.0]]), torch.tensor([[1.1, 0.5, 0.0]]),
                               fovy=0.9, near=0.5, far=6.0)
    light = PointLight(position=torch.tensor([[1.1, 0.5, 3.0]]), intensity=torch.full((1, 3), 9.0))
    before, after = (render_asset(a, camera, light, resolution=48, msaa=2) for a in (asset, split))
    assert float((before - after).abs().max()) < 1e-4
    solid = dataclasses.replace(asset.materials[0], kd=Texture(torch.cat([asset.materials[0].kd.data[..., :3],
                                                                        torch.full((32, 32, 1), 0.99)], -1)))
    whole = split_opaque(dataclasses.replace(asset, materials=[solid]))
    assert [m.alpha_mode for m in whole.materials] == ["OPAQUE"] and whole.mesh.t_mat_idx.tolist() == [0, 0, 0, 0]
    masked = dataclasses.replace(asset, materials=[dataclasses.replace(asset.materials[0], alpha_mode="MASK")])
    assert split_opaque(masked) is masked


def test_a_split_model_read_back_is_merged_into_the_material_it_was_fitted_as(tmp_path):
    from lookalike import io
    from lookalike.jobs.alpha_export import merged_opaque, split_opaque

    asset = _two_quads_with_glass()
    io.save(split_opaque(asset), tmp_path / "split.glb")
    merged = merged_opaque(io.load(tmp_path / "split.glb"))
    assert [m.alpha_mode for m in merged.materials] == ["BLEND"] and merged.mesh.t_mat_idx.tolist() == [0, 0, 0, 0]
    assert merged_opaque(asset) is asset
