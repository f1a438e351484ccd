"""The compiled shading normals (normal mapping, back-face flip, bend towards the viewer)
against their plain-torch twin: values, gradients, finite differences."""

from __future__ import annotations

import torch

from lookalike.shading.normal_map import (
    BEND_THRESHOLD,
    shading_normal,
    shading_normal_python,
)


def _unit(x: torch.Tensor) -> torch.Tensor:
    return x / x.norm(dim=-1, keepdim=True)


def _points(count: int, seed: int = 0):
    """Interpolated normals of varying length, tangents of both handedness, normal-map values
    tilted up to about 60 degrees, half the points mapped, view directions from every side
    (so some shading normals face away and get bent), geometric normals near the normals."""
    generator = torch.Generator().manual_seed(seed)

    def randn(*shape):
        return torch.randn(*shape, generator=generator, dtype=torch.float64)

    normal = _unit(randn(count, 3)) * (0.5 + torch.rand(count, 1, generator=generator, dtype=torch.float64))
    tangent = torch.cat([randn(count, 3), torch.where(randn(count, 1) < 0, -1.0, 1.0)], dim=1)
    tangent_space = _unit(randn(count, 3) * torch.tensor([0.6, 0.6, 0.0], dtype=torch.float64)
                          + torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64))
    mapped = torch.rand(count, generator=generator) < 0.5
    geometric = _unit(_unit(normal) + 0.4 * randn(count, 3))
    view_dir = _unit(randn(count, 3))
    facing = torch.where((geometric * view_dir).sum(-1) >= 0, 1.0, -1.0).to(torch.float64)
    return normal, tangent, tangent_space, mapped, geometric, view_dir, facing


def test_matches_torch_twin_values_and_gradients():
    normal, tangent, tangent_space, mapped, geometric, view_dir, facing = _points(4000)
    grad_out = torch.randn(4000, 3, dtype=torch.float64)
    results = []
    for op in (shading_normal, shading_normal_python):
        leaves = [t.clone().requires_grad_(True) for t in (normal, tangent, tangent_space, geometric, view_dir)]
        out = op(leaves[0], leaves[1], leaves[2], mapped, leaves[3], leaves[4], facing)
        results.append((out, torch.autograd.grad(out, leaves, grad_out)))
    (fast, fast_grads), (slow, slow_grads) = results
    cosine = ((slow - facing[:, None] * geometric) ** 2).sum(-1)
    assert (cosine < 1e-20).any() and (cosine > 1e-6).sum() > 1000  # bent fully back, and kept
    assert (facing < 0).any() and mapped.any() and (~mapped).any()
    torch.testing.assert_close(fast, slow, rtol=1e-12, atol=1e-13)
    for name, got, expected in zip(("normal", "tangent", "tangent_space", "geometric", "view_dir"), fast_grads, slow_grads):
        assert expected.abs().max() > 0, name
        torch.testing.assert_close(got, expected, rtol=1e-10, atol=1e-10, msg=name)


def test_unmapped_points_are_the_bent_interpolated_normal():
    normal, tangent, tangent_space, _, geometric, view_dir, facing = _points(200, seed=1)
    view_dir = _unit(facing[:, None] * _unit(normal) + 0.1 * view_dir)  # well in front: no bend
    out = shading_normal(normal, tangent, tangent_space, torch.zeros(200, dtype=torch.bool), geometric, view_dir, facing)
    kept = (facing[:, None] * _unit(normal) * view_dir).sum(-1) >= BEND_THRESHOLD
    assert kept.sum() > 100
    torch.testing.assert_close(out[kept], facing[kept, None] * _unit(normal[kept]))


def test_gradients_agree_with_finite_differences():
    normal, tangent, tangent_space, mapped, geometric, view_dir, facing = _points(24, seed=2)

    def shade(normal, tangent, tangent_space, geometric, view_dir):
        return shading_normal(normal, tangent, tangent_space, mapped, geometric, view_dir, facing)

    leaves = [t.clone().requires_grad_(True) for t in (normal, tangent, tangent_space, geometric, view_dir)]
    assert torch.autograd.gradcheck(shade, leaves, eps=1e-6, atol=1e-6)
