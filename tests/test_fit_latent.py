"""The latent model: frames, clamping, state round trip; the output folder rules."""

from __future__ import annotations

import os

import pytest
import torch

from lookalike.asset import Mesh
from lookalike.errors import ConfigError
from lookalike.fit.config import ClampConfig
from lookalike.fit.latent import Latent, normal_to_slopes, slopes_to_normal
from lookalike.fit.outdir import CHECKPOINT_NAME, atomic_path, prepare_outdir, write_text_atomic


def make_latent(size: int = 4, alpha: bool = False) -> Latent:
    mesh = Mesh(v_pos=torch.tensor([[10.0, 0, 0], [12.0, 0, 0], [10.0, 2.0, 0]]),
                t_pos_idx=torch.tensor([[0, 1, 2]]),
                uv=[(torch.tensor([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), torch.tensor([[0, 1, 2]]))])
    channels = 4 if alpha else 3
    kd = torch.rand(size, size, channels)
    ks = torch.rand(size, size, 3)
    normal = torch.tensor([0.0, 0.0, 1.0]).expand(size, size, 3)
    return Latent(mesh, kd, ks, normal, centre=torch.tensor([11.0, 1.0, 0.0]), radius=2.0,
                  alpha_mode="BLEND" if alpha else "OPAQUE")


def test_positions_live_in_the_unit_frame_and_export_in_the_input_frame():
    latent = make_latent()
    assert latent.v_pos[0].tolist() == pytest.approx([-0.5, -0.5, 0.0])
    asset = latent.as_asset()
    assert torch.allclose(asset.mesh.v_pos, torch.tensor([[10.0, 0, 0], [12, 0, 0], [10, 2, 0]]))
    assert asset.mesh.v_pos.requires_grad  # differentiable for the renderer


def test_alpha_is_one_unless_trained():
    assert (make_latent().as_asset().materials[0].kd.data[..., 3] == 1).all()
    latent = make_latent(alpha=True)
    assert latent.trains_alpha and latent.as_asset().materials[0].alpha_mode == "BLEND"
    assert torch.equal(latent.as_asset().materials[0].kd.data, latent.kd)


def test_clamp_projects_every_texture_into_its_range():
    latent = make_latent()
    with torch.no_grad():
        latent.kd.uniform_(-1, 2)
        latent.ks.uniform_(-1, 2)
        latent.normal.copy_(10 * torch.randn_like(latent.normal))
    latent.clamp_(ClampConfig(roughness=(0.1, 0.9), normal_max_slope=2.0))
    assert latent.kd.min() >= 0 and latent.kd.max() <= 1
    assert latent.ks[..., 1].min() >= 0.1 and latent.ks[..., 1].max() <= 0.9
    assert latent.ks[..., 0].min() >= 0 and latent.ks[..., 2].max() <= 1 and latent.ks.min() >= 0
    assert latent.normal.abs().max() <= 2.0 and latent.normal.abs().max() == 2.0


def test_normals_are_unit_slopes_and_round_trip():
    normal = torch.nn.functional.normalize(torch.tensor([[0.3, -0.4, 0.8], [0.0, 0.0, 1.0]]), dim=-1)
    assert torch.allclose(slopes_to_normal(normal_to_slopes(normal)), normal, atol=1e-6)
    assert normal_to_slopes(normal)[0].tolist() == pytest.approx([0.375, -0.5])
    latent = make_latent()
    assert torch.equal(latent.unit_normal(), torch.tensor([0.0, 0.0, 1.0]).expand(4, 4, 3))


def test_state_dict_round_trip_rebuilds_the_same_model():
    latent = make_latent(alpha=True)
    again = Latent.from_state_dict(latent.state_dict())
    for name, value in latent.state_dict().items():
        if isinstance(value, torch.Tensor):
            assert torch.equal(value, again.state_dict()[name]), name
    assert again.alpha_mode == "BLEND" and again.trains_alpha


def test_outdir_is_never_overwritten_without_force(tmp_path):
    out = tmp_path / "out"
    prepare_outdir(out, force=False, resume=False)  # absent: created
    prepare_outdir(out, force=False, resume=False)  # empty: fine
    (out / "model.glb").write_text("old")
    with pytest.raises(ConfigError, match="--force"):
        prepare_outdir(out, force=False, resume=False)
    (out / CHECKPOINT_NAME).write_text("stale")
    prepare_outdir(out, force=True, resume=False)
    assert not (out / CHECKPOINT_NAME).exists() and (out / "model.glb").exists()


def test_resume_needs_a_checkpoint(tmp_path):
    with pytest.raises(ConfigError, match="nothing to resume"):
        prepare_outdir(tmp_path, force=False, resume=True)
    (tmp_path / CHECKPOINT_NAME).write_text("x")
    assert prepare_outdir(tmp_path, force=False, resume=True) == tmp_path


def test_atomic_writes_leave_the_old_file_on_failure(tmp_path):
    target = tmp_path / "metrics.json"
    write_text_atomic(target, "first")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as temp:
            temp.write_text("half")
            raise RuntimeError("writer crashed")
    assert target.read_text() == "first"
    assert os.listdir(tmp_path) == ["metrics.json"]
