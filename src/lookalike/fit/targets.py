"""Reference images: what the latent model must look like.

The optimisation treats the reference renderer as a black box (paper Sec. 4): a
:class:`Target` renders the reference under given cameras and lights. :class:`MeshTarget`
is the input asset rendered by our own pipeline, supersampled.

Training views come from a :class:`BatchSource`: :class:`ViewPool` renders a pool of random
views once (stored as float16) and draws mini-batches from it; :class:`FreshViews` renders
new random views at every step. The pool is much cheaper per step because a supersampled
render of a high-poly reference costs many latent steps.
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
    """``size`` random views rendered once; mini-batches are drawn without replacement within
    a batch.

    Attributes:
        camera, light: the pool's views (batch ``size``).
        images: ``[size, H, W, 4]`` float16 reference images.
    """

    def __init__(self, target: Target, sampler: ViewSampler, size: int, rng: np.random.Generator):
        self.camera, self.light = sampler(rng, size)
        self.images = render_in_chunks(target, self.camera, self.light, torch.float16)

    def sample(self, rng: np.random.Generator, batch_size: int) -> Batch:
        index = torch.from_numpy(rng.choice(self.images.shape[0], size=batch_size, replace=False))
        return Batch(self.camera[index], self.light[index], self.images[index].float())


class FreshViews:
    """New random views, rendered by ``target`` at every step."""

    def __init__(self, target: Target, sampler: ViewSampler):
        self.target = target
        self.sampler = sampler

    def sample(self, rng: np.random.Generator, batch_size: int) -> Batch:
        camera, light = self.sampler(rng, batch_size)
        return Batch(camera, light, self.target.render(camera, light))


def latent_renderer(resolution: int, msaa: int):
    """How latent models (and the decimation baseline) are drawn: one shading sample per pixel
    with ``msaa`` x ``msaa`` visibility samples (the paper's MSAA), differentiable.

    Returns ``render(asset, camera, light) -> [B, H, W, 4]``."""
    def draw(asset: Asset, camera: Camera, light: PointLight) -> torch.Tensor:
        return render(asset, camera, light, (resolution, resolution), spp=msaa, msaa=msaa > 1)
    return draw
