"""References: what the latent model must look like (paper Sec. 4).

The optimisation treats the reference renderer as a black box: a :class:`Reference` renders
target images for given cameras, lights and, where it moves, poses. :class:`MeshReference` is
an input asset rendered by our own pipeline, supersampled; :class:`SkinnedReference` is an
animated one, posed by its skeleton at each view's clip and time; :class:`FieldReference` is
an implicit surface, sphere-traced; :class:`PathTracedReference` is an asset path traced under
fixed lighting.
"""

from __future__ import annotations

import hashlib
import time
from pathlib import Path
from typing import Protocol

import numpy as np
import torch

from ..asset import Asset
from ..asset.pose import REST, Poses
from ..asset.skinning import posed
from ..devices import CPU, moved
from ..io.atomic import save_array_atomic
from ..io.mitsuba_runtime import mitsuba
from ..shading.camera import Camera
from ..shading.fixed_lighting import FixedLighting
from ..shading.glsl_tracing import GlslTracer
from ..shading.light import PointLight
from ..shading.path_tracing import mitsuba_scene, render_path_traced
from ..shading.pipeline import FixedAsset, render
from ..shading.relight import CapturedView, capture_view
from ..shading.shadow_maps import ShadowMapping
from ..shading.sphere_tracing import render_field

RENDER_CHUNK = 4
"""Views rendered together over a large batch (bounds the memory of supersampled renders)."""

BOUNDS_TIMES = 16
"""Times per clip at which an animated reference is posed to find the sphere that holds it."""


