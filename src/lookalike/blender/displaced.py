"""``displace``'s outputs applied in Blender (``lookalike.blender.displace_worker``), the way
the README tells a user to: the proof that the documented settings rebuild our surface."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from .. import io
from .process import run_worker, worker_deadline


def blender_displaced(outdir: str | Path, level: int) -> np.ndarray:
    """``[V, 3]`` float64 positions of ``outdir/base.glb`` subdivided ``level`` times and
    displaced by Blender's Displace modifier with the settings in its material's
    ``extras.displacement``. Raises ``ConfigError`` without ``bpy``, ``JudgeError`` where
    Blender fails, ``ExternalToolTimeout`` where it runs past its deadline (the subdivided
    triangles), twice."""
    outdir = Path(outdir)
    base = io.load(outdir / "base.glb")
    displacement = base.materials[0].displacement
    with tempfile.TemporaryDirectory(prefix="lookalike-displace-") as scratch:
        output = Path(scratch) / "positions.npy"
        run_worker("displace_worker", {"base": str(outdir / "base.glb"), "heights": str(outdir / "displacement.png"),
                                       "level": level, "scale": displacement.scale, "offset": displacement.offset,
                                       "output": str(output)},
                   worker_deadline(base.mesh.num_triangles * 4 ** level), "base.glb")
        return np.load(output)
