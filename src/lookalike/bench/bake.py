"""``lookalike bench bake``: speed of the classic projection bake (``lookalike.init.projection_bake``).

The reference is a bumpy UV sphere of 500,000 triangles with a 1024^2 base-colour texture and
a 1024^2 normal map; the low-poly mesh is a 3,200-triangle sphere with a fresh 1024^2 atlas.
Figures (medians over ``repeats``, wall and process CPU seconds; the CPU time is what the
machine's load cannot inflate):

- ``raycast_wall_s`` / ``raycast_cpu_s``: finding the reference point of every texel
  (``locate_on_reference``: BVH build, two rays along each of a texel's two lines,
  closest-point fallback).
- ``bake_wall_s`` / ``bake_cpu_s``: the whole ``bake`` call (texels, rays, closest-point
  fallback, material and normal lookups, filling uncovered texels).
- ``texels``: atlas texels covered (xatlas fills about half of the square);
  ``hit_fraction``: of those, hit within the cage.
- ``million_texels_wall_s`` / ``million_texels_cpu_s``: the same bake into a 1536^2 atlas,
  which covers more than 2^20 texels (``million_texels``).

Target on the 2-core reference machine: ``bake_wall_s`` <= 10 (and ``million_texels_wall_s``).
"""

from __future__ import annotations

import statistics
import time

HELP = "speed of the classic projection bake (1024^2 texels against 500k triangles)"

TARGETS = {"bake_wall_s": 10.0, "million_texels_wall_s": 10.0}
TEXTURE_SIZE = 1024
MILLION_TEXELS_SIZE = 1536
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


def low_mesh(texture_size: int = TEXTURE_SIZE):
    """The 3,200-triangle sphere, unwrapped for ``texture_size``."""
    from ..asset import Mesh
    from ..init import decimate, unwrap
    from .render import sphere_mesh

    v_pos, _, _, tri = sphere_mesh(*LOW_GRID, bumpiness=0.0)
    mesh = Mesh(v_pos=v_pos, t_pos_idx=tri.long())
    # decimating to one triangle fewer welds the seam and pole copies and keeps the shape
    return unwrap(decimate(mesh, mesh.num_triangles - 1), texture_size=texture_size)


def _timed(function) -> tuple[float, float, object]:
    wall, cpu = time.perf_counter(), time.process_time()
    value = function()
    return time.perf_counter() - wall, time.process_time() - cpu, value


def run(repeats: int | None = None) -> dict:
    from ..init.projection_bake import atlas_texels, bake, default_cage, locate_on_reference

    repeats = 3 if repeats is None else max(1, repeats)
    reference, low = reference_asset(), low_mesh()
    texels = atlas_texels(low, TEXTURE_SIZE)
    cage = default_cage(reference.mesh)
    raycasts = [_timed(lambda: locate_on_reference(reference, texels, cage)) for _ in range(repeats)]
    bakes = [_timed(lambda: bake(reference, low, TEXTURE_SIZE)) for _ in range(repeats)]
    result = bakes[-1][2]
    big = low_mesh(MILLION_TEXELS_SIZE)
    big_bakes = [_timed(lambda: bake(reference, big, MILLION_TEXELS_SIZE)) for _ in range(repeats)]
    return {
        "reference_triangles": reference.mesh.num_triangles,
        "low_triangles": low.num_triangles,
        "texels": result.texels,
        "hit_fraction": result.hit_fraction,
        "raycast_wall_s": statistics.median(r[0] for r in raycasts),
        "raycast_cpu_s": statistics.median(r[1] for r in raycasts),
        "bake_wall_s": statistics.median(b[0] for b in bakes),
        "bake_cpu_s": statistics.median(b[1] for b in bakes),
        "million_texels": big_bakes[-1][2].texels,
        "million_texels_wall_s": statistics.median(b[0] for b in big_bakes),
        "million_texels_cpu_s": statistics.median(b[1] for b in big_bakes),
    }


def format_table(result: dict) -> str:
    rows = [("figure", "value", "target")]
    for key, value in result.items():
        target = TARGETS.get(key)
        rows.append((key, f"{value:.3g}" if isinstance(value, float) else f"{value:,}",
                     "" if target is None else f"<= {target:g}"))
    width = [max(len(r[i]) for r in rows) for i in range(3)]
    return "\n".join("  ".join(cell.ljust(w) for cell, w in zip(r, width)).rstrip() for r in rows)
