"""``lookalike bench bake``: speed of the classic projection bake (``lookalike.init.bake``).

The reference is a bumpy UV sphere of 500,000 triangles with a 1024^2 base-colour texture and
a 1024^2 normal map; the low-poly mesh is a 3,200-triangle sphere with a fresh 1024^2 atlas.
Figures (medians over ``repeats``, wall and process CPU seconds; the CPU time is what the
machine's load cannot inflate):

- ``raycast_wall_s`` / ``raycast_cpu_s``: BVH build over the reference plus two rays per texel
  (``RayCaster``, ``project_along_normals``).
- ``bake_wall_s`` / ``bake_cpu_s``: the whole ``bake`` call (texels, rays, closest-point
  fallback, material and normal lookups, dilation).
- ``texels``: atlas texels covered; ``hit_fraction``: of those, hit within the cage.

Target on the 2-core reference machine: ``bake_wall_s`` <= 10.
"""

from __future__ import annotations

import statistics
import time

HELP = "speed of the classic projection bake (1024^2 texels against 500k triangles)"

TARGETS = {"bake_wall_s": 10.0}
TEXTURE_SIZE = 1024
REFERENCE_GRID = (500, 500)          # rows x columns of quads: 500,000 triangles
LOW_GRID = (40, 40)                  # 3,200 triangles


def reference_asset():
    """The 500k-triangle textured, normal-mapped bumpy sphere (see the module docstring)."""
    import numpy as np
    import torch

    from ..asset import Asset, Material, Mesh, Texture
    from .render import sphere_mesh

    v_pos, _, v_uv, tri = sphere_mesh(*REFERENCE_GRID)
    t_pos_idx = tri.long()
    mesh = Mesh(v_pos=v_pos, t_pos_idx=t_pos_idx, uv=[(v_uv, t_pos_idx.clone())])
    y, x = np.mgrid[0:TEXTURE_SIZE, 0:TEXTURE_SIZE] / TEXTURE_SIZE
    colour = np.stack([0.5 + 0.4 * np.sin(40 * x), 0.5 + 0.4 * np.cos(30 * y), 0.5 + 0.2 * np.sin(20 * (x + y)),
                       np.ones_like(x)], axis=-1)
    bump = np.stack([0.3 * np.sin(60 * x), 0.3 * np.cos(60 * y), np.ones_like(x)], axis=-1)
    bump /= np.linalg.norm(bump, axis=-1, keepdims=True)
    material = Material(kd=Texture(torch.from_numpy(colour).float()), normal=Texture(torch.from_numpy(bump).float()))
    return Asset(mesh=mesh, materials=[material])


def low_mesh():
    """The 3,200-triangle sphere, unwrapped for ``TEXTURE_SIZE``."""
    from ..asset import Mesh
    from ..init import decimate, unwrap
    from .render import sphere_mesh

    v_pos, _, _, tri = sphere_mesh(*LOW_GRID, bumpiness=0.0)
    mesh = Mesh(v_pos=v_pos, t_pos_idx=tri.long())
    # decimating to one triangle fewer welds the seam and pole copies and keeps the shape
    return unwrap(decimate(mesh, mesh.num_triangles - 1), texture_size=TEXTURE_SIZE)


def _timed(function) -> tuple[float, float, object]:
    wall, cpu = time.perf_counter(), time.process_time()
    value = function()
    return time.perf_counter() - wall, time.process_time() - cpu, value


def run(repeats: int | None = None) -> dict:
    from ..init.bake import atlas_texels, bake, default_cage, project_along_normals
    from ..init.raycast import RayCaster

    repeats = 3 if repeats is None else max(1, repeats)
    reference, low = reference_asset(), low_mesh()
    texels = atlas_texels(low, TEXTURE_SIZE)
    cage = default_cage(reference.mesh)
    positions, triangles = reference.mesh.v_pos.numpy(), reference.mesh.t_pos_idx.numpy()

    def raycast():
        return project_along_normals(RayCaster(positions, triangles), texels.position, texels.normal, cage)

    raycasts = [_timed(raycast) for _ in range(repeats)]
    bakes = [_timed(lambda: bake(reference, low, TEXTURE_SIZE)) for _ in range(repeats)]
    result = bakes[-1][2]
    return {
        "reference_triangles": reference.mesh.num_triangles,
        "low_triangles": low.num_triangles,
        "texels": result.texels,
        "hit_fraction": result.hit_fraction,
        "raycast_wall_s": statistics.median(r[0] for r in raycasts),
        "raycast_cpu_s": statistics.median(r[1] for r in raycasts),
        "bake_wall_s": statistics.median(b[0] for b in bakes),
        "bake_cpu_s": statistics.median(b[1] for b in bakes),
    }


def format_table(result: dict) -> str:
    rows = [("figure", "value", "target")]
    for key, value in result.items():
        target = TARGETS.get(key)
        rows.append((key, f"{value:.3g}" if isinstance(value, float) else f"{value:,}",
                     "" if target is None else f"<= {target:g}"))
    width = [max(len(r[i]) for r in rows) for i in range(3)]
    return "\n".join("  ".join(cell.ljust(w) for cell, w in zip(r, width)).rstrip() for r in rows)
