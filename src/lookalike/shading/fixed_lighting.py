"""Lighting fixed in the world for a whole run, as a path tracer sees it (paper Sec. 5.5,
"Baking path traced lighting").

A ``FixedLighting`` has two parts: ``emitters``, the lights the path tracer renders (Mitsuba 3
emitter dictionaries: soft area lights, an environment), and ``analytic``, the one point light
our rasterizer computes for every view. What the path tracer shows beyond the analytic light —
soft shadows, the environment's light, light bounced between surfaces — is what a fit learns
into its emission and base colour; the analytic light is what an engine is given to light the
result (``KHR_lights_punctual``).

The studio setup is generated from the object's bounding sphere (centre ``c``, radius ``r``), y
up: a key light (a sphere of radius ``KEY_SIZE r`` at distance ``LIGHT_DISTANCE r``, above and
to the left of the +z side, giving irradiance ``view_sampling.IRRADIANCE`` at ``c``), a dimmer
fill from the other side, a rim light from behind and above, and a uniform sky of radiance
``SKY_RADIANCE``. The lights are black spheres that emit (they reflect nothing), beyond the far
plane of every camera that frames the object. A sphere light of radius ``rho`` and radiance ``L`` has radiant intensity
``I = L pi rho^2`` in every direction, so the key's analytic twin is a point light of that
intensity at its centre.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from .light import PointLight
from .view_sampling import IRRADIANCE

LIGHT_DISTANCE = 4.0
"""Studio lights sit this many bounding radii from the centre."""

KEY_SIZE = 0.25
"""Radius of the studio's sphere lights in bounding radii: shadows with soft edges."""

STUDIO_LIGHTS = (((-0.5, 0.6, 1.0), 1.0), ((0.8, 0.2, 0.3), 0.35), ((0.2, 0.8, -1.0), 0.5))
"""(direction from the centre, irradiance at the centre as a share of the key's) of the key,
the fill and the rim light; the first is the analytic one."""

SKY_RADIANCE = 0.12
"""Radiance of the studio's uniform sky (irradiance ``pi`` times it on an open, upward
surface): the light that reaches into cavities and the undersides, as ambient occlusion."""


@dataclass
class FixedLighting:
    """Lighting that is the same in every view.

    Attributes:
        name: ``"studio"``, or the environment map's file name.
        emitters: Mitsuba 3 emitter dictionaries by name (the path tracer's lights).
        analytic: the point light (batch 1) our rasterizer lights every view with; zero
            intensity where the lighting has no analytic part (an environment map).
    """

    name: str
    emitters: dict
    analytic: PointLight

    def key(self) -> str:
        """What identifies the lighting in a cache key: its name and the analytic light."""
        values = torch.cat([self.analytic.position.reshape(-1), self.analytic.intensity.reshape(-1)])
        return f"{self.name}:{np.asarray(values, dtype=np.float32).tobytes().hex()}"


def studio_lighting(centre, radius: float) -> FixedLighting:
    """The generated studio around the sphere (``centre [3]``, ``radius``): see the module."""
    centre = np.asarray(torch.as_tensor(centre, dtype=torch.float64)).reshape(3)
    distance, size = LIGHT_DISTANCE * radius, KEY_SIZE * radius
    emitters, analytic = {}, None
    for k, (direction, share) in enumerate(STUDIO_LIGHTS):
        unit = np.asarray(direction) / np.linalg.norm(direction)
        position = centre + distance * unit
        intensity = share * IRRADIANCE * distance ** 2
        emitters[f"light_{k}"] = {"type": "sphere", "center": position.tolist(), "radius": size,
                                  "bsdf": {"type": "diffuse", "reflectance": 0.0},
                                  "emitter": {"type": "area", "radiance": {
                                      "type": "rgb", "value": [intensity / (math.pi * size ** 2)] * 3}}}
        if analytic is None:
            analytic = PointLight(position=torch.from_numpy(position[None]).float(),
                                  intensity=torch.full((1, 3), intensity, dtype=torch.float32))
    emitters["sky"] = {"type": "constant", "radiance": {"type": "rgb", "value": [SKY_RADIANCE] * 3}}
    return FixedLighting("studio", emitters, analytic)


def environment_lighting(path: str | Path, centre) -> FixedLighting:
    """An environment map (``.hdr`` or ``.exr``, latitude-longitude, as Mitsuba reads it) at
    infinity; no analytic part (a dark point light at ``centre``): all of its light is learned
    into the emission."""
    centre = torch.as_tensor(centre, dtype=torch.float32).reshape(1, 3)
    return FixedLighting(Path(path).name, {"environment": {"type": "envmap", "filename": str(path)}},
                         PointLight(position=centre.clone(), intensity=torch.zeros(1, 3)))


def point_lighting(light: PointLight) -> FixedLighting:
    """One point light (batch 1) and nothing else: what our rasterizer computes, exactly (the
    conversion's proof)."""
    position, intensity = light.position[0].tolist(), light.intensity[0].tolist()
    return FixedLighting("point", {"point": {"type": "point", "position": position,
                                             "intensity": {"type": "rgb", "value": intensity}}}, light)
