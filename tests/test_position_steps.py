"""Per-vertex position steps (``optim.position_steps = "local"``): each card steps by its own
size, so small and large cards stay as stable as each other."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from lookalike.asset import Asset, Material, Mesh, Texture
from lookalike.fit.position_steps import LOCAL_STEP_SIZE, local_step_scale
from lookalike.fit.textured_mesh import TexturedMesh
from lookalike.fit.training_views import view_sampler
from lookalike.settings import ClampConfig


def two_cards(small: float, large: float) -> Mesh:
    """A ``large`` square card at x = -0.6 and a ``small`` one at x = +0.6 (own vertices, two
    triangles each, facing +z), UVs covering the whole square."""
    corners = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32) / 2
    v_pos = np.concatenate([corners * large + [-0.6, 0, 0], corners * small + [0.6, 0, 0]]).astype(np.float32)
    tri = torch.tensor([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
    uv = torch.tensor([[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]] * 2)
    return Mesh(v_pos=torch.from_numpy(v_pos), t_pos_idx=tri, uv=[(uv, tri.clone())])


def test_local_scale_is_the_card_side_in_radii_at_most_one():
    mesh = two_cards(small=0.05, large=0.6)
    extra = Mesh(v_pos=torch.cat([mesh.v_pos, torch.zeros(1, 3)]), t_pos_idx=mesh.t_pos_idx)
    scale = local_step_scale(extra.v_pos, extra.t_pos_idx, radius=1.0)
    assert scale.shape == (9, 1)
    torch.testing.assert_close(scale[4:8, 0], torch.full((4,), 0.05 / LOCAL_STEP_SIZE))
    assert torch.equal(scale[:4, 0], torch.ones(4))                    # a large card steps as a mesh does
    assert scale[8, 0] == 1.0                                          # no triangle
    halved = local_step_scale(extra.v_pos, extra.t_pos_idx, radius=2.0)
    torch.testing.assert_close(halved[4:8], scale[4:8] / 2)


def latent_of(mesh: Mesh, steps: str) -> TexturedMesh:
    colour = torch.zeros(8, 8, 4)
    colour[..., :3] = torch.linspace(0.1, 0.9, 8)[:, None, None]
    colour[..., 3] = 1.0
    material = Material(kd=Texture(colour), ks=Texture.constant([0.0, 0.6, 0.0]), alpha_mode="BLEND",
                        double_sided=True)
    return TexturedMesh.from_asset(Asset(mesh, [material]), centre=torch.zeros(3), radius=1.0, limits=ClampConfig(),
                                   msaa=1, train_alpha=True, position_steps=steps)


def test_the_latent_starts_where_the_mesh_is_whatever_its_steps():
    mesh = two_cards(small=0.05, large=0.6)
    local, uniform = latent_of(mesh, "local"), latent_of(mesh, "uniform")
    assert uniform.position_steps is None
    torch.testing.assert_close(local.world_positions(), mesh.v_pos)
    assert torch.equal(uniform.world_positions(), mesh.v_pos)
    assert float(local.regularizers()["laplacian"].detach()) == pytest.approx(0.0, abs=1e-12)


def drift(steps: str, seed: int = 0, iterations: int = 30) -> np.ndarray:
    """How far each card's corners wander, relative to its side, in ``iterations`` Adam steps
    (lr 0.01) from the optimum: the latent fitted to renders of itself, where
    Adam's normalised steps are all the motion there is."""
    mesh = two_cards(small=0.05, large=0.6)
    latent = latent_of(mesh, steps)
    reference = latent_of(mesh, "uniform")
    optimiser = torch.optim.Adam(latent.parameter_groups()["positions"], lr=0.01)
    sample = view_sampler(torch.zeros(3), 1.0)
    rng = np.random.default_rng(seed)
    for _ in range(iterations):
        views = sample(rng, 2)
        with torch.no_grad():
            target = reference.render(views.camera, views.light, 32)
        noisy = target + 0.02 * torch.from_numpy(rng.normal(size=target.shape).astype(np.float32))
        optimiser.zero_grad()
        ((latent.render(views.camera, views.light, 32) - noisy) ** 2).mean().backward()
        optimiser.step()
    moved = (latent.world_positions().detach() - mesh.v_pos).norm(dim=1).reshape(2, 4).max(dim=1).values
    return (moved / torch.tensor([0.6, 0.05])).numpy()


def test_local_steps_keep_the_small_card_as_stable_as_the_large_one():
    uniform, local = drift("uniform"), drift("local")
    assert uniform[1] > 1.0                       # uniform steps carry the small card off by more than its size
    assert local[1] < 0.5 and local[1] < uniform[1] / 4
    assert uniform[0] < 0.05 and local[0] < 0.05  # the large card holds either way
