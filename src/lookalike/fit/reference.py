"""References: what the latent model must look like (paper Sec. 4).

The optimisation treats the reference renderer as a black box: a :class:`Reference` renders
target images for given cameras and lights. :class:`MeshReference` is an input asset rendered
by our own pipeline, supersampled. Future references (an animated mesh at a time t, a signed
distance field, a path tracer) implement the same protocol.
"""

from __future__ import annotations

from typing import Protocol

import torch

from ..asset import Asset
from ..shading.camera import Camera
from ..shading.light import PointLight
from ..shading.pipeline import FixedAsset, render
from ..shading.relight import CapturedView, capture_view

RENDER_CHUNK = 4
"""Views rendered together over a large batch (bounds the memory of supersampled renders)."""


class Reference(Protocol):
    """A reference renderer."""

    def render(self, camera: Camera, light: PointLight, resolution: int, spp: int,
               time: torch.Tensor | None = None) -> torch.Tensor:
        """``[B, H, W, 4]`` float32 linear RGB (weighted by coverage) and coverage, row 0 at
        the top (H = W = ``resolution``), for B cameras and lights, with ``spp`` x ``spp``
        samples per pixel, at times ``time [B]`` where the reference moves (an animation);
        no gradients."""
        ...

    def bounding_sphere(self) -> tuple[torch.Tensor, float]:
        """``(centre [3], radius)`` of what it shows, in its own frame."""
        ...


class RelightableReference(Reference, Protocol):
    """A reference whose geometry never changes, so one camera's view can be lit again."""

    def capture(self, camera: Camera, resolution: int, spp: int) -> CapturedView:
        """The view from ``camera`` (batch 1), ready to be lit (``CapturedView.light``)."""
        ...


class MeshReference:
    """A static asset rendered by ``lookalike.shading.render``, supersampled (it does not move:
    ``time`` is ignored); what its views share is computed once (``FixedAsset``)."""

    def __init__(self, asset: Asset):
        self.asset = FixedAsset.of(asset)

    @torch.no_grad()
    def render(self, camera: Camera, light: PointLight, resolution: int, spp: int,
               time: torch.Tensor | None = None) -> torch.Tensor:
        return render(self.asset, camera, light, (resolution, resolution), spp=spp)

    def capture(self, camera: Camera, resolution: int, spp: int) -> CapturedView:
        return capture_view(self.asset, camera, resolution, spp)

    def bounding_sphere(self) -> tuple[torch.Tensor, float]:
        return self.asset.mesh.bounding_sphere()


def render_in_chunks(reference: Reference, camera: Camera, light: PointLight, resolution: int, spp: int,
                     dtype=torch.float32) -> torch.Tensor:
    """``reference.render`` over a large batch, ``RENDER_CHUNK`` views at a time, stored as
    ``dtype``: ``[B, H, W, 4]``."""
    n = camera.batch_size
    return torch.cat([reference.render(camera[i:i + RENDER_CHUNK], light[i:i + RENDER_CHUNK], resolution, spp).to(dtype)
                      for i in range(0, n, RENDER_CHUNK)])
