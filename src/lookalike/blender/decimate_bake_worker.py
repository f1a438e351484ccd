"""The Blender side of ``lookalike.blender.decimate_bake``: Blender's classic LOD pipeline.

Run as ``python -m lookalike.blender.decimate_bake_worker JOB.json``; imports only ``bpy``,
``xatlas``, NumPy and the standard library. The job (JSON) holds ``reference`` (a glb),
``output`` (the glb to write), ``stats`` (a JSON file for timings), ``scratch`` (a folder for
the baked PNGs), ``triangles``, ``texture_size``, ``padding``, ``samples``, ``threads``,
``cage_fraction``, ``margin``, ``base_colour_pass`` (``"DIFFUSE"`` or ``"EMIT"``) and
``sharp_angle`` (degrees, or null: shade smooth everywhere); with
``positions`` (a path), it stops after step 2 and writes the decimation there (``write_positions``:
``lookalike bench decimate`` measures Blender's Decimate alone); with ``keep_materials`` true, it
stops after step 2 and exports the decimated mesh with the input's own materials and UVs
(``export_low``: plain decimation as a Blender user makes it, a leaf texture kept whole).

Steps, as a Blender user does them:

1. Import the reference (glTF importer, "Merge Vertices" on, so that UV and normal seams do not
   cut the surface into pieces the decimation would keep apart).
2. Duplicate it (every mesh object, transforms applied, joined into one, its coincident vertices
   merged: the importer merges a position's vertices only where their normals agree, so a hard
   edge's would still cut it) as the low-poly; add a Decimate modifier (COLLAPSE, ratio = target
   triangles / input triangles, triangulate) and apply it; clear the custom normals and shade
   smooth, or smooth by angle (edges whose faces meet at more than ``sharp_angle`` sharp, as
   Blender's Shade Auto Smooth does for hard-surface models).
3. Unwrap with xatlas (one atlas for ``texture_size`` texels with ``padding`` texels between
   charts, as ``lookalike.init.unwrap``) and make it the only UV map.
4. A new material: Principled BSDF fed by new images at the texture size (base colour sRGB,
   metallic-roughness and normal non-colour).
5. Bake with Cycles, selected (the reference) to active (the low-poly), no cage object: rays
   start ``cage_extrusion`` = ``cage_fraction`` x the reference's bounding-box diagonal above
   the low-poly surface and reach ``max_ray_distance`` = twice that (so as far below it), the
   same reach as our bake; margin ``margin`` texels (Blender's default margin type, adjacent
   faces). Passes: NORMAL (tangent space, +X +Y +Z: glTF's convention), DIFFUSE with only the
   COLOR pass (with every source's metalness and specular level at 0 meanwhile: Cycles' diffuse
   colour is ``base (1 - metallic)`` darkened by the share the dielectric specular layer
   reflects, about 4 %; ``PlainDiffuse``), ROUGHNESS, and metalness through EMIT (each source material's
   metallic input temporarily wired into an Emission shader); alpha the same way where a
   source material has any.
6. Pack roughness (G) and metalness (B) into one image and export a glb (glTF exporter).
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import bpy
import numpy as np
import xatlas

MERGE_DISTANCE = 1e-7
"""Vertices of the low-poly copy closer than this share of its bounding diagonal are one
(``merge_coincident``): the glTF exporter's copies of one position, nothing a model means apart."""

FIRST_FILL, SHRINK, ATTEMPTS = 0.75, 0.9, 12
"""xatlas texel density: first guess (times texture size, at unit area), shrink factor, tries
(the same search as ``lookalike.init.unwrap``)."""


def reset_scene() -> bpy.types.Scene:
    """An empty scene (factory settings, no objects)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene


def select_only(objects: list, active) -> None:
    """Select exactly ``objects`` and make ``active`` the active object."""
    for obj in bpy.context.view_layer.objects:
        obj.select_set(False)
    for obj in objects:
        obj.select_set(True)
    bpy.context.view_layer.objects.active = active


def triangle_count(objects: list) -> int:
    """Triangles of the mesh objects (their polygons triangulated)."""
    total = 0
    for obj in objects:
        obj.data.calc_loop_triangles()
        total += len(obj.data.loop_triangles)
    return total


def duplicate_joined(objects: list):
    """One new mesh object holding copies of ``objects`` with their world transforms applied, its
    coincident vertices merged (``merge_coincident``)."""
    copies = []
    for obj in objects:
        copy = obj.copy()
        copy.data = obj.data.copy()
        copy.parent = None
        copy.data.transform(obj.matrix_world)
        copy.matrix_world.identity()
        bpy.context.scene.collection.objects.link(copy)
        copies.append(copy)
    if len(copies) > 1:
        select_only(copies, copies[0])
        bpy.ops.object.join()
    low = copies[0]
    low.name = "lowpoly"
    merge_coincident(low)
    return low


def merge_coincident(obj) -> None:
    """Merge the vertices of ``obj`` that lie within ``MERGE_DISTANCE`` of its bounding
    diagonal of one another (Blender's "Merge by Distance")."""
    import bmesh

    points = np.empty(3 * len(obj.data.vertices))
    obj.data.vertices.foreach_get("co", points)
    points = points.reshape(-1, 3)
    diagonal = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0))) if len(points) else 0.0
    work = bmesh.new()
    work.from_mesh(obj.data)
    bmesh.ops.remove_doubles(work, verts=work.verts, dist=MERGE_DISTANCE * diagonal)
    work.to_mesh(obj.data)
    work.free()


