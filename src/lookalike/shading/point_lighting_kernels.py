"""Compiled point lighting of shading points: the paper's BSDF (:mod:`.bsdf`) times a point
light's irradiance (:class:`.light.PointLight`), forward and hand-written backward.

The plain-torch twin is :func:`.point_lighting.lit_radiance_python` (``PointLight.illuminate``,
``below_horizon`` and ``bsdf.shade``); tests compare values and gradients. Per point, with
``o = P - x`` (light position minus surface point), ``d2 = max(o.o, 1e-12)``, ``l = o /
sqrt(d2)``, ``E = I / d2`` (0 where the view tests the horizon and ``g.l <= 0``), ``r =
clamp(ks_1, MIN_ROUGHNESS, 1)``, ``a2 = r^4``, ``h = (v + l) / sqrt(max(|v + l|^2, 1e-12))``:

    radiance_c = E_c (kd_c (1 - m) / pi + F_c D Vis) max(n.l, 0)

with ``F``, ``D``, ``Vis`` as in :mod:`.bsdf`. Clamps pass gradients where their input lies
inside the closed range, as ``torch.clamp`` does. Arithmetic is float64 per point.

The CUDA forms (:mod:`.point_lighting_cuda`) run the same loops over runs of points
(``_forward_run``, ``_backward_run``), each GPU thread on a run of one point.
"""

from __future__ import annotations

import math

from numba import njit, prange

from ..kernel_cache import CACHE
from .bsdf import COSINE_EPSILON, DIELECTRIC_F0, MIN_ROUGHNESS

_TINY = 1e-12  # the floor of |o|^2 and |v + l|^2, as in the torch twin


@njit(cache=CACHE, inline="always")
def _clamp(x, low, high):
    """``(clamp(x, low, high), 1.0 where low <= x <= high else 0.0)``."""
    if x < low:
        return low, 0.0
    if x > high:
        return high, 0.0
    return x, 1.0


@njit(cache=CACHE, inline="always")
def _light(x, light_pos, p, b):
    """``(o, d2, inside, rinv)``: offset to the light ``o [3]`` as a tuple, the clamped squared
    distance, whether the clamp passed (1.0/0.0) and ``1 / sqrt(d2)``."""
    ox = light_pos[b, 0] - x[p, 0]
    oy = light_pos[b, 1] - x[p, 1]
    oz = light_pos[b, 2] - x[p, 2]
    d2, inside = _clamp(ox * ox + oy * oy + oz * oz, _TINY, math.inf)
    return ox, oy, oz, d2, inside, 1.0 / math.sqrt(d2)


@njit(cache=CACHE, inline="always")
def _half(vx, vy, vz, lx, ly, lz):
    """``(h, |v+l|^2 clamp passed, 1/sqrt(clamped |v+l|^2))`` with ``h`` as three floats."""
    hx, hy, hz = vx + lx, vy + ly, vz + lz
    hh, inside = _clamp(hx * hx + hy * hy + hz * hz, _TINY, math.inf)
    hinv = 1.0 / math.sqrt(hh)
    return hx * hinv, hy * hinv, hz * hinv, inside, hinv


@njit(cache=CACHE, inline="always")
def _point(ks, normal, view_dir, position, geometric, light_pos, horizon, p, b):
    """Everything the radiance of point ``p`` under light ``b`` needs besides its base colour:
    ``(below, (o, d2, d2 clamp passed, 1/sqrt(d2)), l, n, v, h, |v+l|^2 clamp passed, 1/|v+l|,
    n.l, (nh, passed, vh, passed, clamped nl, passed, clamped nv, passed), (gamma, metal, r,
    r clamp passed, a2), (den, D, root_v, root_l, Vis, (1 - vh)^5))`` with vectors as 3-tuples
    and ``below`` True where the view tests the horizon and the light is below the surface."""
    ox, oy, oz, d2, d2_inside, rinv = _light(position, light_pos, p, b)
    lx, ly, lz = ox * rinv, oy * rinv, oz * rinv
    below = horizon[b] and geometric[p, 0] * lx + geometric[p, 1] * ly + geometric[p, 2] * lz <= 0.0
    nx, ny, nz = normal[p, 0], normal[p, 1], normal[p, 2]
    vx, vy, vz = view_dir[p, 0], view_dir[p, 1], view_dir[p, 2]
    hx, hy, hz, hh_inside, hinv = _half(vx, vy, vz, lx, ly, lz)
    nl = nx * lx + ny * ly + nz * lz
    rough, rough_inside = _clamp(ks[p, 1], MIN_ROUGHNESS, 1.0)
    a2 = rough * rough * rough * rough
    nh, nh_inside = _clamp(nx * hx + ny * hy + nz * hz, 0.0, 1.0)
    vh, vh_inside = _clamp(vx * hx + vy * hy + vz * hz, 0.0, 1.0)
    nlc, nl_inside = _clamp(nl, COSINE_EPSILON, 1.0)
    nvc, nv_inside = _clamp(nx * vx + ny * vy + nz * vz, COSINE_EPSILON, 1.0)
    den = nh * nh * (a2 - 1.0) + 1.0
    dist = a2 / (math.pi * den * den)
    root_v = math.sqrt(nvc * nvc * (1.0 - a2) + a2)
    root_l = math.sqrt(nlc * nlc * (1.0 - a2) + a2)
    vis = 0.5 / (nlc * root_v + nvc * root_l)
    return (below, (ox, oy, oz, d2, d2_inside, rinv), (lx, ly, lz), (nx, ny, nz), (vx, vy, vz), (hx, hy, hz),
            hh_inside, hinv, nl, (nh, nh_inside, vh, vh_inside, nlc, nl_inside, nvc, nv_inside),
            (ks[p, 0], ks[p, 2], rough, rough_inside, a2), (den, dist, root_v, root_l, vis, (1.0 - vh) ** 5))


