"""The Blender side of ``lookalike.blender.displaced``: ``displace``'s base mesh and
displacement map applied in Blender, as the README tells a user to.

Run as ``python -m lookalike.blender.displace_worker JOB.json``; imports only ``bpy``, NumPy
and the standard library. The job (JSON) holds ``base`` (``base.glb``), ``heights``
(``displacement.png``), ``level``, ``scale``, ``offset`` (from the material's ``extras.displacement``) and ``output``
(an ``.npy`` for the displaced positions, ``[V, 3]`` float64 in glTF's frame, y up).

Steps, as a Blender user does them:

1. Import ``base.glb`` (glTF importer, "Merge Vertices" on: the file splits vertices at UV
   seams, which would open the surface into pieces).
2. Subdivide ``level`` times in Edit Mode (Edge > Subdivide, 1 cut, no smoothness: each
   triangle into 4 at its edge midpoints; a Subdivision Surface modifier's Simple mode makes
   quads of triangles instead, and moves no vertex but places others).
3. Add a Displace modifier: a new Image texture with the heights image (Color Space
   "Non-Color", Extension "Extend"), Texture Coordinates UV, Direction Normal, Strength
   ``scale``, Midlevel ``offset``; apply it.
"""

from __future__ import annotations

import json
import sys

import bpy
import bmesh  # bpy's module, importable once bpy is
import numpy as np


def main(job_path: str) -> None:
    job = json.loads(open(job_path).read())
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=job["base"], merge_vertices=True)
    obj = next(o for o in bpy.context.scene.objects if o.type == "MESH")
    mesh = obj.data
    for _ in range(job["level"]):
        editing = bmesh.new()
        editing.from_mesh(mesh)
        bmesh.ops.subdivide_edges(editing, edges=editing.edges[:], cuts=1, use_grid_fill=True)
        editing.to_mesh(mesh)
        editing.free()
    image = bpy.data.images.load(job["heights"])
    image.colorspace_settings.name = "Non-Color"
    texture = bpy.data.textures.new("heights", "IMAGE")
    texture.image = image
    texture.extension = "EXTEND"
    modifier = obj.modifiers.new("Displace", "DISPLACE")
    modifier.texture = texture
    modifier.texture_coords = "UV"
    modifier.direction = "NORMAL"
    modifier.strength = job["scale"]
    modifier.mid_level = job["offset"]
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
    world = np.array(obj.matrix_world)
    points = np.array([tuple(v.co) for v in evaluated.vertices], np.float64)
    points = points @ world[:3, :3].T + world[:3, 3]
    y_up = np.stack([points[:, 0], points[:, 2], -points[:, 1]], axis=1)  # Blender's z up back to glTF's y up
    np.save(job["output"], y_up)


if __name__ == "__main__":
    main(sys.argv[1])
