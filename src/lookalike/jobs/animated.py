"""What ``simplify`` does differently for a skinned, animated input (paper Sec. 5.3): the parts
it composes instead of the still ones.

- The reference is the input posed by its skeleton at each view's clip and time
  (``SkinnedReference``); training views draw a random clip and time each (the rest pose a
  share of the time), held-out and validation views are spread over every clip.
- The initial guess is the still one (decimation, atlas and bake in the bind pose) with
  skinning weights: the candidates and starting weights of the fit
  (``lookalike.init.skin_weights.skin_candidates``), and for the baselines the weights
  transferred from the closest point of the input (``transfer_skin``).
- The latent is a ``SkinnedMesh``; its export keeps the input's skeleton and clips.
"""

from __future__ import annotations

import dataclasses
from functools import partial

import numpy as np
import torch

from ..asset import Asset
from ..asset.pose import REST, Poses
from ..settings import Config
from ..fit.reference import RENDER_CHUNK, SkinnedReference, render_in_chunks
from ..fit.training_views import PoseSampler
from ..init.initial_guess import InitialGuess
from ..init.skin_weights import skin_candidates, transfer_skin
from ..report.heldout import AssetRenderer, HeldoutViews, over_background
from ..report.record import Motion
from ..shading.view_sampling import random_poses, spread_poses

MOTION_FRAMES = 24
"""Frames of the report's animated picture (over one clip)."""


def is_animated(asset: Asset, static: bool) -> bool:
    """Whether ``simplify`` fits ``asset`` over its animations: it has a skin, influences and
    at least one clip, and ``static`` (``latent.static``) is not set."""
    return not static and asset.skin is not None and asset.mesh.v_joints is not None and bool(asset.animations)


def durations(asset: Asset) -> list[float]:
    """Seconds each of ``asset``'s clips lasts."""
    return [animation.duration for animation in asset.animations]


def training_poses(asset: Asset, cfg: Config) -> PoseSampler:
    """Random clips and times, the rest pose ``views.rest_share`` of the time."""
    return partial(_random_poses, durations(asset), cfg.views.rest_share)


def heldout_poses(asset: Asset) -> PoseSampler:
    """Poses spread over every clip (``spread_poses``)."""
    return partial(_spread_poses, durations(asset))


def _random_poses(clip_durations: list[float], rest_share: float, rng: np.random.Generator, n: int) -> Poses:
    return random_poses(clip_durations, n, rng, rest_share)


def _spread_poses(clip_durations: list[float], rng: np.random.Generator, n: int) -> Poses:
    return spread_poses(clip_durations, n, rng)


def animated_guess(asset: Asset, guess: InitialGuess, candidates: int) -> InitialGuess:
    """``guess`` (built in the bind pose) with skinning: the start gets ``candidates`` candidate
    joints per vertex with their starting weights (the blend's 4 strongest, the rest at 0), and
    the baseline the input's weights transferred to it (4 per vertex); both get the input's
    skeleton and clips."""
    joints, weights = skin_candidates(asset.mesh, asset.skin, guess.start.mesh, candidates)
    start = dataclasses.replace(guess.start, mesh=dataclasses.replace(guess.start.mesh, v_joints=joints,
                                                                      v_weights=weights),
                                skin=asset.skin, animations=asset.animations)
    return dataclasses.replace(guess, start=start, baseline=transfer_skin(asset, guess.baseline))


def pose_labels(asset: Asset, poses: Poses) -> list[str]:
    """What each of ``poses`` shows, e.g. ``"Walk at 0.42 s"`` or ``"rest pose"``."""
    return ["rest pose" if clip == REST else f"{asset.animations[clip].name} at {time:.2f} s"
            for clip, time in zip(poses.clip.tolist(), poses.time.tolist())]


@torch.no_grad()
def motion(reference: SkinnedReference, models: dict[str, Asset], heldout: HeldoutViews, draw: AssetRenderer,
           resolution: int, spp: int) -> Motion:
    """The report's moving picture: ``MOTION_FRAMES`` frames of the longest clip of the
    reference's asset, in real time, from the first held-out camera and light, of the reference
    and of each of ``models`` (``{label: asset}``, drawn by ``draw``), at ``resolution``."""
    asset = reference.asset
    clip = max(range(len(asset.animations)), key=lambda k: asset.animations[k].duration)
    duration = asset.animations[clip].duration
    index = torch.zeros(MOTION_FRAMES, dtype=torch.int64)
    camera, light = heldout.camera[index], heldout.light[index]
    poses = Poses.of(np.full(MOTION_FRAMES, clip), np.linspace(0.0, duration, MOTION_FRAMES, endpoint=False))
    columns = {"Reference": over_background(render_in_chunks(reference, camera, light, resolution, spp, pose=poses))}
    for label, model in models.items():
        columns[label] = over_background(torch.cat([draw(model, camera[c], light[c], poses[c])
                                                    for c in _chunks(MOTION_FRAMES)]))
    return Motion(clip=asset.animations[clip].name, seconds_per_frame=duration / MOTION_FRAMES, columns=columns)


def _chunks(count: int) -> list[slice]:
    return [slice(i, i + RENDER_CHUNK) for i in range(0, count, RENDER_CHUNK)]