def decimate(low, ratio: float, sharp_angle: float | None = None) -> None:
    """Decimate modifier (COLLAPSE, triangulate) applied; then every face a triangle, custom
    normals cleared, smooth shading (with ``sharp_angle``, smooth by angle: edges whose faces
    meet at more than that many degrees sharp)."""
    import bmesh

    modifier = low.modifiers.new("decimate", "DECIMATE")
    modifier.decimate_type = "COLLAPSE"
    modifier.ratio = min(max(ratio, 0.0), 1.0)
    modifier.use_collapse_triangulate = True
    select_only([low], low)
    bpy.ops.object.modifier_apply(modifier=modifier.name)
    mesh = low.data
    work = bmesh.new()
    work.from_mesh(mesh)
    bmesh.ops.triangulate(work, faces=[f for f in work.faces if len(f.verts) > 3])
    work.to_mesh(mesh)
    work.free()
    if mesh.has_custom_normals:
        bpy.ops.mesh.customdata_custom_splitnormals_clear()
    mesh.shade_smooth()
    if sharp_angle is not None:
        mesh.set_sharp_from_angle(angle=math.radians(sharp_angle))


def write_positions(mesh, path: str, seconds: float) -> None:
    """The triangle ``mesh``'s positions ``[V, 3]`` in glTF's axes (Blender's Z up turned back
    to Y up), its triangles ``[T, 3]`` and ``seconds`` as an ``.npz`` at ``path``."""
    positions = np.empty(len(mesh.vertices) * 3, np.float64)
    mesh.vertices.foreach_get("co", positions)
    x, y, z = positions.reshape(-1, 3).T
    faces = np.empty(len(mesh.polygons) * 3, np.int64)
    mesh.polygons.foreach_get("vertices", faces)
    np.savez(path, v_pos=np.stack([x, z, -y], axis=1), t_pos_idx=faces.reshape(-1, 3), seconds=seconds)


def xatlas_uvs(mesh, texture_size: int, padding: int) -> np.ndarray:
    """``[T*3, 2]`` float32 UVs (Blender's convention, v up) of every loop of the triangle mesh,
    from an xatlas atlas (module docstring, step 3)."""
    v_pos = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", v_pos)
    v_pos = v_pos.reshape(-1, 3).astype(np.float64)
    faces = np.empty(len(mesh.polygons) * 3, np.int32)
    mesh.polygons.foreach_get("vertices", faces)
    faces = faces.reshape(-1, 3)
    corners = v_pos[faces]
    area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1).sum()
    unit = (v_pos / np.sqrt(max(area, 1e-30))).astype(np.float32)
    texels_per_unit = FIRST_FILL * texture_size
    for _ in range(ATTEMPTS):
        atlas = xatlas.Atlas()
        atlas.add_mesh(unit, faces.astype(np.uint32))
        pack = xatlas.PackOptions()
        pack.resolution, pack.padding, pack.bilinear, pack.texels_per_unit = texture_size, padding, True, texels_per_unit
        atlas.generate(xatlas.ChartOptions(), pack)
        if atlas.atlas_count == 1:
            break
        texels_per_unit *= SHRINK
    else:
        raise RuntimeError(f"no xatlas atlas of {texture_size} texels fits the decimated mesh")
    _, indices, uvs = atlas[0]
    uvs = uvs * np.array([atlas.width, atlas.height], np.float32) / texture_size
    loop_uv = uvs[indices.reshape(-1)]
    loop_uv[:, 1] = 1.0 - loop_uv[:, 1]
    return loop_uv.astype(np.float32)


