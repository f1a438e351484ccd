"""Random training and held-out views of an asset: cameras around its bounding sphere and a
cosine-distributed point light per view (``lookalike.shading.views``)."""

from __future__ import annotations

import numpy as np

from ..asset import Mesh
from ..shading.camera import Camera
from ..shading.light import PointLight
from ..shading.views import random_lights, random_views
from .targets import ViewSampler


def view_sampler(mesh: Mesh) -> ViewSampler:
    """``sample(rng, n) -> (Camera, PointLight)``: ``n`` random views of ``mesh``'s bounding
    sphere, drawn from ``rng`` (cameras first, then lights)."""
    centre, radius = mesh.bounding_sphere()

    def sample(rng: np.random.Generator, n: int) -> tuple[Camera, PointLight]:
        camera = random_views(centre, radius, n, rng)
        return camera, random_lights(camera, centre, rng)

    return sample
