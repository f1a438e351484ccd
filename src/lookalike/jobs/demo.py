"""``demo``: the whole job on the bundled default asset, generated in code: a bumpy, painted
(2, 3) torus knot of 100k triangles, simplified to ``DEMO_TRIANGLES`` in a few minutes.

A tube of radius ``TUBE`` around the torus-knot curve
c(t) = ((2 + cos 3t) cos 2t, (2 + cos 3t) sin 2t, sin 3t), t = 2 pi u, u in [0, 1), with its
radius modulated by a bump field, on a ``segments x sides`` grid (two triangles per cell,
positions welded around both seams). UV u runs along the knot, v around the tube. Its
material has painted base colour (hue bands and six gold rings) with roughness and
metalness varying along with it; the ridges and knobs are geometry that a decimated mesh
loses and a normal map can bring back.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import torch

from .. import io
from ..asset import Asset, Material, Mesh, Texture
from .cards import cards
from ..samples.shrub import shrub
from .run_result import RunResult
from .simplify import simplify

DEMO_TRIANGLES = 2000
DEMO_TEXTURE_SIZE = 512
DEMO_RESOLUTION = 256
DEMO_TIME_BUDGET_S = 240.0
DEMO_CARDS_SHARE = 0.005
"""``demo --cards`` keeps this share of the generated shrub's triangles as cards."""

TUBE = 0.45
BUMP = 0.08
SEGMENTS, SIDES = 1000, 50          # 100,000 triangles
TEXTURE_HEIGHT, TEXTURE_WIDTH = 256, 1024


