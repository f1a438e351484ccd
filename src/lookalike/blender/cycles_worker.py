"""The Blender side of ``lookalike.blender.cycles``: render one glb under many views in Cycles.

Run as ``python -m lookalike.blender.cycles_worker JOB.json`` (``lookalike.blender.process``); it
imports only ``bpy``, NumPy and the standard library. The job (JSON) holds:

- ``glb``: the model; ``output``: where to write the pixels (``.npy``); ``stats``: where to
  write timings (``.json``); ``scratch``: a folder for the EXR frames;
- ``width``, ``height``, ``samples``, ``threads``, ``seed``;
- ``views``: per view a camera (``matrix_world`` in Blender axes, ``angle_y``, ``clip_start``,
  ``clip_end``), a light (``location``, ``color``, ``energy`` in W) and a ``pose`` (``clip``: an
  index into the glb's animations, ``time`` in seconds; ``None`` or absent: the rest pose), from
  ``lookalike.blender.conversion``;
- ``shadows``: a list of booleans, one pass over every view for each;
- ``environment``: a latitude-longitude map lighting the scene (``None``: a black world), turned
  by ``environment_turn`` radians about z; ``bounces``: light bounces (0: direct light only).

The output is ``[S, B, H, W, 4]`` float32 (S shadow settings, B views): linear RGB over black
(premultiplied by coverage, as Cycles' transparent film writes it) and alpha = coverage, row 0
at the top of the picture.

Scene settings, so that Cycles draws what our pipeline draws: Cycles on the CPU, ``samples``
per pixel, no denoising, no adaptive sampling, direct light only unless the job asks for
``bounces`` (``max_bounces = 0``; the transparent bounces stay, so blended materials show what
lies behind them), a box pixel filter 1 pixel wide (ours averages its supersamples in the
pixel), Standard view transform, no world light unless the job names an environment map (never
seen: the film is transparent), a point light of radius 0 without soft falloff, the light threshold
at 0 (no light is culled as too faint).

Poses (an animated glb: a skin and animations). Blender's glTF importer turns each glTF
animation into one action (one slot per object it moves: the armature for its joints), stashes
it on a muted NLA track named after the animation (``Anim_<i>`` where it has no name, ``.001``
where the name is taken) and keys a sample at ``t`` seconds on frame ``t * fps`` (its fps: the
scene's ``fps * fps_base``, 24 in an empty scene); it then plays the first animation. Before
that, a user extension of the importer (``ImportRecorder``) records every node's transform as
the file sets it (the rest pose) and the track name of each animation. Each view then puts every
node back in its rest pose, makes its clip's actions (with their slots) the active actions of
the objects they move and clears every other object's, keeps every NLA track muted, and sets
the scene to frame ``time * fps`` (the fraction as the subframe, which the render evaluates):
channels the clip does not animate keep the rest pose, as glTF says. The armature modifier then
deforms the mesh and Blender recomputes its normals from the posed positions. Blender interpolates
the samples as it keys them: STEP, and LINEAR translations and scales, as glTF does; LINEAR
rotations component by component, normalised (not glTF's slerp: the two part where keys lie far
apart); CUBICSPLINE as Bezier curves through the values (the importer drops the file's tangents).
"""

from __future__ import annotations

import json
import math
import sys
import time
import types
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import bpy
import numpy as np


