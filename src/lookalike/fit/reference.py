"""References: what the latent model must look like (paper Sec. 4).

The optimisation treats the reference renderer as a black box: a :class:`Reference` renders
target images for given cameras, lights and, where it moves, poses. :class:`MeshReference` is
an input asset rendered by our own pipeline, supersampled; :class:`SkinnedReference` is an
animated one, posed by its skeleton at each view's clip and time; :class:`FieldReference` is
an implicit surface, sphere-traced. Future references (a path tracer) implement the same
protocol.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
import torch

from ..asset import Asset
from ..asset.pose import REST, Poses
from ..asset.skinning import posed
from ..shading.camera import Camera
from ..shading.light import PointLight
from ..shading.pipeline import FixedAsset, render
from ..shading.relight import CapturedView, capture_view
from ..shading.glsl_tracing import GlslTracer
from ..shading.sphere_tracing import render_field

RENDER_CHUNK = 4
"""Views rendered together over a large batch (bounds the memory of supersampled renders)."""

BOUNDS_TIMES = 16
"""Times per clip at which an animated reference is posed to find the sphere that holds it."""


class Reference(Protocol):
    """A reference renderer."""

    def render(self, camera: Camera, light: PointLight, resolution: int, spp: int,
               pose: Poses | None = None) -> torch.Tensor:
        """``[B, H, W, 4]`` float32 linear RGB (weighted by coverage) and coverage, row 0 at
        the top (H = W = ``resolution``), for B cameras and lights, with ``spp`` x ``spp``
        samples per pixel, in poses ``pose`` (batch B) where the reference moves (an
        animation); no gradients."""
        ...

    def bounding_sphere(self) -> tuple[torch.Tensor, float]:
        """``(centre [3], radius)`` of what it shows (in every pose), in its own frame."""
        ...


class MeshReference:
    """A static asset rendered by ``lookalike.shading.render``, supersampled, with ``layers``
    depth-peeled layers (it does not move: ``pose`` is ignored); what its views share is
    computed once (``FixedAsset``)."""

    def __init__(self, asset: Asset, layers: int = 1):
        self.asset = FixedAsset.of(asset)
        self.layers = layers

    @torch.no_grad()
    def render(self, camera: Camera, light: PointLight, resolution: int, spp: int,
               pose: Poses | None = None) -> torch.Tensor:
        return render(self.asset, camera, light, (resolution, resolution), spp=spp, layers=self.layers)

    def capture(self, camera: Camera, resolution: int, spp: int) -> CapturedView:
        """The view from ``camera`` (batch 1), ready to be lit again (``CapturedView.light``),
        which a still asset allows because its geometry never changes."""
        return capture_view(self.asset, camera, resolution, spp)

    def bounding_sphere(self) -> tuple[torch.Tensor, float]:
        return self.asset.mesh.bounding_sphere()


class SkinnedReference:
    """An animated asset (a skin, its influences and clips), rendered supersampled in the pose
    of each view (``lookalike.asset.skinning.posed``: its file's normals skinned with it, as
    engines and viewers show it); without poses, in the rest pose. The triangles' topology and the texture
    pyramids are shared by every pose; normals, tangents and clip positions are computed per
    pose, at a cost that grows with the input as a render's does."""

    def __init__(self, asset: Asset):
        self.fixed = FixedAsset.of(asset)

    @property
    def asset(self) -> Asset:
        return self.fixed.asset

    @torch.no_grad()
    def render(self, camera: Camera, light: PointLight, resolution: int, spp: int,
               pose: Poses | None = None) -> torch.Tensor:
        pose = Poses.rest(camera.batch_size) if pose is None else pose
        return torch.cat([render(self.fixed.sharing(posed(self.asset, clip, time)), camera[views], light[views],
                                 (resolution, resolution), spp=spp)
                          for views, clip, time in pose.runs()])

    def bounding_sphere(self) -> tuple[torch.Tensor, float]:
        """The sphere around the bounding box of the rest pose and of ``BOUNDS_TIMES`` times of
        every clip (its radius reaches every vertex of those poses)."""
        poses = [(REST, 0.0)] + [(clip, float(t)) for clip, animation in enumerate(self.asset.animations)
                                 for t in np.linspace(0.0, animation.duration, BOUNDS_TIMES)]
        used = self.asset.mesh.t_pos_idx.unique()
        points = torch.cat([posed(self.asset, clip, time).mesh.v_pos[used] for clip, time in poses])
        lo, hi = points.min(dim=0).values, points.max(dim=0).values
        centre = 0.5 * (lo + hi)
        return centre, float((points - centre).norm(dim=-1).max())


class FieldReference:
    """An implicit surface (``lookalike.asset.implicit.ImplicitSurface``) sphere-traced,
    supersampled: in torch (``lookalike.shading.sphere_tracing``), or a GLSL field in OpenGL
    (``lookalike.shading.glsl_tracing``); ``sphere``: the bounding sphere of what it shows (its
    marching-cubes mesh's, tighter than its bounds)."""

    def __init__(self, surface, sphere: tuple[torch.Tensor, float]):
        self.surface, self.sphere = surface, sphere
        self.tracer = GlslTracer(surface) if surface.kind == "glsl" else None

    @torch.no_grad()
    def render(self, camera: Camera, light: PointLight, resolution: int, spp: int,
               pose: Poses | None = None) -> torch.Tensor:
        if self.tracer is not None:
            return self.tracer.render(camera, light, resolution, spp)
        return render_field(self.surface, camera, light, resolution, spp)

    def bounding_sphere(self) -> tuple[torch.Tensor, float]:
        return self.sphere


CHUNK_SAMPLES = RENDER_CHUNK * 4096 ** 2
"""Samples rendered together at most (``RENDER_CHUNK`` views of 512 pixels at 8 x 8 each):
heavily supersampled views are rendered fewer at a time."""


def views_per_chunk(resolution: int, spp: int) -> int:
    """How many views of ``resolution`` pixels at ``spp`` x ``spp`` samples to render together:
    ``RENDER_CHUNK``, fewer where they would exceed ``CHUNK_SAMPLES`` samples, at least one."""
    return max(1, min(RENDER_CHUNK, CHUNK_SAMPLES // (resolution * spp) ** 2))


def render_in_chunks(reference: Reference, camera: Camera, light: PointLight, resolution: int, spp: int,
                     dtype=torch.float32, pose: Poses | None = None) -> torch.Tensor:
    """``reference.render`` over a large batch (poses ``pose`` where given), ``views_per_chunk``
    views at a time, stored as ``dtype``: ``[B, H, W, 4]``."""
    n, chunk = camera.batch_size, views_per_chunk(resolution, spp)
    return torch.cat([reference.render(camera[i:i + chunk], light[i:i + chunk], resolution, spp,
                                       None if pose is None else pose[i:i + chunk]).to(dtype)
                      for i in range(0, n, chunk)])
