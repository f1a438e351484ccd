"""The BSDF against a plain per-pixel NumPy implementation written from the formulas, and its
behaviour at grazing and back-facing configurations."""

from __future__ import annotations

import math

import numpy as np
import torch

from lookalike.shading import bsdf


def reference_pixel(kd, ks, n, v, l):
    """One pixel of the paper's model, written out term by term with NumPy scalars."""
    gamma, r, m = ks
    r = max(r, 0.08)
    a2 = r ** 4
    nl = float(np.dot(n, l))
    if nl <= 0:
        return np.zeros(3)
    nv = min(max(float(np.dot(n, v)), 1e-4), 1.0)
    h = (v + l) / np.linalg.norm(v + l)
    nh = min(max(float(np.dot(n, h)), 0.0), 1.0)
    vh = min(max(float(np.dot(v, h)), 0.0), 1.0)
    nl_c = min(max(nl, 1e-4), 1.0)
    D = a2 / (math.pi * (nh * nh * (a2 - 1) + 1) ** 2)
    # Smith height-correlated G2 = 1 / (1 + Lambda(v) + Lambda(l)), Lambda(x) = (sqrt(1 + a2 tan^2) - 1) / 2.
    lam_v = (math.sqrt(1 + a2 * (1 - nv * nv) / (nv * nv)) - 1) / 2
    lam_l = (math.sqrt(1 + a2 * (1 - nl_c * nl_c) / (nl_c * nl_c)) - 1) / 2
    G = 1 / (1 + lam_v + lam_l)
    f0 = (0.04 * (1 - m) + kd * m) * (1 - gamma)
    F = f0 + ((1 - gamma) - f0) * (1 - vh) ** 5
    specular = F * D * G / (4 * nl_c * nv)
    diffuse = kd * (1 - m) / math.pi
    return (diffuse + specular) * nl


def random_unit(rng, count):
    x = rng.normal(size=(count, 3))
    return x / np.linalg.norm(x, axis=-1, keepdims=True)


def test_matches_per_pixel_numpy():
    rng = np.random.default_rng(1)
    count = 400
    kd = rng.uniform(0, 1, (count, 3))
    ks = rng.uniform(0, 1, (count, 3))
    ks[:50, 1] = 0.01  # below the minimum roughness
    n = random_unit(rng, count)
    # Viewer and light mostly above the surface, some below.
    v = random_unit(rng, count) + 0.8 * n
    l = random_unit(rng, count) + 0.5 * n
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    l /= np.linalg.norm(l, axis=-1, keepdims=True)
    expected = np.stack([reference_pixel(kd[i], ks[i], n[i], v[i], l[i]) for i in range(count)])
    t = lambda a: torch.from_numpy(a)  # noqa: E731
    got = bsdf.shade(t(kd), t(ks), t(n), t(v), t(l)).numpy()
    assert (expected > 0).any() and (expected == 0).any()
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-12)


def test_energy_and_terms():
    # White Lambertian, light and view along the normal: radiance per irradiance = 1/pi.
    n = torch.tensor([0.0, 0.0, 1.0])
    kd, ks = torch.ones(3), torch.tensor([1.0, 0.5, 0.0])  # gamma = 1 removes the specular lobe
    assert torch.allclose(bsdf.shade(kd, ks, n, n, n), torch.full((3,), 1 / math.pi))
    # A metal has no diffuse term and a specular colour equal to kd.
    kd = torch.tensor([0.9, 0.5, 0.1])
    assert torch.allclose(bsdf.diffuse_colour(kd, torch.tensor([0.0, 0.3, 1.0])), torch.zeros(3))
    assert torch.allclose(bsdf.specular_colour(kd, torch.tensor([0.0, 0.3, 1.0])), kd)
    assert torch.allclose(bsdf.specular_colour(kd, torch.tensor([0.5, 0.3, 0.0])), torch.full((3,), 0.02))
    # GGX D integrates to 1 over the hemisphere of projected half vectors: int D nh dw = 1.
    theta = torch.linspace(0, math.pi / 2, 200001, dtype=torch.float64)
    alpha2 = torch.tensor(0.3 ** 4, dtype=torch.float64)
    integrand = bsdf.ggx_distribution(alpha2, torch.cos(theta)) * torch.cos(theta) * torch.sin(theta) * 2 * math.pi
    assert abs(torch.trapezoid(integrand, theta).item() - 1.0) < 1e-3


def test_no_nans_at_grazing_and_back_facing():
    n = torch.tensor([[0.0, 0.0, 1.0]]).expand(6, 3)
    v = torch.tensor([[1.0, 0, 0], [0, 0, -1], [0, 0, 1], [1, 0, 0], [0, 1, 0], [0.6, 0, 0.8]])
    l = torch.tensor([[1.0, 0, 0], [0, 0, 1], [0, 0, -1], [-1, 0, 0], [0, -1, 0], [-0.6, 0, 0.8]])
    kd = torch.full((6, 3), 0.5, requires_grad=True)
    ks = torch.tensor([[0.0, 0.0, 0.5]]).expand(6, 3).clone().requires_grad_(True)
    normal = n.clone().requires_grad_(True)
    out = bsdf.shade(kd, ks, normal, v, l)
    assert torch.isfinite(out).all() and (out >= 0).all()
    assert torch.equal(out[2], torch.zeros(3))  # light below the surface
    out.sum().backward()
    for g in (kd.grad, ks.grad, normal.grad):
        assert torch.isfinite(g).all()


def test_gradient_matches_finite_differences():
    rng = np.random.default_rng(2)
    count = 8
    n = torch.from_numpy(random_unit(rng, count))
    v = torch.nn.functional.normalize(torch.from_numpy(random_unit(rng, count)) + n, dim=-1)
    l = torch.nn.functional.normalize(torch.from_numpy(random_unit(rng, count)) + n, dim=-1)
    kd = torch.from_numpy(rng.uniform(0.1, 0.9, (count, 3))).requires_grad_(True)
    ks = torch.from_numpy(rng.uniform(0.2, 0.8, (count, 3))).requires_grad_(True)
    assert torch.autograd.gradcheck(lambda a, b: bsdf.shade(a, b, n, v, l), (kd, ks))
