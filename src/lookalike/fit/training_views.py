"""Training views: random cameras and lights, and the reference's images of them.

A :class:`BatchSource` hands the loop a :class:`Batch` per step. :class:`ViewPool` keeps a
rolling pool of rendered views (float16) and draws mini-batches from it; :class:`FreshViews`
renders new random views at every step. A view is a camera, its point light and, where the
reference moves (an animated character), a pose (:class:`Views`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import torch

from ..asset.pose import Poses
from ..phases import phase
from ..shading.camera import Camera
from ..shading.light import PointLight
from ..shading.view_sampling import random_lights, random_views
from .reference import Reference, render_in_chunks


@dataclass
class Views:
    """B views: ``camera`` and ``light`` (batch B) and, where the reference moves, the
    ``pose`` each shows (batch B; ``None`` for a still reference)."""

    camera: Camera
    light: PointLight
    pose: Poses | None = None

    @property
    def batch_size(self) -> int:
        return self.camera.batch_size

    def __getitem__(self, index) -> Views:
        return Views(self.camera[index], self.light[index], None if self.pose is None else self.pose[index])

    @staticmethod
    def cat(views: list[Views]) -> Views:
        poses = [v.pose for v in views]
        return Views(Camera.cat([v.camera for v in views]), PointLight.cat([v.light for v in views]),
                     None if poses[0] is None else Poses.cat(poses))


ViewSampler = Callable[[np.random.Generator, int], Views]
"""Draws ``n`` random views."""
LightSampler = Callable[[np.random.Generator, Camera], PointLight]
"""Draws a random light for each of a batch of cameras."""
PoseSampler = Callable[[np.random.Generator, int], Poses]
"""Draws ``n`` poses (``lookalike.shading.view_sampling.random_poses``)."""


@dataclass
class Batch:
    """Views of one step: ``camera`` and ``light`` (batch B), the reference ``target``
    ``[B, H, W, 4]`` float32 (linear RGB weighted by coverage, and coverage), and the ``pose``
    of each view where the reference moves (else ``None``)."""

    camera: Camera
    light: PointLight
    target: torch.Tensor
    pose: Poses | None = None

    def split(self, n: int) -> tuple[Batch, Batch | None]:
        """The first ``n`` views and the rest (``None`` if there are none)."""
        def part(index: slice) -> Batch:
            return Batch(self.camera[index], self.light[index], self.target[index],
                         None if self.pose is None else self.pose[index])

        if self.target.shape[0] <= n:
            return part(slice(None, n)), None
        return part(slice(None, n)), part(slice(n, None))


class BatchSource(Protocol):
    """Where training views come from; its state is part of a checkpoint."""

    def sample(self, rng: np.random.Generator, batch_size: int) -> Batch:
        ...

    def state_dict(self) -> dict:
        ...

    def load_state_dict(self, state: dict) -> None:
        ...


def view_sampler(centre: torch.Tensor, radius: float, horizon_share: float = 0.0,
                 poses: PoseSampler | None = None, distance_spread: float = 0.0,
                 fixed_light: PointLight | None = None) -> ViewSampler:
    """``sample(rng, n) -> Views``: ``n`` random views of the sphere (``centre [3]``,
    ``radius``), drawn from ``rng`` (cameras first, then a cosine-distributed point light per
    view; ``lookalike.shading.view_sampling``); with ``horizon_share > 0``, then each view's
    light tests the geometric horizon (``PointLight.horizon``) with that probability; with
    ``poses``, then a pose per view; with ``distance_spread``, cameras nearer and farther
    than the framing distance (``random_views``). With ``fixed_light`` (batch 1), every view is
    lit by it instead (a reference's fixed lighting; no light is drawn)."""

    lights = light_sampler(centre, horizon_share) if fixed_light is None else fixed_lights(fixed_light)

    def sample(rng: np.random.Generator, n: int) -> Views:
        camera = random_views(centre, radius, n, rng, distance_spread=distance_spread)
        light = lights(rng, camera)
        return Views(camera, light, None if poses is None else poses(rng, n))

    return sample


def light_sampler(centre: torch.Tensor, horizon_share: float = 0.0) -> LightSampler:
    """``sample(rng, camera) -> PointLight``: a cosine-distributed point light per camera
    (``lookalike.shading.view_sampling.random_lights``), testing the geometric horizon with
    probability ``horizon_share`` (``PointLight.horizon``)."""

    def sample(rng: np.random.Generator, camera: Camera) -> PointLight:
        light = random_lights(camera, centre, rng)
        if horizon_share > 0:
            light.horizon = torch.from_numpy(rng.uniform(size=camera.batch_size) < horizon_share)
        return light

    return sample


def fixed_lights(light: PointLight) -> LightSampler:
    """``sample(rng, camera) -> PointLight``: ``light`` (batch 1) for every camera, drawing
    nothing from ``rng``."""

    def sample(rng: np.random.Generator, camera: Camera) -> PointLight:
        n = camera.batch_size
        return PointLight(position=light.position.expand(n, 3).clone(), intensity=light.intensity.expand(n, 3).clone(),
                          horizon=None if light.horizon is None else light.horizon.expand(n).clone())

    return sample


class ViewPool:
    """A rolling pool of reference images: ``size`` random views rendered up front, then one
    new view rendered every ``refresh_every`` mini-batches, replacing the oldest. Mini-batches
    are drawn from the pool without replacement within a batch.

    A small fixed pool lets the latent model overfit its few lights and viewpoints; fresh
    views at every step cost a supersampled render of the high-poly reference per image. The
    rolling pool keeps most steps cheap while the set of views keeps growing.

    Views are drawn one at a time from the pool's own generator, so the pool after ``drawn``
    views is the same however it got there; ``state_dict``/``load_state_dict`` rebuild it.

    With ``relight``, the pool keeps each camera's G-buffer instead of an image
    (``reference.capture``, ``lookalike.shading.relight``) and lights it again under a fresh
    light drawn by ``relight`` every time the view is drawn: the lights keep varying while the
    reference's triangles are touched once per camera, so a step costs the same whatever the
    reference's size.

    Args:
        reference: renders the images, at ``resolution`` with ``spp`` x ``spp`` samples.
        sampler: draws the views; size: views in the pool; seed: of the pool's generator;
        refresh_every: steps between refreshes (0: a fixed pool); relight: draws the lights of
            drawn views (from the step's generator), or ``None`` to keep each view's own.

    Attributes:
        camera, light, pose: the pool's views (batch ``size``; ``pose`` ``None`` for a still
            reference); slot ``j % size`` holds view ``j``.
        images: ``[size, H, W, 4]`` float16 reference images (without ``relight``).
        captures: ``size`` ``CapturedView``s (with ``relight``).
    """

    def __init__(self, reference: Reference, sampler: ViewSampler, size: int, seed, refresh_every: int = 0,
                 resolution: int = 512, spp: int = 2, relight: LightSampler | None = None):
        self.reference = reference
        self.relight = relight
        self.resolution = resolution
        self.spp = spp
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
        pool = Views.cat([views[k] for k in order])
        self.camera, self.light, self.pose = pool.camera, pool.light, pool.pose
        if self.relight is None:
            self.images = render_in_chunks(self.reference, pool.camera, pool.light, self.resolution, self.spp,
                                           torch.float16, pool.pose)
        else:
            self.captures = [self.reference.capture(self.camera[k], self.resolution, self.spp) for k in range(self.size)]
        self.drawn = drawn

    @property
    def nbytes(self) -> int:
        """Bytes of memory the pool's reference data takes (images or captured G-buffers)."""
        if self.relight is None:
            return self.images.numel() * self.images.element_size()
        return sum(capture.nbytes for capture in self.captures)

    def _refresh(self) -> None:
        """Render one new view into the slot of the oldest."""
        view = self.sampler(self.rng, 1)
        camera, light = view.camera, view.light
        slot = self.drawn % self.size
        self.camera.mv[slot], self.camera.proj[slot], self.camera.position[slot] = camera.mv[0], camera.proj[0], camera.position[0]
        self.light.position[slot], self.light.intensity[slot] = light.position[0], light.intensity[0]
        if self.light.horizon is not None:
            self.light.horizon[slot] = light.horizon[0]
        if self.pose is not None:
            self.pose.clip[slot], self.pose.time[slot] = view.pose.clip[0], view.pose.time[0]
        if self.relight is None:
            self.images[slot] = self.reference.render(camera, light, self.resolution, self.spp,
                                                      view.pose)[0].to(torch.float16)
        else:
            self.captures[slot] = self.reference.capture(camera, self.resolution, self.spp)
        self.drawn += 1

    def sample(self, rng: np.random.Generator, batch_size: int) -> Batch:
        if self.refresh_every and self.samples and self.samples % self.refresh_every == 0:
            with phase("reference refresh"):
                self._refresh()
        self.samples += 1
        index = torch.from_numpy(rng.choice(self.size, size=batch_size, replace=False))
        pose = None if self.pose is None else self.pose[index]
        if self.relight is None:
            return Batch(self.camera[index], self.light[index], self.images[index].float(), pose)
        camera = self.camera[index]
        light = self.relight(rng, camera)
        with phase("relight"):
            target = torch.cat([self.captures[int(slot)].light(light[k]) for k, slot in enumerate(index)])
        return Batch(camera, light, target)

    def state_dict(self) -> dict:
        return {"drawn": self.drawn, "samples": self.samples}

    def load_state_dict(self, state: dict) -> None:
        if state["drawn"] != self.drawn:
            self._fill(state["drawn"])
        self.samples = state["samples"]


class FreshViews:
    """New random views, rendered by ``reference`` at ``resolution`` with ``spp`` x ``spp``
    samples at every step."""

    def __init__(self, reference: Reference, sampler: ViewSampler, resolution: int = 512, spp: int = 2):
        self.reference = reference
        self.sampler = sampler
        self.resolution = resolution
        self.spp = spp

    def sample(self, rng: np.random.Generator, batch_size: int) -> Batch:
        views = self.sampler(rng, batch_size)
        return Batch(views.camera, views.light,
                     self.reference.render(views.camera, views.light, self.resolution, self.spp, views.pose), views.pose)

    def state_dict(self) -> dict:
        return {}

    def load_state_dict(self, state: dict) -> None:
        pass
