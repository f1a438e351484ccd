"""Our views in Blender's terms: cameras, point lights and the axes, exactly.

Axes. Our world is the glTF file's (y up); Blender's glTF importer writes a glTF point
``(x, y, z)`` as Blender's ``(x, -z, y)`` (z up). ``GLTF_TO_BLENDER`` is that map as a
``[4, 4]`` matrix ``C``; it is a rotation (det 1), so lengths, angles and handedness are kept.

Cameras. Ours are OpenGL cameras: ``mv`` maps world to view space (x right, y up, looking down
-z) and ``proj = perspective(fovy, aspect, near, far)``. A Blender camera object looks down its
local -z with local y up, the same as OpenGL's view space, so its world matrix is
``C @ inverse(mv)``. The vertical field of view comes back from ``proj[1, 1] = 1 / tan(fovy / 2)``
and the aspect (width / height) from ``proj[1, 1] / proj[0, 0]``; Blender gets ``sensor_fit =
VERTICAL`` and ``angle_y = fovy``, so the picture's height spans ``fovy`` whatever its width.
Clipping distances come back from the depth rows: ``near = P23 / (P22 - 1)``, ``far = P23 / (P22 + 1)``.

Point lights. Ours gives a surface facing it at distance ``d`` the irradiance ``I / d^2``
(``lookalike.shading.light``), so a Lambertian surface of albedo ``a`` reflects radiance
``a I / (pi d^2)``. Cycles renders a point light of power ``P`` watts (radius 0, no soft
falloff) on that surface as ``a P / (4 pi^2 d^2)``; equal radiance needs ``P = 4 pi I``. A
coloured intensity ``I = (r, g, b)`` becomes colour ``I / max(I)`` and power ``4 pi max(I)``.

Environment maps. Mitsuba's ``envmap`` (as our path-traced reference places it) looks a
direction ``(x, y, z)`` of our world up at column ``u = atan2(x, -z) / 2 pi`` (and row
``acos(y) / pi`` from the top); Blender's world texture looks the same direction, ``(x, -z, y)``
in its axes, up at ``u = atan2(z, x) / 2 pi + 1/2``, which is a quarter turn further. A world
texture turned by ``ENVIRONMENT_TURN`` about Blender's z axis lights the model as Mitsuba does.

Poses. A view of an animated model shows clip ``c`` (an index into the glb's animations, the
order ``lookalike.io`` writes ``Asset.animations`` in) at ``t`` seconds; the worker plays the
importer's action of that animation at frame ``t * fps`` (``lookalike.blender.cycles_worker``).
The rest pose (clip ``REST``) is no animation playing.
"""

from __future__ import annotations

import math

import numpy as np

from ..asset.pose import REST

ENVIRONMENT_TURN = math.pi / 2
"""Radians a Blender world texture turns about z to match Mitsuba's ``envmap`` (see the module)."""

GLTF_TO_BLENDER = np.array([
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 0.0, -1.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
])
"""``[4, 4]`` ``C``: glTF ``(x, y, z, 1)`` -> Blender ``(x, -z, y, 1)`` (the glTF importer's axes)."""

ASPECT_TOLERANCE = 1e-3
"""Largest relative difference between a projection's aspect and the picture's width / height."""


def _as_numpy(x) -> np.ndarray:
    """A torch tensor or array-like as a float64 NumPy array."""
    if hasattr(x, "detach"):
        x = x.detach().cpu().numpy()
    return np.asarray(x, dtype=np.float64)


def projection_parameters(proj) -> dict:
    """``fovy`` (radians), ``aspect`` (width / height), ``near`` and ``far`` of one OpenGL
    projection ``proj [4, 4]`` made by ``lookalike.shading.camera.perspective``.

    Raises:
        ValueError: an off-centre (shifted) or non-perspective projection.
    """
    p = _as_numpy(proj)
    if abs(p[0, 2]) > 1e-6 or abs(p[1, 2]) > 1e-6 or abs(p[3, 2] + 1.0) > 1e-6 or abs(p[3, 3]) > 1e-6:
        raise ValueError("only centred perspective projections (gluPerspective) convert to a Blender camera")
    return {"fovy": 2.0 * math.atan(1.0 / p[1, 1]), "aspect": p[1, 1] / p[0, 0],
            "near": p[2, 3] / (p[2, 2] - 1.0), "far": p[2, 3] / (p[2, 2] + 1.0)}


def blender_cameras(camera, width: int, height: int) -> list[dict]:
    """Blender camera settings of B cameras (a ``lookalike.shading.camera.Camera``) for a
    ``width x height`` picture.

    Returns:
        One dict per view: ``matrix_world`` (``[4, 4]`` nested lists, ``C @ inverse(mv)``),
        ``angle_y`` (= fovy, radians), ``clip_start`` and ``clip_end``.
    Raises:
        ValueError: a projection whose aspect is not ``width / height``, or not convertible.
    """
    views = []
    for mv, proj in zip(_as_numpy(camera.mv), _as_numpy(camera.proj)):
        params = projection_parameters(proj)
        if abs(params["aspect"] * height / width - 1.0) > ASPECT_TOLERANCE:
            raise ValueError(f"the projection's aspect {params['aspect']:.4f} is not the picture's "
                             f"{width}/{height} = {width / height:.4f}")
        views.append({"matrix_world": (GLTF_TO_BLENDER @ np.linalg.inv(mv)).tolist(), "angle_y": params["fovy"],
                      "clip_start": params["near"], "clip_end": params["far"]})
    return views


def blender_point_lights(light, count: int) -> list[dict]:
    """Blender point-light settings of the lights of ``count`` views (a
    ``lookalike.shading.light.PointLight``; a batch of 1 is shared by every view).

    Returns:
        One dict per view: ``location`` (Blender axes), ``color`` (``I / max(I)``) and
        ``energy`` in watts (``4 pi max(I)``, 0 with colour white for a dark light).
    """
    position = _as_numpy(light.position).reshape(-1, 3)
    intensity = _as_numpy(light.intensity).reshape(-1, 3)
    if position.shape[0] == 1:
        position, intensity = np.repeat(position, count, 0), np.repeat(intensity, count, 0)
    lights = []
    for p, i in zip(position[:count], intensity[:count]):
        peak = float(i.max())
        colour = (i / peak).tolist() if peak > 0 else [1.0, 1.0, 1.0]
        location = (GLTF_TO_BLENDER[:3, :3] @ p).tolist()
        lights.append({"location": location, "color": colour, "energy": 4.0 * math.pi * max(peak, 0.0)})
    return lights


def blender_poses(pose, count: int) -> list[dict | None]:
    """The poses of ``count`` views (a ``lookalike.asset.pose.Poses``, or ``None``: every view
    in the rest pose).

    Returns:
        One entry per view: ``{"clip": index, "time": seconds}``, or ``None`` for the rest pose.
    """
    if pose is None:
        return [None] * count
    return [None if clip == REST else {"clip": clip, "time": time}
            for clip, time in zip(pose.clip.tolist(), pose.time.tolist())]