def set_only_uv_map(mesh, loop_uv: np.ndarray) -> str:
    """Replace every UV map of ``mesh`` with one holding ``loop_uv [loops, 2]``; returns its name."""
    while mesh.uv_layers:
        mesh.uv_layers.remove(mesh.uv_layers[0])
    layer = mesh.uv_layers.new(name="UVMap")
    starts = np.empty(len(mesh.polygons), np.int32)
    mesh.polygons.foreach_get("loop_start", starts)
    order = (starts[:, None] + np.arange(3)[None]).reshape(-1)
    uv = np.empty((len(mesh.loops), 2), np.float32)
    uv[order] = loop_uv
    layer.uv.foreach_set("vector", uv.reshape(-1))
    return layer.name


def new_image(name: str, size: int, colour_space: str, alpha: bool = False):
    """A new 8-bit ``size x size`` image in ``colour_space`` (``"sRGB"`` or ``"Non-Color"``)."""
    image = bpy.data.images.new(name, size, size, alpha=alpha, float_buffer=False)
    image.colorspace_settings.name = colour_space
    return image


class BakeMaterial:
    """The low-poly's material: a Principled BSDF and one image node per baked channel."""

    def __init__(self, size: int, uv_name: str, with_alpha: bool):
        material = bpy.data.materials.new("baked")
        material.use_nodes = True
        nodes, links = material.node_tree.nodes, material.node_tree.links
        self.material, self.nodes, self.links = material, nodes, links
        self.principled = next(n for n in nodes if n.type == "BSDF_PRINCIPLED")
        self.images = {
            "base": new_image("base_color", size, "sRGB", alpha=with_alpha),
            "roughness": new_image("roughness", size, "Non-Color"),
            "metallic": new_image("metallic", size, "Non-Color"),
            "normal": new_image("normal", size, "Non-Color"),
        }
        if with_alpha:
            self.images["alpha"] = new_image("alpha", size, "Non-Color")
        self.texture_nodes = {}
        for key, image in self.images.items():
            node = nodes.new("ShaderNodeTexImage")
            node.image = image
            self.texture_nodes[key] = node
        uv = nodes.new("ShaderNodeUVMap")
        uv.uv_map = uv_name
        for node in self.texture_nodes.values():
            links.new(uv.outputs["UV"], node.inputs["Vector"])

    def bake_target(self, key: str) -> None:
        """Make the image node of ``key`` the one Cycles bakes into."""
        self.nodes.active = self.texture_nodes[key]

    def wire_for_export(self, scratch: Path, uv_name: str) -> None:
        """Connect the baked images to the Principled BSDF the way the glTF exporter reads them:
        base colour (+ alpha), one metallic-roughness image through Separate Color (G roughness,
        B metalness), and the normal map through a tangent-space Normal Map node."""
        nodes, links, principled = self.nodes, self.links, self.principled
        size = self.images["base"].size[0]
        if "alpha" in self.images:
            base = pixels(self.images["base"])
            base[:, 3] = pixels(self.images["alpha"])[:, 0]
            self.images["base"].pixels.foreach_set(base.reshape(-1))
        packed = new_image("metallic_roughness", size, "Non-Color")
        mr = np.ones((size * size, 4), np.float32)
        mr[:, 1] = pixels(self.images["roughness"])[:, 0]
        mr[:, 2] = pixels(self.images["metallic"])[:, 0]
        packed.pixels.foreach_set(mr.reshape(-1))
        for key, image in [("base", self.images["base"]), ("metallic_roughness", packed), ("normal", self.images["normal"])]:
            image.filepath_raw = str(scratch / f"{key}.png")
            image.file_format = "PNG"
            image.save()
        base_node = self.texture_nodes["base"]
        links.new(base_node.outputs["Color"], principled.inputs["Base Color"])
        if "alpha" in self.images:
            links.new(base_node.outputs["Alpha"], principled.inputs["Alpha"])
        mr_node = nodes.new("ShaderNodeTexImage")
        mr_node.image = packed
        links.new(self.texture_nodes["base"].inputs["Vector"].links[0].from_socket, mr_node.inputs["Vector"])
        separate = nodes.new("ShaderNodeSeparateColor")
        links.new(mr_node.outputs["Color"], separate.inputs["Color"])
        links.new(separate.outputs["Green"], principled.inputs["Roughness"])
        links.new(separate.outputs["Blue"], principled.inputs["Metallic"])
        normal_map = nodes.new("ShaderNodeNormalMap")
        normal_map.space = "TANGENT"
        normal_map.uv_map = uv_name
        links.new(self.texture_nodes["normal"].outputs["Color"], normal_map.inputs["Color"])
        links.new(normal_map.outputs["Normal"], principled.inputs["Normal"])
        for key in ("roughness", "metallic", "alpha"):
            if key in self.texture_nodes:
                nodes.remove(self.texture_nodes[key])


