"""Random views for training and scoring (paper Sec. 4: a virtual photo-goniometer).

A view is a camera on a sphere around the asset's bounding sphere, looking at its centre,
uniformly distributed over directions, and one point light whose direction from the centre
is cosine-distributed around the direction to the camera (so that most views are lit from
the front, some at grazing angles).
"""

from __future__ import annotations

import math

import numpy as np
import torch

from ..asset import Mesh
from ..shading.camera import Camera
from ..shading.light import PointLight
from .targets import ViewSampler

FOVY = math.radians(45.0)
"""Vertical field of view of every camera."""

FRAMING = 1.05
"""Camera distance = FRAMING * radius / sin(FOVY / 2): the bounding sphere just fills the picture."""

IRRADIANCE = 3.0
"""Irradiance at the centre, facing the light (a white Lambertian surface reflects ~0.95)."""


def unit_vectors(rng: np.random.Generator, n: int) -> np.ndarray:
    """``[n, 3]`` float64 directions uniform on the unit sphere (normalised Gaussians)."""
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True).clip(min=1e-12)


def cosine_around(rng: np.random.Generator, axis: np.ndarray) -> np.ndarray:
    """``[n, 3]`` unit directions with density cos(theta) / pi around ``axis [n, 3]`` (unit):
    theta = asin(sqrt(u1)), phi = 2 pi u2 in a frame built around each axis."""
    n = axis.shape[0]
    u1, u2 = rng.uniform(size=n), rng.uniform(size=n)
    sin_t, cos_t, phi = np.sqrt(u1), np.sqrt(1 - u1), 2 * np.pi * u2
    helper = np.where(np.abs(axis[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    tangent = np.cross(axis, helper)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    bitangent = np.cross(axis, tangent)
    return (sin_t * np.cos(phi))[:, None] * tangent + (sin_t * np.sin(phi))[:, None] * bitangent + cos_t[:, None] * axis


def view_sampler(mesh: Mesh) -> ViewSampler:
    """Draws ``n`` views of ``mesh`` (see the module docstring): ``(Camera, PointLight)``,
    batches of ``n``, float32, positions in the mesh's frame."""
    centre, radius = mesh.bounding_sphere()
    centre = centre.detach().double().numpy()
    radius = max(float(radius), 1e-12)
    distance = FRAMING * radius / math.sin(FOVY / 2)

    def sample(rng: np.random.Generator, n: int) -> tuple[Camera, PointLight]:
        to_camera = unit_vectors(rng, n)
        to_light = cosine_around(rng, to_camera)
        eye = torch.from_numpy(centre + distance * to_camera).float()
        target = torch.from_numpy(np.broadcast_to(centre, (n, 3)).copy()).float()
        camera = Camera.looking_at(eye, target, fovy=FOVY, near=max(distance - 1.5 * radius, 0.01 * radius),
                                   far=distance + 1.5 * radius)
        light_pos = torch.from_numpy(centre + distance * to_light).float()
        intensity = torch.full((n, 3), IRRADIANCE * distance ** 2)
        return camera, PointLight(position=light_pos, intensity=intensity)

    return sample