class Reference(Protocol):
    """A reference renderer.

    Attributes:
        fixed_light: where the reference lights every view itself (a path tracer's fixed
            lighting), the point light (batch 1) the views' lights must be, its analytic part;
            ``None`` where the views draw their lights and the reference renders under them.
    """

    fixed_light: PointLight | None

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
    depth-peeled layers, shadowing itself as ``shadows`` says (``None``: no shadows); it does
    not move (``pose`` is ignored); what its views share is computed once (``FixedAsset``)."""

    fixed_light = None

    def __init__(self, asset: Asset, layers: int = 1, shadows: ShadowMapping | None = None):
        self.asset = FixedAsset.of(asset)
        self.layers = layers
        self.shadows = shadows

    @torch.no_grad()
    def render(self, camera: Camera, light: PointLight, resolution: int, spp: int,
               pose: Poses | None = None) -> torch.Tensor:
        return render(self.asset, camera, light, (resolution, resolution), spp=spp, layers=self.layers,
                      shadows=self.shadows)

    def to(self, device) -> MeshReference:
        """This reference with its asset on ``device``, where its renders then run."""
        return MeshReference(moved(self.asset.asset, device), self.layers, moved(self.shadows, device))

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
    pose, at a cost that grows with the input as a render's does. It shadows itself as
    ``shadows`` says (``None``: no shadows)."""

    fixed_light = None

    def __init__(self, asset: Asset, shadows: ShadowMapping | None = None):
        self.fixed = FixedAsset.of(asset)
        self.shadows = shadows

    @property
    def asset(self) -> Asset:
        return self.fixed.asset

    def to(self, device) -> SkinnedReference:
        """This reference with its asset on ``device``, where its renders then run."""
        return SkinnedReference(moved(self.asset, device), moved(self.shadows, device))

    @torch.no_grad()
    def render(self, camera: Camera, light: PointLight, resolution: int, spp: int,
               pose: Poses | None = None) -> torch.Tensor:
        pose = Poses.rest(camera.batch_size) if pose is None else pose
        return torch.cat([render(self.fixed.sharing(posed(self.asset, clip, time)), camera[views], light[views],
                                 (resolution, resolution), spp=spp, shadows=self.shadows)
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


class ReferenceOn:
    """``reference`` drawing for a run on ``device``: one that can move (``to``: a still or
    animated asset) is moved there once and renders there, any other (a field, a path tracer)
    renders where it is; either way the views it is given are moved to where it renders and its
    images returned on ``device``, and its bounding sphere on the CPU, where views are drawn.
    Everything else is the wrapped reference's."""

    def __init__(self, reference: Reference, device: torch.device):
        movable = hasattr(reference, "to")
        self.wrapped = reference.to(device) if movable else reference
        self.device, self.renders_on = device, device if movable else torch.device(CPU)

    def render(self, camera: Camera, light: PointLight, resolution: int, spp: int,
               pose: Poses | None = None) -> torch.Tensor:
        camera, light, pose = moved((camera, light, pose), self.renders_on)
        return self.wrapped.render(camera, light, resolution, spp, pose).to(self.device)

    def capture(self, camera: Camera, resolution: int, spp: int) -> CapturedView:
        return self.wrapped.capture(moved(camera, self.renders_on), resolution, spp)

    def bounding_sphere(self) -> tuple[torch.Tensor, float]:
        return moved(self.wrapped.bounding_sphere(), torch.device(CPU))

    def __getattr__(self, name: str):
        return getattr(self.wrapped, name)


def reference_on(reference: Reference, device: torch.device) -> Reference:
    """``reference`` for a run on ``device``: itself on the CPU, else ``ReferenceOn``."""
    return reference if device.type == "cpu" else ReferenceOn(reference, device)


class FieldReference:
    """An implicit surface (``lookalike.asset.implicit.ImplicitSurface``) sphere-traced,
    supersampled: in torch (``lookalike.shading.sphere_tracing``), or a GLSL field in OpenGL
    (``lookalike.shading.glsl_tracing``); ``sphere``: the bounding sphere of what it shows (its
    marching-cubes mesh's, tighter than its bounds)."""

    fixed_light = None

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


class PathTracedReference:
    """An asset path traced by Mitsuba 3 under fixed ``lighting``
    (``lookalike.shading.path_tracing``), ``spp`` samples per pixel, paths of at most
    ``max_depth`` vertices; the lights ``render`` is given are ignored (the lighting is its own,
    and ``fixed_light``, its analytic part, is what the views' lights must be). Every view is
    rendered once: kept in ``cache`` (a folder, or ``None``) under a hash of the asset, the
    lighting, the samples and the camera, as float16, so that a resumed run, or a run of the same
    input and lighting into the same folder, never renders it again (a view is returned as
    stored either way, so a resumed run is bit-exact).

    Attributes:
        rendered, loaded: views path traced and views read from the cache so far.
        seconds: wall seconds spent path tracing.
    """

    def __init__(self, asset: Asset, lighting: FixedLighting, spp: int, max_depth: int, cache: Path | None,
                 seed: int = 0):
        self.asset, self.lighting, self.spp, self.max_depth, self.cache, self.seed = (
            asset, lighting, spp, max_depth, cache, seed)
        light = lighting.analytic
        self.fixed_light = PointLight(position=light.position, intensity=light.intensity,
                                      horizon=torch.ones(1, dtype=torch.bool))
        self.variant = mitsuba().variant()  # fails at once where Mitsuba is not installed
        self.key = f"{asset.fingerprint()}:{lighting.key()}:{spp}:{max_depth}:{seed}"
        self.rendered = self.loaded = 0
        self.seconds = 0.0
        self._scene = None

    @property
    def scene(self):
        """The Mitsuba scene, built at the first view that is not in the cache."""
        if self._scene is None:
            self._scene = mitsuba_scene(self.asset, self.lighting, self.max_depth)
        return self._scene

    def _path(self, camera: Camera, resolution: int) -> Path | None:
        if self.cache is None:
            return None
        digest = hashlib.sha256(self.key.encode() + str(resolution).encode()
                                + np.asarray(camera.mv.detach().cpu(), dtype=np.float32).tobytes()
                                + np.asarray(camera.proj.detach().cpu(), dtype=np.float32).tobytes()).hexdigest()
        return self.cache / f"{digest[:32]}.npy"

    @torch.no_grad()
    def render(self, camera: Camera, light: PointLight, resolution: int, spp: int,
               pose: Poses | None = None) -> torch.Tensor:
        pictures = []
        for k in range(camera.batch_size):
            path = self._path(camera[k], resolution)
            if path is not None and path.is_file():
                picture = torch.from_numpy(np.load(path))
                self.loaded += 1
            else:
                clock = time.monotonic()
                picture = render_path_traced(self.scene, camera[k], resolution, self.spp, self.seed)[0].half()
                self.seconds += time.monotonic() - clock
                self.rendered += 1
                if path is not None:
                    save_array_atomic(path, picture.numpy())
            pictures.append(picture.float())
        return torch.stack(pictures)

    def bounding_sphere(self) -> tuple[torch.Tensor, float]:
        return self.asset.mesh.bounding_sphere()

    def summary(self) -> dict:
        """What the reference cost: ``{"renderer", "variant", "lighting", "spp", "max_depth",
        "views_rendered", "views_from_cache", "seconds"}``."""
        return {"renderer": "mitsuba", "variant": self.variant, "lighting": self.lighting.name, "spp": self.spp,
                "max_depth": self.max_depth, "views_rendered": self.rendered, "views_from_cache": self.loaded,
                "seconds": self.seconds}


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
