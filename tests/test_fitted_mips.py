"""Fitted mip levels: user mips receive exactly the gradients of the levels a lookup uses,
levels no view reaches stay the box filter of the level above, the latent exports its mips,
and the setting reaches the run's latent."""

from __future__ import annotations

import torch

import lookalike.render as dr
from lookalike.fit.fitted_mips import FittedMips, box_down
from lookalike.render.mipmap import texture_construct_mip
from test_fit_latent import make_latent


def _lookup_at_level(texture: torch.Tensor, mips: list[torch.Tensor], level: float) -> torch.Tensor:
    """Trilinear lookups of ``texture [H, W, C]`` with user ``mips`` at a footprint of ``2^level`` texels."""
    height, width = texture.shape[:2]
    uv = torch.rand(1, 64, 1, 2, generator=torch.Generator().manual_seed(0))
    footprint = 2.0 ** level
    uv_da = torch.tensor([footprint / width, 0.0, 0.0, footprint / height]).expand(1, 64, 1, 4).contiguous()
    return dr.texture(texture[None], uv, uv_da=uv_da, mip=[m[None] for m in mips],
                      filter_mode="linear-mipmap-linear")


def test_user_mips_get_gradients_exactly_at_the_levels_a_lookup_used():
    texture = torch.rand(32, 32, 3, requires_grad=True)
    mips = [level[0].detach().clone().requires_grad_(True) for level in texture_construct_mip(texture.detach()[None])]
    _lookup_at_level(texture, mips, 2.5).sum().backward()
    used = [k for k, level in enumerate([texture, *mips]) if level.grad is not None and level.grad.abs().sum() > 0]
    assert used == [2, 3]


def test_levels_no_lookup_reaches_stay_the_box_filter_of_the_level_above():
    texture = torch.rand(32, 32, 3, requires_grad=True)
    fitted = FittedMips(32, 32, 3, (0.5, 0.5))
    optimiser = torch.optim.Adam([texture, *fitted.parameters()], lr=0.05)
    target = torch.rand(1, 64, 1, 3)
    for _ in range(5):
        optimiser.zero_grad()
        (_lookup_at_level(texture, fitted(texture), 1.4) - target).square().mean().backward()
        optimiser.step()
    levels = [texture.detach(), *[m.detach() for m in fitted(texture.detach())]]
    moved = [k for k in range(1, len(levels)) if not torch.allclose(levels[k], box_down(levels[k - 1], levels[k].shape[:2]))]
    assert moved == [1, 2]                                   # the levels the lookups used were fitted
    for k in range(3, len(levels)):                          # the rest are the box filter of the level above
        assert torch.equal(levels[k], box_down(levels[k - 1], levels[k].shape[:2]))
    assert [tuple(level.shape[:2]) for level in levels] == [(32 >> k, 32 >> k) for k in range(6)]


def test_fitted_mips_are_clamped_into_the_texture_s_range_and_exported_with_it():
    latent = make_latent(size=16, fitted_mips=True)
    with torch.no_grad():
        latent.kd_mips.residuals[0].levels[-1].fill_(10.0)
    asset = latent.export()
    kd, ks, normal = asset.materials[0].kd, asset.materials[0].ks, asset.materials[0].normal
    assert [tuple(m.shape) for m in kd.mips] == [(16 >> k, 16 >> k, 4) for k in range(1, 5)]
    assert kd.mips[0][..., :3].max() <= latent.limits.kd[1] and torch.equal(kd.mips[0][..., 3], torch.ones(8, 8))
    assert len(ks.mips) == 4 and torch.allclose(normal.mips[2].norm(dim=-1), torch.ones(2, 2))
    plain = make_latent(size=16).export().materials[0]
    assert plain.kd.mips is None and plain.normal.mips is None
    names = {name for name, _ in latent.named_parameters()}
    grouped = {id(p) for group in latent.parameter_groups().values() for p in group}
    assert any(name.startswith("normal_mips") for name in names) and grouped == {id(p) for p in latent.parameters()}


def test_the_setting_gives_the_run_s_latent_fitted_mips():
    from lookalike.jobs.run import mesh_latent
    from lookalike.settings import with_overrides
    from test_fit_simplify import bumpy_sphere

    start = make_latent(size=8).export()
    assert mesh_latent(bumpy_sphere(), start, with_overrides(None, fitted_mips=True), moving=False).kd_mips is not None
    assert mesh_latent(bumpy_sphere(), start, with_overrides(None), moving=False).kd_mips is None
