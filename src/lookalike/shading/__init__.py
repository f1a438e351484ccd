"""The paper's shading: cameras, point lights, the PBR BSDF and the deferred pipeline
``render(asset, camera, light, resolution, spp, layers, background, msaa) -> [B, H, W, 4]``."""

from .camera import Camera, look_at, perspective
from .light import PointLight
from .pipeline import render

__all__ = ["Camera", "PointLight", "look_at", "perspective", "render"]