def knot_curve(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points ``[N, 3]`` and unit tangents ``[N, 3]`` of the (2, 3) torus knot at angles ``t [N]``."""
    r = 2 + np.cos(3 * t)
    point = np.stack([r * np.cos(2 * t), r * np.sin(2 * t), np.sin(3 * t)], axis=1)
    dr = -3 * np.sin(3 * t)
    tangent = np.stack([dr * np.cos(2 * t) - 2 * r * np.sin(2 * t),
                        dr * np.sin(2 * t) + 2 * r * np.cos(2 * t),
                        3 * np.cos(3 * t)], axis=1)
    return point, tangent / np.linalg.norm(tangent, axis=1, keepdims=True)


def bump(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Relative radius change in [-1, 1]-ish: ridges around the tube plus a knobbly pattern."""
    theta = 2 * np.pi * v
    return (0.55 * np.sin(2 * np.pi * 60 * u) ** 8
            + 0.45 * np.sin(2 * np.pi * 25 * u + 3 * theta) * np.sin(5 * theta))


def knot_mesh(segments: int = SEGMENTS, sides: int = SIDES) -> Mesh:
    """The tube mesh: ``segments * sides`` welded vertices, ``2 * segments * sides`` triangles."""
    u = np.arange(segments) / segments
    v = np.arange(sides) / sides
    centre, tangent = knot_curve(2 * np.pi * u)
    side = np.cross(tangent, [0.0, 0.0, 1.0])  # never zero: the knot's tangent always has an xy part
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    up = np.cross(tangent, side)
    theta = 2 * np.pi * v
    uu, vv = np.meshgrid(u, v, indexing="ij")
    radius = TUBE * (1 + BUMP * bump(uu, vv))
    ring = np.cos(theta)[None, :, None] * side[:, None] + np.sin(theta)[None, :, None] * up[:, None]
    v_pos = (centre[:, None] + radius[..., None] * ring).reshape(-1, 3)

    i, j = np.meshgrid(np.arange(segments), np.arange(sides), indexing="ij")
    i1, j1 = (i + 1) % segments, (j + 1) % sides
    a, b, c, d = i * sides + j, i1 * sides + j, i1 * sides + j1, i * sides + j1
    t_pos_idx = np.stack([np.stack([a, d, b], -1), np.stack([b, d, c], -1)], axis=2).reshape(-1, 3)

    # UVs: an unwelded (segments + 1) x (sides + 1) grid, so both seams are cut in UV space
    tu, tv = np.meshgrid(np.arange(segments + 1) / segments, np.arange(sides + 1) / sides, indexing="ij")
    v_tex = np.stack([tu, tv], axis=-1).reshape(-1, 2)
    ta, tb = i * (sides + 1) + j, (i + 1) * (sides + 1) + j
    tc, td = (i + 1) * (sides + 1) + j + 1, i * (sides + 1) + j + 1
    t_tex_idx = np.stack([np.stack([ta, td, tb], -1), np.stack([tb, td, tc], -1)], axis=2).reshape(-1, 3)
    return Mesh(v_pos=torch.from_numpy(v_pos).float(), t_pos_idx=torch.from_numpy(t_pos_idx).long(),
                uv=[(torch.from_numpy(v_tex).float(), torch.from_numpy(t_tex_idx).long())])


def paint(height: int = TEXTURE_HEIGHT, width: int = TEXTURE_WIDTH) -> tuple[np.ndarray, np.ndarray]:
    """Base colour + alpha ``[H, W, 4]`` and (gamma, roughness, metalness) ``[H, W, 3]``, linear."""
    u = (np.arange(width) + 0.5) / width
    v = (np.arange(height) + 0.5) / height
    uu, vv = np.meshgrid(u, v)  # rows follow v, columns u
    hue = 2 * np.pi * (3 * uu + 0.15 * np.sin(2 * np.pi * 2 * vv))
    base = 0.4 + 0.3 * np.stack([np.cos(hue), np.cos(hue - 2.1), np.cos(hue + 2.1)], axis=-1)
    gold = (np.cos(2 * np.pi * 6 * uu) > 0.8)[..., None]
    kd = np.where(gold, [1.0, 0.72, 0.3], base).clip(0.02, 1.0) ** 2.2
    roughness = np.where(gold[..., 0], 0.25, 0.6 + 0.15 * np.sin(hue))
    metalness = gold[..., 0].astype(np.float64)
    ks = np.stack([np.zeros_like(roughness), roughness, metalness], axis=-1)
    kd = np.concatenate([kd, np.ones_like(kd[..., :1])], axis=-1)
    return kd.astype(np.float32), ks.astype(np.float32)


def demo_asset(triangles: int = 2 * SEGMENTS * SIDES) -> Asset:
    """The default asset of ``lookalike demo`` (100k triangles), one textured material; other
    ``triangles`` tessellate the same shape finer or coarser (``SEGMENTS x SIDES`` scaled by
    ``sqrt(triangles / 100k)``, so cells keep their shape)."""
    scale = (triangles / (2 * SEGMENTS * SIDES)) ** 0.5
    kd, ks = paint()
    material = Material(name="painted", kd=Texture(torch.from_numpy(kd)), ks=Texture(torch.from_numpy(ks)))
    return Asset(mesh=knot_mesh(max(3, round(SEGMENTS * scale)), max(3, round(SIDES * scale))), materials=[material])


def demo(outdir: str | Path = "lookalike-demo", time_budget: float = DEMO_TIME_BUDGET_S, force: bool = False,
         progress: bool = True) -> RunResult:
    """``simplify`` of ``demo_asset()`` (written to a temporary glTF first, as a user's file
    would be) to ``DEMO_TRIANGLES`` triangles with ``DEMO_TEXTURE_SIZE`` textures and
    ``DEMO_RESOLUTION`` views, within ``time_budget`` seconds, into ``outdir``."""
    with tempfile.TemporaryDirectory(prefix="lookalike-demo-") as folder:
        source = Path(folder) / "painted-knot.glb"
        io.save(demo_asset(), source)
        return simplify(source, outdir, triangles=DEMO_TRIANGLES, texture_size=DEMO_TEXTURE_SIZE,
                        resolution=DEMO_RESOLUTION, time_budget=time_budget, force=force, progress=progress)


def demo_cards(outdir: str | Path = "lookalike-cards-demo", time_budget: float = DEMO_TIME_BUDGET_S,
               force: bool = False, progress: bool = True) -> RunResult:
    """``cards`` of the generated shrub (``lookalike.samples.shrub``, written to a temporary glTF
    first) to ``DEMO_CARDS_SHARE`` of its triangles, with ``DEMO_TEXTURE_SIZE`` textures and
    ``DEMO_RESOLUTION`` views, within ``time_budget`` seconds, into ``outdir``."""
    with tempfile.TemporaryDirectory(prefix="lookalike-demo-") as folder:
        source = Path(folder) / "shrub.glb"
        asset = shrub()
        io.save(asset, source)
        return cards(source, outdir, triangles=max(2, round(DEMO_CARDS_SHARE * asset.mesh.num_triangles)),
                     texture_size=DEMO_TEXTURE_SIZE, resolution=DEMO_RESOLUTION, time_budget=time_budget,
                     force=force, progress=progress)