def pixels(image) -> np.ndarray:
    """``[H*W, 4]`` float32 pixels of an image (Blender's row order, bottom first)."""
    out = np.empty(image.size[0] * image.size[1] * 4, np.float32)
    image.pixels.foreach_get(out)
    return out.reshape(-1, 4)


def principled_nodes(material) -> list:
    """The Principled BSDF nodes of a node material."""
    return [n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED"] if material and material.node_tree else []


def source_materials(objects: list) -> list:
    """The distinct node materials of ``objects``."""
    seen = {}
    for obj in objects:
        for slot in obj.material_slots:
            if slot.material is not None and slot.material.node_tree is not None:
                seen[slot.material.name] = slot.material
    return list(seen.values())


def uses_alpha(materials: list) -> bool:
    """Whether any source Principled BSDF has an alpha below 1 or a texture on it."""
    return any(p.inputs["Alpha"].is_linked or p.inputs["Alpha"].default_value < 1.0
               for m in materials for p in principled_nodes(m))


class EmitInput:
    """Context manager: every source material's output shows one Principled input as emission
    (its link, or its value), so that an EMIT bake copies that input; restored on exit."""

    def __init__(self, materials: list, socket: str):
        self.materials, self.socket, self.saved = materials, socket, []

    def __enter__(self):
        for material in self.materials:
            tree = material.node_tree
            principled = principled_nodes(material)
            outputs = [n for n in tree.nodes if n.type == "OUTPUT_MATERIAL"]
            if not principled or not outputs:
                continue
            source = principled[0].inputs[self.socket]
            emission = tree.nodes.new("ShaderNodeEmission")
            emission.inputs["Strength"].default_value = 1.0
            if source.is_linked:
                tree.links.new(source.links[0].from_socket, emission.inputs["Color"])
            elif hasattr(source.default_value, "__len__"):                     # a colour
                emission.inputs["Color"].default_value = (*tuple(source.default_value)[:3], 1.0)
            else:
                value = float(source.default_value)
                emission.inputs["Color"].default_value = (value, value, value, 1.0)
            surface = outputs[0].inputs["Surface"]
            previous = surface.links[0].from_socket if surface.is_linked else None
            tree.links.new(emission.outputs["Emission"], surface)
            self.saved.append((tree, emission, surface, previous))
        return self

    def __exit__(self, *exc):
        for tree, emission, surface, previous in self.saved:
            tree.nodes.remove(emission)
            if previous is not None:
                tree.links.new(previous, surface)
        return False


class PlainDiffuse:
    """Context manager: every source Principled BSDF's ``Metallic`` and ``Specular IOR Level``
    inputs at 0 (unlinked); restored on exit. Cycles' DIFFUSE COLOR pass is the weight of the
    diffuse closure: ``base colour (1 - metallic)``, further scaled by the share of light the
    dielectric specular layer leaves to it (about 0.96 at normal incidence); with both at 0 it is
    the base colour."""

    SOCKETS = ("Metallic", "Specular IOR Level")

    def __init__(self, materials: list):
        self.materials, self.saved = materials, []

    def __enter__(self):
        for material in self.materials:
            for principled in principled_nodes(material):
                for name in self.SOCKETS:
                    socket = principled.inputs[name]
                    previous = socket.links[0].from_socket if socket.is_linked else None
                    for link in list(socket.links):
                        material.node_tree.links.remove(link)
                    self.saved.append((material.node_tree, socket, previous, socket.default_value))
                    socket.default_value = 0.0
        return self

    def __exit__(self, *exc):
        for tree, socket, previous, value in self.saved:
            socket.default_value = value
            if previous is not None:
                tree.links.new(previous, socket)
        return False


def configure_bake(scene, job: dict, diagonal: float) -> None:
    """Cycles bake settings of the module docstring (step 5); ``diagonal`` is the reference's
    bounding-box diagonal."""
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = int(job["samples"])
    scene.cycles.use_denoising = False
    scene.cycles.use_adaptive_sampling = False
    scene.render.threads_mode = "FIXED"
    scene.render.threads = max(1, int(job["threads"]))
    bake = scene.render.bake
    bake.use_selected_to_active = True
    bake.use_cage = False
    bake.cage_extrusion = float(job["cage_fraction"]) * diagonal
    bake.max_ray_distance = 2.0 * float(job["cage_fraction"]) * diagonal
    bake.margin = int(job["margin"])
    bake.use_clear = True
    bake.target = "IMAGE_TEXTURES"
    bake.normal_space = "TANGENT"
    bake.normal_r, bake.normal_g, bake.normal_b = "POS_X", "POS_Y", "POS_Z"


def bake(kind: str, **options) -> float:
    """One ``bpy.ops.object.bake`` call; returns its wall seconds."""
    started = time.monotonic()
    bpy.ops.object.bake(type=kind, **options)
    return time.monotonic() - started


def bounding_diagonal(objects: list) -> float:
    """Diagonal of the world-space bounding box of ``objects``."""
    from mathutils import Vector

    points = [obj.matrix_world @ Vector(corner) for obj in objects for corner in obj.bound_box]
    lo = np.min(np.array(points), axis=0)
    hi = np.max(np.array(points), axis=0)
    return float(np.linalg.norm(hi - lo))


def main(job_path: str) -> None:
    """Run the job in ``job_path``: the steps of the module docstring; write the glb and the
    timings."""
    job = json.loads(Path(job_path).read_text())
    scratch = Path(job["scratch"])
    timings = {}
    scene = reset_scene()
    started = time.monotonic()
    bpy.ops.import_scene.gltf(filepath=job["reference"], merge_vertices=True)
    high = [o for o in scene.objects if o.type == "MESH"]
    input_triangles = triangle_count(high)
    timings["import"] = time.monotonic() - started

    started = time.monotonic()
    low = duplicate_joined(high)
    decimate(low, float(job["triangles"]) / max(input_triangles, 1), job.get("sharp_angle"))
    timings["decimate"] = time.monotonic() - started
    if job.get("positions"):
        write_positions(low.data, job["positions"], timings["decimate"])
        return
    if job.get("keep_materials"):
        timings["export"] = export_low(high, low, job["output"])
        write_stats(job["stats"], input_triangles, low, timings)
        return

    started = time.monotonic()
    uv_name = set_only_uv_map(low.data, xatlas_uvs(low.data, int(job["texture_size"]), int(job["padding"])))
    timings["unwrap"] = time.monotonic() - started

    sources = source_materials(high)
    material = BakeMaterial(int(job["texture_size"]), uv_name, uses_alpha(sources))
    low.data.materials.clear()
    low.data.materials.append(material.material)
    low.data.polygons.foreach_set("material_index", np.zeros(len(low.data.polygons), np.int32))
    configure_bake(scene, job, bounding_diagonal(high))
    select_only(high + [low], low)

    material.bake_target("normal")
    timings["bake normal"] = bake("NORMAL")
    material.bake_target("base")
    if job.get("base_colour_pass", "DIFFUSE") == "EMIT":
        with EmitInput(sources, "Base Color"):
            timings["bake base colour"] = bake("EMIT")
    else:
        with PlainDiffuse(sources):
            timings["bake base colour"] = bake("DIFFUSE", pass_filter={"COLOR"})
    material.bake_target("roughness")
    timings["bake roughness"] = bake("ROUGHNESS")
    material.bake_target("metallic")
    with EmitInput(sources, "Metallic"):
        timings["bake metalness"] = bake("EMIT")
    if "alpha" in material.images:
        material.bake_target("alpha")
        with EmitInput(sources, "Alpha"):
            timings["bake alpha"] = bake("EMIT")

    material.wire_for_export(scratch, uv_name)
    timings["export"] = export_low(high, low, job["output"])
    write_stats(job["stats"], input_triangles, low, timings)


def export_low(high: list, low, path: str) -> float:
    """Export ``low`` alone (the reference's objects ``high`` hidden) as a glb with its
    materials, normals and UVs, y up; the seconds it took."""
    started = time.monotonic()
    for obj in high:
        obj.hide_render = True
    select_only([low], low)
    bpy.ops.export_scene.gltf(filepath=path, export_format="GLB", use_selection=True,
                              export_materials="EXPORT", export_image_format="AUTO", export_normals=True,
                              export_texcoords=True, export_tangents=False, export_yup=True, export_apply=True,
                              export_animations=False, export_cameras=False, export_lights=False)
    return time.monotonic() - started


def write_stats(path: str, input_triangles: int, low, timings: dict) -> None:
    """The job's ``stats`` JSON: the triangle counts and the seconds of each step."""
    Path(path).write_text(json.dumps({"input_triangles": input_triangles, "triangles": triangle_count([low]),
                                      "seconds": timings}))


if __name__ == "__main__":
    if len(sys.argv) != 2:
        raise SystemExit("usage: python -m lookalike.blender.decimate_bake_worker JOB.json")
    main(sys.argv[1])
