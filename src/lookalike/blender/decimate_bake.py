"""Blender's classic LOD pipeline as a baseline: decimate, unwrap, bake selected-to-active
(``blender_classic_bake``), and its decimation alone with the input's materials kept
(``blender_decimate_glb``). What users compare us with ("Blender's decimate + bake"); the
steps and their settings are in ``lookalike.blender.decimate_bake_worker``. It makes a still model
(its steps know no skeleton), so the judge leaves it out of animated runs.
"""

from __future__ import annotations

import json
import tempfile
from dataclasses import dataclass
from pathlib import Path

from ..io.gltf_data import triangle_count
from ..threads import thread_count
from .process import run_worker, worker_deadline

CAGE_FRACTION = 0.02
"""Rays start this fraction of the reference's bounding-box diagonal above the low-poly surface
and end as far below it (the reach of our own bake, ``lookalike.init.projection_bake``)."""

MARGIN = 16
"""Texels of dilation around every chart (Blender's bake margin)."""

PADDING = 4
"""Texels between the atlas's charts (as our own unwrap's default)."""

SAMPLES = 4
"""Cycles samples per texel while baking (antialiasing within the texel)."""

SECONDS_PER_TEXEL_SAMPLE = 1.5e-5
"""Seconds the worker may take per texel and sample of its maps (all its bakes together): about
ten times what Blender takes (``docs/judge.md``)."""

SHARP_ANGLE = 30.0
"""Degrees between faces above which Blender's Smooth by Angle (Shade Auto Smooth) makes an edge
sharp: its default, what a user shades a hard-surface model with."""

BASE_COLOUR_PASS = "DIFFUSE"
"""How the base colour is baked: ``"DIFFUSE"`` (the DIFFUSE bake's COLOR pass, what users do,
with the sources' metalness and specular level at 0 meanwhile, else it comes out darker) or
``"EMIT"`` (the base colour input wired into an Emission shader); both copy the base colour."""


@dataclass
class BlenderBake:
    """What Blender's pipeline wrote.

    Attributes:
        path: the glb (one mesh, one material: base colour, metallic-roughness, normal map).
        input_triangles, triangles: triangle counts of the reference and of the result.
        seconds: wall seconds per step (``import``, ``decimate``, ``unwrap``, ``bake ...``,
            ``export``) and ``total`` (the whole Blender process).
    """

    path: Path
    input_triangles: int
    triangles: int
    seconds: dict[str, float]


def blender_classic_bake(reference_glb: str | Path, output_glb: str | Path, triangles: int, texture_size: int,
                         samples: int = SAMPLES, cage_fraction: float = CAGE_FRACTION, margin: int = MARGIN,
                         padding: int = PADDING, base_colour_pass: str = BASE_COLOUR_PASS,
                         threads: int | None = None, sharp_angle: float | None = None) -> BlenderBake:
    """Run Blender's decimate + xatlas + selected-to-active bake on ``reference_glb`` down to
    about ``triangles`` triangles with ``texture_size``-texel square maps; write ``output_glb``.
    The decimated mesh is shaded smooth, or with ``sharp_angle`` smooth by angle (edges whose
    faces meet at more than ``sharp_angle`` degrees sharp; ``SHARP_ANGLE`` is Blender's default).

    Raises:
        ConfigError: ``bpy`` is not installed; JudgeError: Blender failed; ExternalToolTimeout:
            Blender ran past its deadline (the reference's triangles and
            ``SECONDS_PER_TEXEL_SAMPLE``), twice.
    """
    job = {"texture_size": int(texture_size), "padding": int(padding), "samples": int(samples),
           "threads": threads or thread_count(), "cage_fraction": float(cage_fraction), "margin": int(margin),
           "base_colour_pass": base_colour_pass, "sharp_angle": sharp_angle}
    return _run_pipeline(reference_glb, output_glb, triangles, job, SECONDS_PER_TEXEL_SAMPLE * texture_size ** 2 * samples)


def blender_decimate_glb(reference_glb: str | Path, output_glb: str | Path, triangles: int) -> BlenderBake:
    """Blender's Decimate alone, as a user makes plain decimation in Blender: ``reference_glb``
    decimated to about ``triangles`` triangles (the pipeline's steps 1-2) and written to
    ``output_glb`` with the input's own materials and UVs (its textures whole: a tree of
    alpha-textured leaf quads keeps its leaf texture). Raises as ``blender_classic_bake``."""
    return _run_pipeline(reference_glb, output_glb, triangles, {"keep_materials": True}, 0.0)


def _run_pipeline(reference_glb: str | Path, output_glb: str | Path, triangles: int, options: dict,
                  work: float) -> BlenderBake:
    """Run ``decimate_bake_worker`` on ``reference_glb`` with the job ``options`` (and ``work``
    seconds beside the reference's triangles in its deadline); what it wrote to ``output_glb``."""
    output_glb = Path(output_glb).resolve()
    output_glb.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="lookalike-blender-bake-") as scratch:
        stats = Path(scratch) / "stats.json"
        job = {"reference": str(Path(reference_glb).resolve()), "output": str(output_glb), "stats": str(stats),
               "scratch": scratch, "triangles": int(triangles), **options}
        total = run_worker("decimate_bake_worker", job, worker_deadline(triangle_count(reference_glb), work),
                           Path(reference_glb).name)
        figures = json.loads(stats.read_text())
    return BlenderBake(output_glb, figures["input_triangles"], figures["triangles"],
                       {**figures["seconds"], "total": total})
