"""The compiled point lighting (BSDF x irradiance) against its plain-torch twin: values,
gradients to every input (light position and intensity included) and finite differences."""

from __future__ import annotations

import pytest
import torch

from lookalike.shading.bsdf import MIN_ROUGHNESS
from lookalike.shading.light import PointLight
from lookalike.shading.point_lighting import lit_radiance, lit_radiance_python


def _unit(x: torch.Tensor) -> torch.Tensor:
    return x / x.norm(dim=-1, keepdim=True)


def _points(count: int, views: int, dtype=torch.float64, seed: int = 0):
    """Random shading points: viewers and lights mostly above the surface, some below, some
    roughness below the minimum, geometric normals near the shading ones; the views' lights
    test the horizon in turn."""
    generator = torch.Generator().manual_seed(seed)

    def randn(*shape):
        return torch.randn(*shape, generator=generator, dtype=dtype)

    normal = _unit(randn(count, 3))
    view_dir = _unit(normal + 0.7 * randn(count, 3))
    kd = torch.rand(count, 3, generator=generator, dtype=dtype)
    ks = torch.rand(count, 3, generator=generator, dtype=dtype)
    ks[: count // 8, 1] = 0.5 * MIN_ROUGHNESS
    position = randn(count, 3)
    geometric = _unit(normal + 0.3 * randn(count, 3))
    view = torch.randint(0, views, (count,), generator=generator)
    light = PointLight(position=3 * randn(views, 3), intensity=10 * torch.rand(views, 3, generator=generator, dtype=dtype),
                       horizon=torch.arange(views) % 2 == 0)
    return [kd, ks, normal, view_dir, position], geometric, view, light


def _both(inputs, geometric, view, light, grad_out):
    """Values and gradients (to the five point inputs, then the light's position and
    intensity) of the compiled op and of its twin."""
    results = []
    for op in (lit_radiance, lit_radiance_python):
        leaves = [t.clone().requires_grad_(True) for t in inputs]
        light_leaves = [light.position.clone().requires_grad_(True), light.intensity.clone().requires_grad_(True)]
        out = op(*leaves, geometric, view, PointLight(*light_leaves, light.horizon))
        results.append((out, torch.autograd.grad(out, leaves + light_leaves, grad_out)))
    return results


@pytest.mark.parametrize("views", [1, 3])
def test_matches_torch_twin_values_and_gradients(views):
    inputs, geometric, view, light = _points(3000, views)
    grad_out = torch.rand(3000, 3, dtype=torch.float64)
    (fast, fast_grads), (slow, slow_grads) = _both(inputs, geometric, view, light, grad_out)
    dark = (slow == 0).all(-1)
    assert dark.any() and (~dark).sum() > 1000  # lights below the surface or its horizon, and lit points
    torch.testing.assert_close(fast, slow, rtol=1e-12, atol=1e-13)
    for name, got, expected in zip(("kd", "ks", "normal", "view_dir", "position", "light position", "intensity"),
                                   fast_grads, slow_grads):
        assert expected.abs().max() > 0, name
        torch.testing.assert_close(got, expected, rtol=1e-10, atol=1e-10, msg=name)


def test_horizon_darkens_points_whose_surface_faces_away_from_the_light():
    inputs, geometric, view, light = _points(500, 1)
    light = PointLight(light.position, light.intensity, torch.tensor([True]))
    open_sky = PointLight(light.position, light.intensity, None)
    below = (geometric * (light.position - inputs[4])).sum(-1) <= 0
    tested, untested = lit_radiance(*inputs, geometric, view, light), lit_radiance(*inputs, geometric, view, open_sky)
    assert below.any() and (untested[below] > 0).any()
    assert (tested[below] == 0).all()
    torch.testing.assert_close(tested[~below], untested[~below])


def test_float32_inputs_agree_with_the_float64_twin():
    inputs, geometric, view, light = _points(2000, 2)
    expected = lit_radiance_python(*inputs, geometric, view, light)
    single = [t.float() for t in inputs]
    light32 = PointLight(light.position.float(), light.intensity.float(), light.horizon)
    got = lit_radiance(*single, geometric.float(), view, light32)
    assert got.dtype == torch.float32
    torch.testing.assert_close(got.double(), expected, rtol=1e-4, atol=1e-5)


def test_gradients_agree_with_finite_differences():
    inputs, geometric, view, light = _points(24, 2, seed=3)

    def radiance(kd, ks, normal, view_dir, position, light_position, intensity):
        return lit_radiance(kd, ks, normal, view_dir, position, geometric, view,
                            PointLight(light_position, intensity, light.horizon))

    leaves = [t.clone().requires_grad_(True) for t in [*inputs, light.position, light.intensity]]
    assert torch.autograd.gradcheck(radiance, leaves, eps=1e-6, atol=1e-6)
