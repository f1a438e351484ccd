"""Reference images: what the latent model must look like.

The optimisation treats the reference renderer as a black box (paper Sec. 4): a
:class:`Target` renders the reference under given cameras and lights. :class:`MeshTarget`
is the input asset rendered by our own pipeline, supersampled.

Training views come from a :class:`BatchSource`: :class:`ViewPool` keeps a rolling pool of
rendered views (float16) and draws mini-batches from it; :class:`FreshViews` renders new
random views at every step.
"""

from __future__ import annotations

from typing import Callable, Protocol

import numpy as np
import torch

from ..asset import Asset
from ..shading.pipeline import render
from ..shading.camera import Camera
from ..shading.light import PointLight
from .optimize import Batch

ViewSampler = Callable[[np.random.Generator, int], tuple[Camera, PointLight]]
"""Draws ``n`` random views: ``(camera, light)`` batches of ``n``."""

RENDER_CHUNK = 4
"""Views rendered together when filling a pool (bounds the memory of supersampled renders)."""


class Target(Protocol):
    """A reference renderer."""

    def render(self, camera: Camera, light: PointLight) -> torch.Tensor:
        """``[B, H, W, 4]`` float32 linear RGB (weighted by coverage) and coverage."""
        ...


class MeshTarget:
    """A reference asset rendered by ``lookalike.shading.render`` with ``spp`` x ``spp``
    supersampling, without gradients.

    Args:
        asset: the reference.
        resolution: image side in pixels.
        spp: samples per pixel per axis.
    """

    def __init__(self, asset: Asset, resolution: int, spp: int):
        self.asset = asset
        self.resolution = resolution
        self.spp = spp

    @torch.no_grad()
    def render(self, camera: Camera, light: PointLight) -> torch.Tensor:
        return render(self.asset, camera, light, (self.resolution, self.resolution), spp=self.spp)


def render_in_chunks(target: Target, camera: Camera, light: PointLight, dtype=torch.float32) -> torch.Tensor:
    """``target.render`` over a large batch, ``RENDER_CHUNK`` views at a time, stored as ``dtype``."""
    n = camera.batch_size
    return torch.cat([target.render(camera[i:i + RENDER_CHUNK], light[i:i + RENDER_CHUNK]).to(dtype)
                      for i in range(0, n, RENDER_CHUNK)])


class ViewPool:
    """A rolling pool of reference images: ``size`` random views rendered up front, then one
    new view rendered every ``refresh_every`` mini-batches, replacing the oldest. Mini-batches
    are drawn from the pool without replacement within a batch.

    A small fixed pool lets the latent model overfit its few lights and viewpoints; fresh
    views at every step cost a supersampled render of the high-poly reference per image. The
    rolling pool keeps most steps cheap while the set of views keeps growing.

    Views are drawn one at a time from the pool's own generator, so the pool after ``drawn``
    views is the same however it got there; ``state_dict``/``load_state_dict`` rebuild it.

    Attributes:
        camera, light: the pool's views (batch ``size``); slot ``j % size`` holds view ``j``.
        images: ``[size, H, W, 4]`` float16 reference images.
    """

    def __init__(self, target: Target, sampler: ViewSampler, size: int, seed, refresh_every: int = 0):
        self.target = target
        self.sampler = sampler
        self.size = size
        self.seed = seed
        self.refresh_every = refresh_every
        self.samples = 0
        self._fill(drawn=size)

    def _fill(self, drawn: int) -> None:
        """Render the views ``drawn - size .. drawn - 1`` into their slots."""
        self.rng = np.random.default_rng(self.seed)
        views = [self.sampler(self.rng, 1) for _ in range(drawn)][-self.size:]
        order = sorted(range(self.size), key=lambda k: (drawn - self.size + k) % self.size)
        self.camera = _cat_cameras([views[k][0] for k in order])
        self.light = _cat_lights([views[k][1] for k in order])
        self.images = render_in_chunks(self.target, self.camera, self.light, torch.float16)
        self.drawn = drawn

    def _refresh(self) -> None:
        """Render one new view into the slot of the oldest."""
        camera, light = self.sampler(self.rng, 1)
        slot = self.drawn % self.size
        self.camera.mv[slot], self.camera.proj[slot], self.camera.position[slot] = camera.mv[0], camera.proj[0], camera.position[0]
        self.light.position[slot], self.light.intensity[slot] = light.position[0], light.intensity[0]
        self.images[slot] = self.target.render(camera, light)[0].to(torch.float16)
        self.drawn += 1

    def sample(self, rng: np.random.Generator, batch_size: int) -> Batch:
        if self.refresh_every and self.samples and self.samples % self.refresh_every == 0:
            self._refresh()
        self.samples += 1
        index = torch.from_numpy(rng.choice(self.size, size=batch_size, replace=False))
        return Batch(self.camera[index], self.light[index], self.images[index].float())

    def state_dict(self) -> dict:
        return {"drawn": self.drawn, "samples": self.samples}

    def load_state_dict(self, state: dict) -> None:
        if state["drawn"] != self.drawn:
            self._fill(state["drawn"])
        self.samples = state["samples"]


def _cat_cameras(cameras: list[Camera]) -> Camera:
    return Camera(mv=torch.cat([c.mv for c in cameras]).contiguous(), proj=torch.cat([c.proj for c in cameras]).contiguous(),
                  position=torch.cat([c.position for c in cameras]).contiguous())


def _cat_lights(lights: list[PointLight]) -> PointLight:
    return PointLight(position=torch.cat([l.position for l in lights]), intensity=torch.cat([l.intensity for l in lights]))


class FreshViews:
    """New random views, rendered by ``target`` at every step."""

    def __init__(self, target: Target, sampler: ViewSampler):
        self.target = target
        self.sampler = sampler

    def sample(self, rng: np.random.Generator, batch_size: int) -> Batch:
        camera, light = self.sampler(rng, batch_size)
        return Batch(camera, light, self.target.render(camera, light))

    def state_dict(self) -> dict:
        return {}

    def load_state_dict(self, state: dict) -> None:
        pass


def latent_renderer(resolution: int, msaa: int):
    """How latent models (and the decimation baseline) are drawn: one shading sample per pixel
    with ``msaa`` x ``msaa`` visibility samples (the paper's MSAA), differentiable.

    Returns ``render(asset, camera, light) -> [B, H, W, 4]``."""
    def draw(asset: Asset, camera: Camera, light: PointLight) -> torch.Tensor:
        return render(asset, camera, light, (resolution, resolution), spp=msaa, msaa=msaa > 1)
    return draw
