"""The Blender side of ``lookalike.judge.cycles``: render one glb under many views in Cycles.

Run as ``python -m lookalike.judge.cycles_worker JOB.json`` (``lookalike.judge.process``); it
imports only ``bpy``, NumPy and the standard library. The job (JSON) holds:

- ``glb``: the model; ``output``: where to write the pixels (``.npy``); ``stats``: where to
  write timings (``.json``); ``scratch``: a folder for the EXR frames;
- ``width``, ``height``, ``samples``, ``threads``, ``seed``;
- ``views``: per view a camera (``matrix_world`` in Blender axes, ``angle_y``, ``clip_start``,
  ``clip_end``) and a light (``location``, ``color``, ``energy`` in W), from
  ``lookalike.judge.conversion``;
- ``shadows``: a list of booleans, one pass over every view for each.

The output is ``[S, B, H, W, 4]`` float32 (S shadow settings, B views): linear RGB over black
(premultiplied by coverage, as Cycles' transparent film writes it) and alpha = coverage, row 0
at the top of the picture.

Scene settings, so that Cycles draws what our pipeline draws: Cycles on the CPU, ``samples``
per pixel, no denoising, no adaptive sampling, direct light only (``max_bounces = 0``; the
transparent bounces stay, so blended materials show what lies behind them), a box pixel filter
1 pixel wide (ours averages its supersamples in the pixel), Standard view transform, no world
light, transparent film, a point light of radius 0 without soft falloff, the light threshold
at 0 (no light is culled as too faint).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import bpy
import numpy as np


def reset_scene() -> bpy.types.Scene:
    """An empty scene (factory settings, no objects)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene


def import_glb(path: str) -> list:
    """Import a glb with Blender's glTF importer (its defaults: the file's normals, y-up turned
    to z-up); returns the mesh objects."""
    bpy.ops.import_scene.gltf(filepath=path)
    return [o for o in bpy.context.scene.objects if o.type == "MESH"]


def configure_cycles(scene: bpy.types.Scene, job: dict) -> None:
    """The render settings of the module docstring."""
    scene.render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples = int(job["samples"])
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    cycles.seed = int(job.get("seed", 0))
    cycles.max_bounces = 0
    cycles.diffuse_bounces = cycles.glossy_bounces = cycles.transmission_bounces = cycles.volume_bounces = 0
    cycles.transparent_max_bounces = 16
    cycles.pixel_filter_type = "BOX"
    cycles.filter_width = 1.0
    cycles.light_sampling_threshold = 0.0
    cycles.sample_clamp_direct = 0.0
    cycles.sample_clamp_indirect = 0.0
    scene.render.film_transparent = True
    scene.render.resolution_x = int(job["width"])
    scene.render.resolution_y = int(job["height"])
    scene.render.resolution_percentage = 100
    scene.render.pixel_aspect_x = scene.render.pixel_aspect_y = 1.0
    scene.render.use_persistent_data = True
    scene.render.use_compositing = False
    scene.render.use_sequencer = False
    scene.render.threads_mode = "FIXED"
    scene.render.threads = max(1, int(job.get("threads", 1)))
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    settings = scene.render.image_settings
    settings.file_format = "OPEN_EXR"
    settings.color_mode = "RGBA"
    settings.color_depth = "32"
    settings.exr_codec = "NONE"
    world = bpy.data.worlds.new("black")
    world.color = (0.0, 0.0, 0.0)
    if world.node_tree is not None:
        for node in world.node_tree.nodes:
            if node.type == "BACKGROUND":
                node.inputs["Strength"].default_value = 0.0
    scene.world = world


def add_camera(scene: bpy.types.Scene) -> bpy.types.Object:
    """A perspective camera whose vertical field of view is ``angle_y`` (``sensor_fit = VERTICAL``)."""
    data = bpy.data.cameras.new("judge")
    data.type = "PERSP"
    data.sensor_fit = "VERTICAL"
    data.shift_x = data.shift_y = 0.0
    camera = bpy.data.objects.new("judge camera", data)
    scene.collection.objects.link(camera)
    scene.camera = camera
    return camera


def add_point_light(scene: bpy.types.Scene) -> bpy.types.Object:
    """A point light of radius 0 with the inverse-square falloff only (no soft falloff)."""
    data = bpy.data.lights.new("judge", "POINT")
    data.shadow_soft_size = 0.0
    data.use_soft_falloff = False
    data.use_shadow = True
    light = bpy.data.objects.new("judge light", data)
    scene.collection.objects.link(light)
    return light


def place_view(camera: bpy.types.Object, light: bpy.types.Object, view: dict) -> None:
    """Set the camera and the light to one view of the job."""
    from mathutils import Matrix

    camera.matrix_world = Matrix(view["camera"]["matrix_world"])
    camera.data.angle_y = float(view["camera"]["angle_y"])
    camera.data.clip_start = float(view["camera"]["clip_start"])
    camera.data.clip_end = float(view["camera"]["clip_end"])
    light.location = view["light"]["location"]
    light.data.color = view["light"]["color"]
    light.data.energy = float(view["light"]["energy"])


def render_frame(scene: bpy.types.Scene, exr_path: Path) -> np.ndarray:
    """Render the scene's camera to ``exr_path`` and read it back: ``[H, W, 4]`` float32, row 0
    at the top."""
    scene.render.filepath = str(exr_path)
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(str(exr_path))
    width, height = image.size
    pixels = np.empty(width * height * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    bpy.data.images.remove(image)
    exr_path.unlink(missing_ok=True)
    return pixels.reshape(height, width, 4)[::-1]


def _triangles(obj) -> int:
    """Triangles of a mesh object (its polygons triangulated)."""
    obj.data.calc_loop_triangles()
    return len(obj.data.loop_triangles)


def main(job_path: str) -> None:
    """Run the job in ``job_path`` (module docstring): import, then every view once per shadow
    setting; write the pixels and the timings."""
    job = json.loads(Path(job_path).read_text())
    scene = reset_scene()
    started = time.monotonic()
    objects = import_glb(job["glb"])
    imported = time.monotonic() - started
    configure_cycles(scene, job)
    camera, light = add_camera(scene), add_point_light(scene)
    scratch = Path(job["scratch"])
    views = job["views"]
    out = np.zeros((len(job["shadows"]), len(views), int(job["height"]), int(job["width"]), 4), dtype=np.float32)
    started = time.monotonic()
    for s, shadows in enumerate(job["shadows"]):
        for obj in objects:
            obj.visible_shadow = bool(shadows)
        for b, view in enumerate(views):
            place_view(camera, light, view)
            out[s, b] = render_frame(scene, scratch / f"view-{s}-{b}.exr")
    rendering = time.monotonic() - started
    np.save(job["output"], out)
    frames = max(len(views) * len(job["shadows"]), 1)
    Path(job["stats"]).write_text(json.dumps({"import_s": imported, "render_s": rendering,
                                              "seconds_per_view": rendering / frames,
                                              "triangles": sum(_triangles(o) for o in objects)}))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        raise SystemExit("usage: python -m lookalike.judge.cycles_worker JOB.json")
    main(sys.argv[1])
