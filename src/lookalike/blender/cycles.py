"""Render a glb in Blender Cycles under our cameras and point lights (``render_cycles_views``).

All views of one model are rendered by one Blender process (``lookalike.blender.cycles_worker``):
the glb is imported once, then the camera and the light are moved from view to view. The
conversion of our views is exact (``lookalike.blender.conversion``); the images come back in our
renderer's conventions: ``[B, H, W, 4]`` float32 linear RGB over black (premultiplied by
coverage, like ``lookalike.shading.pipeline.render`` without a background) and alpha =
coverage, row 0 at the top. An animated glb (a skin and animations, as ``lookalike.io`` writes
an animated run's models) is posed per view, at the view's clip and time (``Poses``), by
Blender's own armature (``lookalike.blender.cycles_worker``).
"""

from __future__ import annotations

import json
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from ..asset.pose import Poses
from ..io.gltf_data import triangle_count
from ..shading.camera import Camera
from ..shading.light import PointLight
from ..threads import thread_count
from .conversion import ENVIRONMENT_TURN, blender_cameras, blender_point_lights, blender_poses
from .process import run_worker, worker_deadline

SAMPLES = 32
"""Cycles samples per pixel (the judge's prescribed setting): antialiasing, and the alpha of blended surfaces."""

SEED = 0
"""Cycles' sampling seed: the same views give the same pixels."""

SECONDS_PER_SAMPLE = 5e-6
"""Seconds a worker may take per Cycles sample (views x shadow settings x pixels x samples per
pixel x (1 + bounces)): about ten times what Cycles takes on a busy 2-core machine
(``docs/judge.md``)."""


@dataclass
class CyclesRender:
    """What one Blender process rendered.

    Attributes:
        images: ``{shadows: [B, H, W, 4] float32}`` (see the module docstring).
        seconds_per_view: Cycles' wall seconds per picture (import excluded).
        seconds: the whole process's wall seconds (start, import, every picture).
    """

    images: dict[bool, torch.Tensor] = field(default_factory=dict)
    seconds_per_view: float = 0.0
    seconds: float = 0.0


def _size(resolution) -> tuple[int, int]:
    """``(height, width)`` of an ``H`` or ``(H, W)`` resolution."""
    if isinstance(resolution, int):
        return resolution, resolution
    height, width = resolution
    return int(height), int(width)


def render_cycles_views(glb_path: str | Path, camera: Camera, light: PointLight, resolution,
                        shadows: tuple[bool, ...] = (True, False), samples: int = SAMPLES,
                        threads: int | None = None, pose: Poses | None = None, environment: str | Path | None = None,
                        bounces: int = 0, seed: int = SEED) -> CyclesRender:
    """Render the glb at ``glb_path`` in Cycles from B cameras, each lit by its point light, once
    for each setting in ``shadows`` (True: the model casts shadows; False: no object does).

    Args:
        glb_path: a glTF binary in our world frame (y up; as ``lookalike.io.save`` writes it).
        camera: B cameras (centred perspective projections, aspect = W / H).
        light: B point lights (or 1, shared).
        resolution: ``H`` or ``(H, W)``.
        samples: Cycles samples per pixel; threads: CPU threads (default: ours); seed: Cycles'
            sampling seed (another seed draws another noise: the judge's own noise floor).
        pose: B poses of an animated glb (clip indices into its animations, times in seconds);
            ``None``: the rest pose (a still glb shows itself as it is).
    Raises:
        ConfigError: ``bpy`` is not installed; JudgeError: Blender failed (e.g. a pose names an
            animation the glb lacks); ExternalToolTimeout: Blender ran past its deadline (the
            glb's triangles, once per view where posed, and ``SECONDS_PER_SAMPLE``), twice.
    """
    height, width = _size(resolution)
    count = camera.batch_size
    views = [{"camera": c, "light": l, "pose": p}
             for c, l, p in zip(blender_cameras(camera, width, height), blender_point_lights(light, count),
                                blender_poses(pose, count))]
    with tempfile.TemporaryDirectory(prefix="lookalike-cycles-") as scratch:
        output, stats = Path(scratch) / "images.npy", Path(scratch) / "stats.json"
        job = {"glb": str(Path(glb_path).resolve()), "output": str(output), "stats": str(stats), "scratch": scratch,
               "width": width, "height": height, "samples": int(samples), "seed": int(seed),
               "threads": threads or thread_count(), "views": views, "shadows": [bool(s) for s in shadows],
               "environment": str(Path(environment).resolve()) if environment else None, "bounces": int(bounces),
               "environment_turn": ENVIRONMENT_TURN}
        work = SECONDS_PER_SAMPLE * count * len(shadows) * height * width * samples * (1 + int(bounces))
        deadline = worker_deadline(triangle_count(glb_path) * (1 if pose is None else count), work)
        seconds = run_worker("cycles_worker", job, deadline, Path(glb_path).name)
        pixels = np.load(output)
        figures = json.loads(stats.read_text())
    images = {bool(s): torch.from_numpy(np.ascontiguousarray(pixels[i])) for i, s in enumerate(shadows)}
    return CyclesRender(images, figures["seconds_per_view"], seconds)
