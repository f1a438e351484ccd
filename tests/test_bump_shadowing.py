"""Cycles' bump shadowing in our shading: the term against hand-worked values and finite
differences, and where ``light_points`` applies it (normal-mapped points, in the views that test
the horizon, with ``PointLight.bump_shadowing``)."""

from __future__ import annotations

import math

import numpy as np
import torch

from lookalike.fit.training_views import light_sampler
from lookalike.shading.bump_shadowing import bump_shadowing
from lookalike.shading.camera import Camera, perspective
from lookalike.shading.light import PointLight
from lookalike.shading.points import SurfacePoints, light_points


def _in_xz(degrees: float) -> list[float]:
    """The unit vector ``degrees`` from +z towards +x."""
    return [math.sin(math.radians(degrees)), 0.0, math.cos(math.radians(degrees))]


def test_the_term_is_cycles_masking_of_the_maps_tilt():
    smooth = torch.tensor([[0.0, 0.0, 1.0]] * 4, dtype=torch.float64)
    normal = torch.tensor([_in_xz(30), _in_xz(30), _in_xz(0), _in_xz(30)], dtype=torch.float64)
    light = torch.tensor([_in_xz(60), _in_xz(100), _in_xz(85), _in_xz(80)], dtype=torch.float64)
    factor = bump_shadowing(smooth, normal, light)[:, 0]
    alpha2 = 0.125 * (1 / math.cos(math.radians(30)) ** 2 - 1)                # the map tilts 30 degrees
    expected = 2 / (1 + math.sqrt(1 + alpha2 * 3))                            # cos_i = 0.5: tan^2 = 3
    assert math.isclose(float(factor[0]), expected, rel_tol=1e-12) and 0.95 < expected < 0.99
    assert float(factor[1]) == 0.0                                            # the light is below the smooth surface, the map faces it
    assert float(factor[2]) == 1.0                                            # a map that does not tilt
    assert 0.0 < float(factor[3]) < float(factor[0]) - 0.1                    # nearer the terminator: softened more


def test_the_term_has_the_gradients_of_its_formula():
    generator = torch.Generator().manual_seed(4)

    def unit(x):
        return x / x.norm(dim=-1, keepdim=True)

    smooth = unit(torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64) + 0.1 * torch.randn(16, 3, generator=generator,
                                                                                       dtype=torch.float64))
    normal = unit(smooth + 0.4 * torch.randn(16, 3, generator=generator, dtype=torch.float64))
    light = unit(smooth + 0.8 * torch.randn(16, 3, generator=generator, dtype=torch.float64))
    keep = ((smooth * light).sum(-1) * (smooth * normal).sum(-1) * (normal * light).sum(-1)) > 0.02
    inputs = [x[keep].clone().requires_grad_(True) for x in (smooth, normal, light)]
    assert inputs[0].shape[0] >= 8
    assert torch.autograd.gradcheck(bump_shadowing, inputs)


def _points(mapped: list[bool]) -> SurfacePoints:
    """Points at the origin lit from ``_in_xz(80)``: facets facing the light (the facet horizon
    test passes), smooth normals tilted away from it, normal maps turned back towards it."""
    count = len(mapped)

    def rows(vector):
        return torch.tensor([vector] * count)

    return SurfacePoints(view=torch.zeros(count, dtype=torch.int64), position=torch.zeros(count, 3),
                         normal=rows(_in_xz(40)), geometric_normal=rows(_in_xz(20)), view_dir=rows(_in_xz(0)),
                         kd=torch.full((count, 3), 0.5), ks=rows([1.0, 1.0, 0.0]), emissive=None,
                         alpha=torch.ones(count, 1), smooth_normal=rows(_in_xz(-20)), mapped=torch.tensor(mapped))


def test_light_points_shades_with_it_only_where_the_light_asks_for_it():
    points = _points([True, False])
    position = torch.tensor([_in_xz(80)]) * 3.0
    intensity = torch.ones(1, 3) * 9.0

    def lit(horizon: bool, bump: bool) -> torch.Tensor:
        light = PointLight(position=position, intensity=intensity, horizon=torch.tensor([horizon]), bump_shadowing=bump)
        return light_points(points, light)[:, :3]

    engine, offline, cycles = lit(False, True), lit(True, False), lit(True, True)
    assert (engine > 0).all() and torch.equal(engine, offline)                # the facet faces the light: lit either way
    assert torch.equal(cycles[0], torch.zeros(3))                              # the smooth surface under the map does not
    assert torch.equal(cycles[1], engine[1])                                   # a point without a normal map is unchanged


def test_sampled_lights_carry_the_convention_through_batches():
    eye = torch.tensor([[0.0, 0.0, 5.0]]).expand(6, 3).clone()
    camera = Camera(mv=torch.eye(4).expand(6, 4, 4).clone(), proj=perspective(0.8, 1.0, 0.1, 10.0).expand(6, 4, 4).clone(),
                    position=eye)
    light = light_sampler(torch.zeros(3), 0.5, bump_shadowing=True)(np.random.default_rng(0), camera)
    assert light.bump_shadowing and light.horizon.any() and not light.horizon.all()
    assert light[1:3].bump_shadowing and PointLight.cat([light[:2], light[2:]]).bump_shadowing
    assert not light_sampler(torch.zeros(3), 0.5)(np.random.default_rng(0), camera).bump_shadowing