def reset_scene() -> bpy.types.Scene:
    """An empty scene (factory settings, no objects)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene


IMPORT_HOOK = "lookalike_judge_import_hook"
"""The add-on name under which ``import_glb`` hands the glTF importer its ``ImportRecorder``."""


@dataclass
class Imported:
    """What the glTF importer made of one glb.

    Attributes:
        meshes: the mesh objects.
        rest: ``{(object name, pose bone name or ""): (location, rotation_quaternion, scale)}``:
            every imported object's and pose bone's transform as the importer set it from the
            file's nodes, before any animation played (the rest pose).
        clips: the importer's NLA track (and action) name of each glTF animation, in the file's order.
        fps: frames per second of the importer's keys (a sample at ``t`` s is keyed on frame ``t * fps``).
    """

    meshes: list = field(default_factory=list)
    rest: dict = field(default_factory=dict)
    clips: list[str] = field(default_factory=list)
    fps: float = 0.0


class ImportRecorder:
    """A user extension of Blender's glTF importer (it calls the hooks of the
    ``glTF2ImportUserExtension`` of every enabled add-on): once the importer has made the nodes
    and before it makes the animations, it records the rest pose, the animations' track names
    and the fps into ``imported`` (module docstring)."""

    def __init__(self):
        self.imported: Imported | None = None

    def gather_import_scene_after_nodes_hook(self, gltf_scene, blender_scene, gltf) -> None:
        rest = {}
        for obj in blender_scene.objects:
            for name, node in [("", obj)] + [(bone.name, bone) for bone in (obj.pose.bones if obj.pose else [])]:
                rest[obj.name, name] = (tuple(node.location), tuple(node.rotation_quaternion), tuple(node.scale))
        render = blender_scene.render
        self.imported = Imported(rest=rest, clips=[a.track_name for a in gltf.data.animations or []],
                                 fps=render.fps * render.fps_base)


@contextmanager
def importer_extension(extension):
    """While in the block, the glTF importer calls ``extension``'s hooks: an enabled add-on
    entry named ``IMPORT_HOOK`` whose module offers it as ``glTF2ImportUserExtension``."""
    addon = bpy.context.preferences.addons.new()
    addon.module = IMPORT_HOOK
    sys.modules[IMPORT_HOOK] = types.SimpleNamespace(glTF2ImportUserExtension=lambda: extension)
    try:
        yield
    finally:
        del sys.modules[IMPORT_HOOK]
        bpy.context.preferences.addons.remove(addon)


def import_glb(path: str) -> Imported:
    """Import a glb with Blender's glTF importer (its defaults: the file's normals, y-up turned
    to z-up, bind pose guessed from the inverse bind matrices; no custom shapes drawn for
    bones), recording its rest pose and animations (``ImportRecorder``)."""
    recorder = ImportRecorder()
    with importer_extension(recorder):
        bpy.ops.import_scene.gltf(filepath=path, disable_bone_shape=True)
    if recorder.imported is None:
        raise RuntimeError(f"{path}: the glTF importer did not call the judge's hook ({IMPORT_HOOK})")
    recorder.imported.meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    return recorder.imported


def restore_rest(imported: Imported) -> None:
    """Every imported object and pose bone back to its rest transform (``Imported.rest``)."""
    for (object_name, bone_name), (location, rotation, scale) in imported.rest.items():
        obj = bpy.data.objects[object_name]
        node = obj.pose.bones[bone_name] if bone_name else obj
        node.location, node.rotation_quaternion, node.scale = location, rotation, scale


def play(animation_data, track: str | None) -> None:
    """Make the action stashed on the NLA track named ``track`` (with its slot) the active
    action of ``animation_data``; none where it has no such track or ``track`` is ``None``.
    Every NLA track stays muted."""
    strips = [t.strips[0] for t in animation_data.nla_tracks if t.name == track and len(t.strips) > 0]
    for t in animation_data.nla_tracks:
        t.mute = True
    animation_data.action = strips[0].action if strips else None
    if strips:
        animation_data.action_slot = strips[0].action_slot


def pose_scene(scene: bpy.types.Scene, imported: Imported, pose: dict | None) -> None:
    """Pose the imported glb for one view (module docstring): the rest pose where ``pose`` is
    ``None``, else clip ``pose["clip"]`` at ``pose["time"]`` seconds."""
    if pose is not None and not 0 <= int(pose["clip"]) < len(imported.clips):
        raise ValueError(f"a view asks for animation {pose['clip']}; the glb has {len(imported.clips)}")
    restore_rest(imported)
    track = None if pose is None else imported.clips[int(pose["clip"])]
    for obj in scene.objects:
        if obj.animation_data is not None:
            play(obj.animation_data, track)
    frame = 0.0 if pose is None else float(pose["time"]) * imported.fps
    whole = math.floor(frame)
    scene.frame_set(whole, subframe=frame - whole)


def configure_cycles(scene: bpy.types.Scene, job: dict) -> None:
    """The render settings of the module docstring."""
    scene.render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples = int(job["samples"])
    cycles.use_adaptive_sampling = False
    cycles.use_denoising = False
    cycles.seed = int(job.get("seed", 0))
    bounces = int(job.get("bounces", 0))
    cycles.max_bounces = bounces
    cycles.diffuse_bounces = cycles.glossy_bounces = cycles.transmission_bounces = cycles.volume_bounces = bounces
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
    scene.world = environment_world(job["environment"], job.get("environment_turn", 0.0)) if job.get("environment") \
        else black_world()


def black_world() -> bpy.types.World:
    """A world that gives no light."""
    world = bpy.data.worlds.new("black")
    world.color = (0.0, 0.0, 0.0)
    if world.node_tree is not None:
        for node in world.node_tree.nodes:
            if node.type == "BACKGROUND":
                node.inputs["Strength"].default_value = 0.0
    return world


def environment_world(path: str, turn: float) -> bpy.types.World:
    """A world lit by the latitude-longitude map at ``path`` (strength 1, linear), turned by
    ``turn`` radians about z (``lookalike.blender.conversion.ENVIRONMENT_TURN``)."""
    world = bpy.data.worlds.new("environment")
    world.use_nodes = True
    nodes, links = world.node_tree.nodes, world.node_tree.links
    nodes.clear()
    coordinates, mapping = nodes.new("ShaderNodeTexCoord"), nodes.new("ShaderNodeMapping")
    texture, background = nodes.new("ShaderNodeTexEnvironment"), nodes.new("ShaderNodeBackground")
    output = nodes.new("ShaderNodeOutputWorld")
    texture.image = bpy.data.images.load(path)
    texture.image.colorspace_settings.name = "Linear Rec.709"
    texture.interpolation = "Linear"
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, float(turn))
    background.inputs["Strength"].default_value = 1.0
    links.new(coordinates.outputs["Generated"], mapping.inputs["Vector"])
    links.new(mapping.outputs["Vector"], texture.inputs["Vector"])
    links.new(texture.outputs["Color"], background.inputs["Color"])
    links.new(background.outputs["Background"], output.inputs["Surface"])
    return world


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
    """Run the job in ``job_path`` (module docstring): import, then every view (posed, where the
    glb has animations) once per shadow setting; write the pixels and the timings."""
    job = json.loads(Path(job_path).read_text())
    scene = reset_scene()
    started = time.monotonic()
    imported = import_glb(job["glb"])
    import_seconds = time.monotonic() - started
    configure_cycles(scene, job)
    camera, light = add_camera(scene), add_point_light(scene)
    scratch = Path(job["scratch"])
    views = job["views"]
    out = np.zeros((len(job["shadows"]), len(views), int(job["height"]), int(job["width"]), 4), dtype=np.float32)
    started = time.monotonic()
    for s, shadows in enumerate(job["shadows"]):
        for obj in imported.meshes:
            obj.visible_shadow = bool(shadows)
        for b, view in enumerate(views):
            if imported.clips:
                pose_scene(scene, imported, view.get("pose"))
            place_view(camera, light, view)
            out[s, b] = render_frame(scene, scratch / f"view-{s}-{b}.exr")
    rendering = time.monotonic() - started
    np.save(job["output"], out)
    frames = max(len(views) * len(job["shadows"]), 1)
    Path(job["stats"]).write_text(json.dumps({"import_s": import_seconds, "render_s": rendering,
                                              "seconds_per_view": rendering / frames,
                                              "triangles": sum(_triangles(o) for o in imported.meshes)}))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        raise SystemExit("usage: python -m lookalike.blender.cycles_worker JOB.json")
    main(sys.argv[1])
