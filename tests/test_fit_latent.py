"""The latent model of ``simplify`` (``TexturedMesh``): frames, clamping, the Laplacian
regulariser, coverage, state round trip."""

from __future__ import annotations

import pytest
import torch

from lookalike.asset import Mesh
from lookalike.settings import ClampConfig
from lookalike.fit.slope_normals import (
    normal_to_slopes,
    slopes_to_normal,
    slopes_to_normal_python,
)
from lookalike.fit.textured_mesh import TexturedMesh


def make_latent(size: int = 4, alpha: bool = False, cls: type[TexturedMesh] = TexturedMesh, **kwargs) -> TexturedMesh:
    """One triangle in world coordinates [10, 12] x [0, 2] with random textures; its unit frame
    is centred at (11, 1, 0) with radius 2. ``kwargs`` go to the constructor (``limits``,
    ``msaa``, ...)."""
    mesh = Mesh(v_pos=torch.tensor([[10.0, 0, 0], [12.0, 0, 0], [10.0, 2.0, 0]]),
                t_pos_idx=torch.tensor([[0, 1, 2]]),
                uv=[(torch.tensor([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), torch.tensor([[0, 1, 2]]))])
    channels = 4 if alpha else 3
    kd = torch.rand(size, size, channels)
    ks = torch.rand(size, size, 3)
    normal = torch.tensor([0.0, 0.0, 1.0]).expand(size, size, 3)
    return cls(mesh, kd, ks, normal, centre=torch.tensor([11.0, 1.0, 0.0]), radius=2.0,
               alpha_mode="BLEND" if alpha else "OPAQUE", **kwargs)


def laplacian(latent: TexturedMesh) -> float:
    return float(latent.regularizers()["laplacian"].detach())


def test_positions_live_in_the_unit_frame_and_export_in_the_input_frame():
    latent = make_latent()
    assert latent.v_pos[0].tolist() == pytest.approx([-0.5, -0.5, 0.0])
    asset = latent.as_asset()
    assert torch.allclose(asset.mesh.v_pos, torch.tensor([[10.0, 0, 0], [12, 0, 0], [10, 2, 0]]))
    assert asset.mesh.v_pos.requires_grad  # differentiable for the renderer
    exported = latent.export()
    assert torch.equal(exported.mesh.v_pos, asset.mesh.v_pos) and not exported.mesh.v_pos.requires_grad


def test_alpha_is_one_unless_trained():
    assert (make_latent().as_asset().materials[0].kd.data[..., 3] == 1).all()
    latent = make_latent(alpha=True)
    assert latent.trains_alpha and latent.as_asset().materials[0].alpha_mode == "BLEND"
    assert torch.equal(latent.as_asset().materials[0].kd.data, latent.kd())


def test_the_parameter_groups_hold_every_parameter_once():
    latent = make_latent()
    groups = latent.parameter_groups()
    assert list(groups) == ["positions", "textures"]
    assert groups["positions"] == [latent.v_pos]
    grouped = [id(p) for params in groups.values() for p in params]
    assert sorted(grouped) == sorted(id(p) for p in latent.parameters()) and len(set(grouped)) == len(grouped)


def test_reading_projects_every_texture_into_the_stored_limits():
    latent = make_latent(limits=ClampConfig(roughness=(0.1, 0.9), normal_max_slope=2.0),
                         texture_scales=(0.5, 1.0, 1.0))
    with torch.no_grad():
        for pyramid in (latent.kd, latent.ks, latent.normal):
            for level in pyramid.levels:
                level.copy_(10 * torch.randn_like(level))
    kd, ks, normal = (channel().detach() for channel in (latent.kd, latent.ks, latent.normal))
    stored = [channel.levels[0].detach().clone() for channel in (latent.kd, latent.ks, latent.normal)]
    again = [channel().detach() for channel in (latent.kd, latent.ks, latent.normal)]
    for first, second, level, channel in zip((kd, ks, normal), again, stored, (latent.kd, latent.ks, latent.normal)):
        torch.testing.assert_close(second, first)  # the projection was written back: a second read changes nothing
        torch.testing.assert_close(channel.levels[0].detach(), level)  # up to rounding of the re-summed texels
    assert kd.min() >= -1e-5 and kd.max() <= 1 + 1e-5
    assert ks[..., 1].min() >= 0.1 - 1e-5 and ks[..., 1].max() <= 0.9 + 1e-5
    assert ks[..., 0].min() >= -1e-5 and ks[..., 2].max() <= 1 + 1e-5 and ks.min() >= -1e-5
    assert normal.abs().max() <= 2.0 + 1e-5 and float(normal.abs().max()) == pytest.approx(2.0)


def test_normals_are_unit_slopes_and_round_trip():
    normal = torch.nn.functional.normalize(torch.tensor([[0.3, -0.4, 0.8], [0.0, 0.0, 1.0]]), dim=-1)
    assert torch.allclose(slopes_to_normal(normal_to_slopes(normal)), normal, atol=1e-6)
    assert normal_to_slopes(normal)[0].tolist() == pytest.approx([0.375, -0.5])
    latent = make_latent()
    assert torch.equal(latent.unit_normal().data, torch.tensor([0.0, 0.0, 1.0]).expand(4, 4, 3))


def test_the_compiled_slopes_to_normal_matches_its_twin_and_finite_differences():
    slopes = 3 * torch.randn(5, 7, 2)
    fast, slow = slopes.clone().requires_grad_(), slopes.clone().requires_grad_()
    out_fast, out_slow = slopes_to_normal(fast), slopes_to_normal_python(slow)
    torch.testing.assert_close(out_fast, out_slow)
    weights = torch.randn_like(out_fast)
    torch.testing.assert_close(*(torch.autograd.grad(out, s, weights)[0] for out, s in ((out_fast, fast), (out_slow, slow))))
    assert torch.autograd.gradcheck(slopes_to_normal, torch.randn(3, 4, 2, dtype=torch.float64, requires_grad=True))


def test_the_laplacian_is_relative_to_the_initial_mesh_and_scaled_by_its_energy():
    latent = make_latent()
    # unit-frame corners (-.5, -.5), (.5, -.5), (-.5, .5): differentials (-.5, -.5), (1, -.5), (-.5, 1),
    # squared lengths .5, 1.25, 1.25
    assert latent.regularizer_scales() == {"laplacian": pytest.approx(1.0)}
    assert laplacian(latent) == 0.0
    with torch.no_grad():
        latent.v_pos += torch.tensor([0.2, -0.1, 0.3])  # a translation leaves the differentials alone
    assert laplacian(latent) == pytest.approx(0.0, abs=1e-12)
    with torch.no_grad():
        latent.v_pos[0, 0] += 0.3  # delta_0 moves by 0.3, delta_1 and delta_2 by -0.15
    assert laplacian(latent) == pytest.approx((0.09 + 2 * 0.0225) / 3)
    assert latent.regularizer_scales() == {"laplacian": pytest.approx(1.0)}  # the initial mesh's
    assert "rest_delta" in latent.state_dict()


def test_coverage_is_none_where_alpha_is_trained():
    from lookalike.shading.camera import Camera

    eye = torch.tensor([[11.0, 1.0, 6.0]])
    camera = Camera.looking_at(eye, torch.tensor([[11.0, 1.0, 0.0]]))
    coverage = make_latent().coverage(camera, 8)
    assert coverage.shape == (1, 8, 8) and 0 < float(coverage.detach().mean()) < 1
    assert make_latent(alpha=True).coverage(camera, 8) is None


def test_state_dict_round_trip_rebuilds_the_same_model():
    latent = make_latent(alpha=True, limits=ClampConfig(kd=(0.1, 0.9)), msaa=2, double_sided=True, wrap="wrap")
    with torch.no_grad():
        latent.v_pos[0, 0] += 0.3
    expected_laplacian = laplacian(latent)
    assert expected_laplacian == pytest.approx((0.09 + 2 * 0.0225) / 3)
    # another model, built on the moved mesh (so its own initial mesh differs) with other textures and settings
    again = TexturedMesh(latent.export().mesh, torch.rand(4, 4, 4), torch.rand(4, 4, 3),
                         torch.tensor([0.0, 0.0, 1.0]).expand(4, 4, 3), centre=torch.zeros(3), radius=1.0)
    assert laplacian(again) == 0.0 and not torch.equal(again.kd(), latent.kd())
    again.load_state_dict(latent.state_dict())
    for name, value in latent.state_dict().items():
        if isinstance(value, torch.Tensor):
            assert torch.equal(value, again.state_dict()[name]), name
    assert again.alpha_mode == "BLEND" and again.trains_alpha
    assert again.limits == ClampConfig(kd=(0.1, 0.9)) and again.msaa == 2
    assert again.double_sided and again.wrap == "wrap"
    assert laplacian(again) == expected_laplacian  # the initial mesh's differentials came along


def test_a_constant_colour_never_holds_a_trained_alpha_constant():
    from lookalike.asset import Asset, Material, Texture
    from test_pipeline import quad

    kd = torch.ones(8, 8, 4) * torch.tensor([0.3, 0.5, 0.2, 1.0])
    kd[:, :4, 3] = 0.0                                       # one colour; coverage on half the card
    asset = Asset(quad(), [Material(kd=Texture(kd), alpha_mode="MASK", double_sided=True)])
    common = dict(centre=torch.zeros(3), radius=1.0, limits=ClampConfig(), msaa=1, constant=frozenset({"kd", "ks"}))
    trained = TexturedMesh.from_asset(asset, train_alpha=True, **common).export().materials[0].kd.data
    assert trained.shape[:2] == (8, 8) and torch.equal(trained[..., 3], kd[..., 3])
    held = TexturedMesh.from_asset(asset, train_alpha=False, **common).export().materials[0].kd.data
    assert held.shape[:2] == (1, 1)
