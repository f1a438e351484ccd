"""Random cameras and point lights around an object, as in the paper's virtual
photo-goniometer (Sec. 3): cameras uniformly distributed over the directions around the
object's bounding sphere, looking at its centre; one point light per view whose direction from
the centre is cosine-distributed around the direction to the camera (mostly frontal light,
sometimes grazing). An animated asset's views also draw poses: a clip and a time each
(``random_poses``), or poses spread over every clip (``spread_poses``) for held-out views.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from ..asset.pose import REST, Poses
from .camera import Camera
from .light import PointLight

FOVY = math.radians(45.0)
"""Default vertical field of view."""

FRAMING = 1.05
"""Default camera distance is ``FRAMING * radius / sin(fovy / 2)``: the bounding sphere just
fits the picture vertically."""

IRRADIANCE = 3.0
"""Default irradiance at the centre, facing the light (a white Lambertian surface there
reflects radiance ``3 / pi``, about 0.95)."""

UP = (0.0, 1.0, 0.0)
"""World up (glTF is y-up); it points up in every picture except straight top/bottom views."""


def unit_vectors(rng: np.random.Generator, n: int) -> np.ndarray:
    """``[n, 3]`` float64 directions uniform on the unit sphere (normalised Gaussians)."""
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True).clip(min=1e-12)


def cosine_around(rng: np.random.Generator, axis: np.ndarray) -> np.ndarray:
    """``[n, 3]`` unit directions with density ``cos(theta) / pi`` around unit ``axis [n, 3]``:
    ``theta = asin(sqrt(u1))``, ``phi = 2 pi u2`` in a frame built around each axis."""
    n = axis.shape[0]
    u1, u2 = rng.uniform(size=n), rng.uniform(size=n)
    sin_t, cos_t, phi = np.sqrt(u1), np.sqrt(1.0 - u1), 2.0 * np.pi * u2
    helper = np.where(np.abs(axis[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    tangent = np.cross(axis, helper)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    bitangent = np.cross(axis, tangent)
    return ((sin_t * np.cos(phi))[:, None] * tangent + (sin_t * np.sin(phi))[:, None] * bitangent
            + cos_t[:, None] * axis)


def framing_distance(radius: float, fovy: float = FOVY) -> float:
    """Camera distance at which a sphere of ``radius`` fills the picture (``FRAMING``)."""
    return FRAMING * radius / math.sin(fovy / 2.0)


def random_views(centre, radius: float, n: int, generator: np.random.Generator, fovy: float = FOVY,
                 distance: float | None = None, aspect: float = 1.0, distance_spread: float = 0.0) -> Camera:
    """``n`` cameras at ``distance`` (default ``framing_distance``) from ``centre [3]`` in
    directions uniform on the sphere, looking at it with up ``UP``; near and far planes hug
    the bounding sphere of ``radius``. With ``distance_spread > 0`` each camera's distance is
    scaled by ``2^u``, ``u`` uniform in ``[-spread / 2, spread / 2]`` (drawn after the
    directions, so the directions do not depend on it). Float32."""
    radius = max(float(radius), 1e-12)
    distance = framing_distance(radius, fovy) if distance is None else float(distance)
    centre = torch.as_tensor(centre).detach().double().cpu().numpy()
    directions = unit_vectors(generator, n)
    distances = np.full((n, 1), distance)
    if distance_spread > 0:
        distances *= 2.0 ** generator.uniform(-distance_spread / 2, distance_spread / 2, size=(n, 1))
    eye = torch.from_numpy(centre + distances * directions).float()
    target = torch.from_numpy(np.broadcast_to(centre, (n, 3)).copy()).float()
    return Camera.looking_at(eye, target, up=UP, fovy=fovy, aspect=aspect,
                             near=max(float(distances.min()) - 1.5 * radius, 0.01 * radius),
                             far=float(distances.max()) + 1.5 * radius)


def orbit_views(centre, radius: float, frames: int, degrees: float, elevation_degrees: float = 20.0,
                fovy: float = FOVY) -> tuple[Camera, PointLight]:
    """A slow turn around the object: ``frames`` cameras at ``framing_distance`` from
    ``centre [3]``, ``elevation`` above its horizontal plane, stepping ``degrees / frames``
    about the world's up axis (``UP``) from azimuth 0, and one point light fixed in the world
    (above and to the left of the first camera, irradiance ``IRRADIANCE`` at the centre), so
    that frame-to-frame change comes from the motion alone. Why: flicker (aliasing, sparkle)
    shows between consecutive frames of a slow motion, not in still pictures."""
    radius = max(float(radius), 1e-12)
    distance = framing_distance(radius, fovy)
    centre = torch.as_tensor(centre).detach().double().cpu().numpy()
    azimuth = np.radians(degrees) * np.arange(frames) / frames
    elevation = math.radians(elevation_degrees)
    directions = np.stack([np.cos(elevation) * np.sin(azimuth), np.full(frames, math.sin(elevation)),
                           np.cos(elevation) * np.cos(azimuth)], axis=1)
    eye = torch.from_numpy(centre + distance * directions).float()
    target = torch.from_numpy(np.broadcast_to(centre, (frames, 3)).copy()).float()
    camera = Camera.looking_at(eye, target, up=UP, fovy=fovy, near=max(distance - 1.5 * radius, 0.01 * radius),
                               far=distance + 1.5 * radius)
    towards = np.array([-0.5, 0.6, 1.0]) / np.linalg.norm([-0.5, 0.6, 1.0])
    position = np.broadcast_to(centre + distance * towards, (frames, 3)).copy()
    intensity = np.full((frames, 3), IRRADIANCE * distance ** 2)
    return camera, PointLight(position=torch.from_numpy(position).float(), intensity=torch.from_numpy(intensity).float())


def random_lights(camera: Camera, centre, generator: np.random.Generator, distance: float | None = None,
                  irradiance: float = IRRADIANCE) -> PointLight:
    """One white point light per camera, at ``distance`` (default: the camera's) from
    ``centre [3]``, in a direction cosine-distributed around the direction to the camera;
    intensity ``irradiance * distance^2`` so the irradiance at the centre is ``irradiance``."""
    centre = torch.as_tensor(centre).detach().double().cpu().numpy()
    offset = camera.position.detach().double().cpu().numpy() - centre
    camera_distance = np.linalg.norm(offset, axis=1, keepdims=True).clip(min=1e-12)
    distance = camera_distance if distance is None else np.full_like(camera_distance, float(distance))
    position = centre + distance * cosine_around(generator, offset / camera_distance)
    intensity = np.repeat(irradiance * distance ** 2, 3, axis=1)
    return PointLight(position=torch.from_numpy(position).float(), intensity=torch.from_numpy(intensity).float())


def random_poses(durations: list[float], n: int, generator: np.random.Generator, rest_share: float = 0.0) -> Poses:
    """``n`` poses of an animated asset whose clips last ``durations`` seconds: each the rest
    pose with probability ``rest_share``, else a clip drawn uniformly and a time uniform over
    it (three uniforms per pose, drawn whatever the outcome, so streams stay aligned)."""
    u = generator.uniform(size=(n, 3))
    clip = np.minimum((u[:, 1] * len(durations)).astype(np.int64), len(durations) - 1)
    time = u[:, 2] * np.asarray(durations, dtype=np.float64)[clip]
    rest = u[:, 0] < rest_share
    return Poses.of(np.where(rest, REST, clip), np.where(rest, 0.0, time))


def spread_poses(durations: list[float], n: int, generator: np.random.Generator) -> Poses:
    """``n`` poses spread over every clip (clips lasting ``durations`` seconds): view ``i``
    shows clip ``i mod C`` at a time stratified over it, ``duration * (j + u) / n_c`` for the
    clip's ``j``-th of ``n_c`` views and ``u`` uniform."""
    clips = np.arange(n) % len(durations)
    stratum = np.arange(n) // len(durations)
    per_clip = np.bincount(clips, minlength=len(durations))[clips]
    time = np.asarray(durations, dtype=np.float64)[clips] * (stratum + generator.uniform(size=n)) / per_clip
    return Poses.of(clips, time)
