"""The light leaving points of an asset's surface, path traced by Mitsuba 3: what a camera sees
there, averaged over the directions it may be seen from. An unlit model carries one colour per
texel whatever the view, and the colour that best matches every view is this mean.

For a point ``p`` with outward normal ``n``, ``S`` directions ``w_s`` are drawn cosine-weighted
about ``n`` (a view sees a patch in proportion to its projected area, ``cos theta``, so views
from a sphere of directions weight it so), and a camera ray from ``p + delta w_s`` towards
``-w_s`` is traced through the scene as a view's would be (``lit`` plus ``glow``,
``lookalike.shading.path_tracing``):

    L(p) = (1 / S) sum_s L_o(p, w_s)  ~  (1 / pi) int L_o(p, w) cos(theta) dw.

``delta`` is small beside the asset (``RAY_OFFSET`` of its radius), so the ray meets ``p``'s own
surface before anything else. The rays of many points go to Mitsuba together, one wavefront of at
most ``RAYS_PER_CALL``, which is what makes its LLVM variant fast; the scalar variant traces one
ray per call from Python and is refused here.
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError
from ..io.mitsuba_runtime import mitsuba
from .path_tracing import TracedScene

RAY_OFFSET = 1e-4
"""How far above a point its rays start, as a share of the asset's bounding radius."""

RAYS_PER_CALL = 1 << 22
"""Rays traced in one Mitsuba call at most (its memory grows with the wavefront)."""


def cosine_directions(normals: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """``[N, 3]`` unit directions, each drawn cosine-weighted about its unit ``normals [N, 3]``
    (Malley's method: a uniform point on the unit disc lifted onto the hemisphere)."""
    u1, u2 = rng.random(len(normals)), rng.random(len(normals))
    radius, angle = np.sqrt(u1), 2.0 * np.pi * u2
    helper = np.where(np.abs(normals[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    tangent = np.cross(normals, helper)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    bitangent = np.cross(normals, tangent)
    return ((radius * np.cos(angle))[:, None] * tangent + (radius * np.sin(angle))[:, None] * bitangent
            + np.sqrt(np.clip(1.0 - u1, 0.0, 1.0))[:, None] * normals)


def _traced(mi, scene, origins: np.ndarray, directions: np.ndarray, seed: int) -> np.ndarray:
    """``[M, 3]`` radiance of the camera rays ``(origins, directions) [M, 3]`` in a Mitsuba
    ``scene``, one sample each, seeded by ``seed``."""
    import drjit as dr

    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(seed, len(origins))
    ray = mi.Ray3f(o=mi.Point3f(*(mi.Float(origins[:, k].astype(np.float32)) for k in range(3))),
                   d=mi.Vector3f(*(mi.Float(directions[:, k].astype(np.float32)) for k in range(3))))
    radiance, _, _ = scene.integrator().sample(scene, sampler, ray, None, True)
    dr.eval(radiance)
    return np.array(radiance, dtype=np.float32).T.reshape(-1, 3)


def mean_outgoing_radiance(scene: TracedScene, points: np.ndarray, normals: np.ndarray, samples: int,
                           radius: float, seed: int = 0) -> np.ndarray:
    """``[N, 3]`` float32 linear radiance leaving ``points [N, 3]`` (on the surface of the asset
    in ``scene``, ``mitsuba_scene``), averaged over ``samples`` cosine-weighted directions about
    their unit outward ``normals [N, 3]`` (see the module); ``radius`` is the asset's bounding
    radius. Same ``seed``, same values. ``ConfigError`` where Mitsuba runs its scalar variant."""
    mi = mitsuba()
    if not mi.variant().startswith("llvm"):
        raise ConfigError("baking path-traced light onto texels needs Mitsuba's LLVM variant (Debian's libllvm19; "
                          f"this process runs {mi.variant()})")
    points, normals = np.asarray(points, np.float64), np.asarray(normals, np.float64)
    total = np.zeros((len(points), 3), np.float64)
    per_call = max(1, RAYS_PER_CALL // max(int(samples), 1))
    rng = np.random.default_rng((seed, 0x5EED))
    for call, start in enumerate(range(0, len(points), per_call)):
        chunk = slice(start, start + per_call)
        where = np.repeat(points[chunk], samples, axis=0)
        towards = cosine_directions(np.repeat(normals[chunk], samples, axis=0), rng)
        origins, directions = where + RAY_OFFSET * radius * towards, -towards
        radiance = sum(_traced(mi, part, origins, directions, int(seed) * 7919 + 2 * call + k)
                       for k, part in enumerate((scene.lit, scene.glow)) if part is not None)
        total[chunk] = radiance.reshape(-1, samples, 3).mean(axis=1)
    return total.astype(np.float32)