@njit(cache=CACHE)
def _forward_run(kd, ks, normal, view_dir, position, geometric, view, light_pos, intensity, horizon, out, start, end):
    """:func:`lit_radiance_forward` for points ``start .. end-1``."""
    shared = light_pos.shape[0] == 1
    for p in range(start, end):
        b = 0 if shared else view[p]
        below, light, _l, _n, _v, _h, _hh, _hinv, nl, _cosines, material, lobe = _point(
            ks, normal, view_dir, position, geometric, light_pos, horizon, p, b)
        if below:
            out[p, 0] = 0.0
            out[p, 1] = 0.0
            out[p, 2] = 0.0
            continue
        d2, cosine = light[3], max(0.0, nl)
        gamma, metal = material[0], material[1]
        dist, vis, schlick = lobe[1], lobe[4], lobe[5]
        f90 = 1.0 - gamma
        for c in range(3):
            f0 = (DIELECTRIC_F0 * (1.0 - metal) + kd[p, c] * metal) * (1.0 - gamma)
            fresnel = f0 + (f90 - f0) * schlick
            bsdf = kd[p, c] * (1.0 - metal) / math.pi + fresnel * dist * vis
            out[p, c] = bsdf * cosine * intensity[b, c] / d2


@njit(cache=CACHE, parallel=True)
def lit_radiance_forward(kd, ks, normal, view_dir, position, geometric, view, light_pos, intensity, horizon, out, runs):
    """``out [N, 3]`` = the radiance above for ``kd, ks, normal, view_dir, position, geometric
    [N, 3]`` and ``view [N]`` int64 (the light of each point: ``light_pos [L, 3]``,
    ``intensity [L, 3]``, ``horizon [L]`` bool, with ``L = 1`` shared by all points), in ``runs``
    contiguous runs of points in parallel."""
    n = kd.shape[0]
    for run in prange(runs):
        _forward_run(kd, ks, normal, view_dir, position, geometric, view, light_pos, intensity, horizon, out,
                     run * n // runs, (run + 1) * n // runs)


@njit(cache=CACHE)
def _backward_run(kd, ks, normal, view_dir, position, geometric, view, light_pos, intensity, horizon, grad_out,
                  grad_kd, grad_ks, grad_normal, grad_view_dir, grad_position, grad_intensity, start, end):
    """:func:`lit_radiance_backward` for points ``start .. end-1``."""
    shared = light_pos.shape[0] == 1
    for p in range(start, end):
        for c in range(3):
            grad_kd[p, c] = 0.0
            grad_ks[p, c] = 0.0
            grad_normal[p, c] = 0.0
            grad_view_dir[p, c] = 0.0
            grad_position[p, c] = 0.0
            grad_intensity[p, c] = 0.0
        b = 0 if shared else view[p]
        below, light, l, n, v, h, hh_inside, hinv, nl, cosines, material, lobe = _point(
            ks, normal, view_dir, position, geometric, light_pos, horizon, p, b)
        if below:
            continue
        ox, oy, oz, d2, d2_inside, rinv = light
        lx, ly, lz = l
        nx, ny, nz = n
        vx, vy, vz = v
        hx, hy, hz = h
        nh, nh_inside, vh, vh_inside, nlc, nl_inside, nvc, nv_inside = cosines
        gamma, metal, rough, rough_inside, a2 = material
        den, dist, root_v, root_l, vis, schlick = lobe
        cosine = max(0.0, nl)
        f90 = 1.0 - gamma
        # back through radiance_c = bsdf_c * cosine * E_c
        g_cosine = 0.0
        g_dist = 0.0
        g_vis = 0.0
        g_schlick = 0.0
        g_gamma = 0.0
        g_metal = 0.0
        g_d2 = 0.0
        for c in range(3):
            irradiance = intensity[b, c] / d2
            f0 = (DIELECTRIC_F0 * (1.0 - metal) + kd[p, c] * metal) * (1.0 - gamma)
            fresnel = f0 + (f90 - f0) * schlick
            bsdf = kd[p, c] * (1.0 - metal) / math.pi + fresnel * dist * vis
            g = grad_out[p, c]
            grad_intensity[p, c] = g * bsdf * cosine / d2
            g_d2 -= g * bsdf * cosine * irradiance / d2
            g_cosine += g * bsdf * irradiance
            g_bsdf = g * cosine * irradiance
            grad_kd[p, c] = g_bsdf * (1.0 - metal) / math.pi
            g_metal -= g_bsdf * kd[p, c] / math.pi
            g_fresnel = g_bsdf * dist * vis
            g_dist += g_bsdf * fresnel * vis
            g_vis += g_bsdf * fresnel * dist
            g_f0 = g_fresnel * (1.0 - schlick)
            g_gamma -= g_fresnel * schlick  # through f90 = 1 - gamma
            g_schlick += g_fresnel * (f90 - f0)
            grad_kd[p, c] += g_f0 * metal * (1.0 - gamma)
            g_metal += g_f0 * (kd[p, c] - DIELECTRIC_F0) * (1.0 - gamma)
            g_gamma -= g_f0 * (DIELECTRIC_F0 * (1.0 - metal) + kd[p, c] * metal)
        # the terms' inputs
        g_vh = -5.0 * (1.0 - vh) ** 4 * g_schlick * vh_inside
        g_den = -2.0 * dist / den * g_dist
        g_a2 = g_dist / (math.pi * den * den) + g_den * nh * nh
        g_nh = g_den * 2.0 * nh * (a2 - 1.0) * nh_inside
        g_lambda = -2.0 * vis * vis * g_vis  # d(0.5 / s) / ds = -2 vis^2
        g_nlc = g_lambda * (root_v + nvc * nlc * (1.0 - a2) / root_l)
        g_nvc = g_lambda * (root_l + nlc * nvc * (1.0 - a2) / root_v)
        g_a2 += g_lambda * (nlc * (1.0 - nvc * nvc) / (2.0 * root_v) + nvc * (1.0 - nlc * nlc) / (2.0 * root_l))
        g_nl = g_nlc * nl_inside + (g_cosine if nl >= 0.0 else 0.0)
        g_nv = g_nvc * nv_inside
        grad_ks[p, 0] = g_gamma
        grad_ks[p, 1] = g_a2 * 4.0 * rough * rough * rough * rough_inside
        grad_ks[p, 2] = g_metal
        # the cosines: nl = n.l, nv = n.v, nh = n.h, vh = v.h
        grad_normal[p, 0] = g_nl * lx + g_nv * vx + g_nh * hx
        grad_normal[p, 1] = g_nl * ly + g_nv * vy + g_nh * hy
        grad_normal[p, 2] = g_nl * lz + g_nv * vz + g_nh * hz
        ghx = g_nh * nx + g_vh * vx
        ghy = g_nh * ny + g_vh * vy
        ghz = g_nh * nz + g_vh * vz
        # h = (v + l) * hinv: d/d(v + l) = (gh - h (h.gh) [clamp passed]) hinv
        hdot = (ghx * hx + ghy * hy + ghz * hz) * hh_inside
        gsx, gsy, gsz = (ghx - hx * hdot) * hinv, (ghy - hy * hdot) * hinv, (ghz - hz * hdot) * hinv
        grad_view_dir[p, 0] = g_nv * nx + g_vh * hx + gsx
        grad_view_dir[p, 1] = g_nv * ny + g_vh * hy + gsy
        grad_view_dir[p, 2] = g_nv * nz + g_vh * hz + gsz
        glx, gly, glz = g_nl * nx + gsx, g_nl * ny + gsy, g_nl * nz + gsz
        # l = o * rinv, rinv = d2^(-1/2), d2 = max(o.o, tiny); E = I / d2
        g_d2 += -0.5 * rinv * rinv * rinv * (glx * ox + gly * oy + glz * oz)
        g_o2 = 2.0 * g_d2 * d2_inside
        grad_position[p, 0] = -(glx * rinv + g_o2 * ox)
        grad_position[p, 1] = -(gly * rinv + g_o2 * oy)
        grad_position[p, 2] = -(glz * rinv + g_o2 * oz)


@njit(cache=CACHE, parallel=True)
def lit_radiance_backward(kd, ks, normal, view_dir, position, geometric, view, light_pos, intensity, horizon, grad_out,
                          grad_kd, grad_ks, grad_normal, grad_view_dir, grad_position, grad_intensity, runs):
    """Gradients of :func:`lit_radiance_forward` for ``grad_out [N, 3]``: overwrite every row of
    ``grad_kd, grad_ks, grad_normal, grad_view_dir, grad_position [N, 3]`` and of
    ``grad_intensity [N, 3]`` (each point's share of its light's intensity gradient; the light
    position's is minus ``grad_position``, summed per light by the caller), in ``runs``
    contiguous runs of points in parallel."""
    n = kd.shape[0]
    for run in prange(runs):
        _backward_run(kd, ks, normal, view_dir, position, geometric, view, light_pos, intensity, horizon, grad_out,
                      grad_kd, grad_ks, grad_normal, grad_view_dir, grad_position, grad_intensity,
                      run * n // runs, (run + 1) * n // runs)
