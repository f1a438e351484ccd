"""``displace``: one coarse base mesh and one set of maps (displacement, normal, base colour,
specular) that look right at every tessellation level (paper Sec. 5.1, and its supplement's
tessellation as level of detail).

The start is the classic displacement bake, as artists make one: ``simplify``'s decimation and
atlas at the base count, smooth (one normal per position: a hard edge would be two vertices in
every engine, and displaced apart), its displacement map baked as the distance from the
subdivided base to the input along each vertex's displacement direction
(``lookalike.init.displacement_bake``), its other maps baked on the displaced surface. With
``latent.displacement_shading`` ``"engine"`` (the default) shading reads the normal map in the
base's interpolated frame at every level, so the maps are baked at the finest level, nearest the
input; with ``"recomputed"`` each level shades its own relief and a normal map baked at one level
suits the levels near it best, so they are baked at the middle one (``docs/benchmarks.md``). With
engine shading the fitted model's coarse levels straddle the finest level's relief
(``Displacement.detail_level``) where the classic bake's read the map at their vertices alone
and cut under it. The latent (``lookalike.fit.displaced_mesh``) fits the heights (by default;
the base positions and maps too where their learning rates are set), each step at the next of
``latent.tessellation_levels``, the levels' losses balanced and the steps shared towards the
level that gains least, its states chosen on the least gain over the start among the levels (so
that every level gains). The report scores every level beside the start at that level and the
classic decimate + bake at the same triangle count. Outputs besides the run's (``model.glb`` is the finest level):
``base.glb`` (the base mesh and its maps, the displacement map in the material's ``extras``),
``displacement.png`` (16-bit heights; also ``.exr`` where the ``OpenEXR`` package is installed)
and ``lodK.glb``, level K tessellated and displaced, for engines without tessellation
(``written_level``: on the displaced geometry's own normals, the normal map re-expressed to
shade as the engine convention does).
"""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

import numpy as np

from .. import io
from ..asset import Asset
from ..asset.displacement import displaced, stitched_displacement, tessellated
from ..errors import ConfigError
from ..init import decimate
from ..init.displacement_bake import bake_displacement
from ..init.initial_guess import InitialGuess, Ranges, initial_guess
from ..init.projection_bake import bake
from ..io.glb_bytes import to_glb_bytes
from ..io.gpu_memory import gpu_bytes
from ..io.image_files import write_png
from ..io.normal_frames import on_own_normals
from ..phases import phase
from ..fit.displaced_mesh import DisplacedMesh
from ..report.record import MethodResult
from ..settings import Config, LatentConfig, OptimConfig
from .run import TEXTURE_STREAM, Application, keywords_doc, mesh_latent, run
from .run_result import RunResult
from .simplify import build_initial_guess

DISPLACE_DEFAULTS = Config(latent=LatentConfig(ratio=0.01),
                           optim=OptimConfig(lr_positions=0.0, lr_textures=0.0, lr_displacement=0.001,
                                             lr_decades=3.0, validation_flip_share=0.5))
"""Where a ``displace`` run's settings start: a base of 1 % of the input's triangles, fitted at
levels 0 to 3 (1 to 64 times the base's triangles). The fit moves the heights alone, the base's
vertices and the classic bake's maps held: with engine shading the maps shade every level alike,
so what the levels ask of them differently is only where their geometry lies, and maps fitted to
the coarse levels' misplaced surfaces blur the finest, while heights fitted for every level
serve each (``docs/benchmarks.md``). The heights' rate starts at a fifth of the warm start's
texel rate and falls three decades: Adam moves every texel by about its rate whatever its
gradient, the finest level's start sits within a hundred-thousandth of the size of the input,
and larger steps jitter it further than the coarse levels gain. States are chosen on
PSNR and FLIP alike, since the finest levels' start is already close in PSNR and a fit can gain
it with grain."""


def displace_guess(asset: Asset, cfg: Config, count: int | None) -> InitialGuess:
    """The classic displacement bake at the base count (module docstring); plain decimation as
    the baseline, and as comparisons the classic decimate + bake at each level's count and the
    start at each of the coarser levels. ``ConfigError`` for ``latent.init`` other than
    ``"bake"``."""
    if cfg.latent.init != "bake":
        raise ConfigError(f"displace bakes its maps on the displaced surface: latent.init must be 'bake', not "
                          f"{cfg.latent.init!r}")
    levels = sorted(cfg.latent.tessellation_levels)
    shading = cfg.latent.displacement_shading
    guess = build_initial_guess(asset, cfg, count)
    base = dataclasses.replace(guess.start, mesh=dataclasses.replace(guess.start.mesh, t_nrm_idx=None))
    size = cfg.latent.texture_size
    with phase("displacement bake"):
        displacement = bake_displacement(asset, base.mesh, levels[-1], size, shading)
    displacement = stitched_displacement(base.mesh, displacement, levels[-1])
    bake_level = levels[-1] if shading == "engine" else levels[len(levels) // 2]
    with phase("bake on the displaced surface"):
        maps = bake(asset, displaced(base.mesh, displacement, bake_level)[0], size).material
    material = dataclasses.replace(base.materials[0], kd=maps.kd, ks=maps.ks, normal=maps.normal,
                                   displacement=displacement)
    start = dataclasses.replace(base, materials=[material])
    notes = [f"base mesh of {base.mesh.num_triangles:,} triangles, displacement map {size}², fitted at tessellation "
             f"levels {', '.join(map(str, levels))}, shading {shading} ({SHADING_NOTES[shading]})"]
    starts = [(f"start_l{level}", f"{DISPLACE.start_label}, level {level}", at_level(start, level))
              for level in levels[:-1]]
    return dataclasses.replace(guess, start=start, notes=guess.notes + notes,
                               comparisons=classic_bakes(asset, cfg, guess, levels) + starts)


SHADING_NOTES = {"engine": "normals interpolated from the base, as tessellating engines draw it; the coarser levels "
                            "straddle the finest level's relief",
                 "recomputed": "normals of the displaced geometry, as Blender's Displace modifier draws it"}
"""The report's words for each ``latent.displacement_shading``."""


def classic_bakes(asset: Asset, cfg: Config, guess: InitialGuess, levels: list[int]) -> list[tuple[str, str, Asset]]:
    """The classic decimate + bake at the triangle count of each of ``levels`` (the base's count
    times 4^level) below the input's, as ``(key, label, asset)``."""
    clamp = cfg.clamp
    ranges = Ranges(kd=clamp.kd, ks=(clamp.gamma, clamp.roughness, clamp.metalness))
    rng = np.random.default_rng((cfg.optim.seed, TEXTURE_STREAM))
    bakes = []
    for level in levels:
        count = guess.start.mesh.num_triangles * 4 ** level
        if count >= asset.mesh.num_triangles:
            continue
        if level == 0 and guess.baked is not None:
            baked = guess.baked
        else:
            with phase("classic bakes"):
                baked = initial_guess(asset, decimate(asset.mesh, count), "bake", cfg.latent.texture_size, ranges,
                                      rng).baked
        bakes.append((f"bake_l{level}", f"Classic bake, {count:,}", baked))
    return bakes


def at_level(model: Asset, level: int) -> Asset:
    """``model`` (a displaced asset) drawn at tessellation level ``level``."""
    material = model.materials[0]
    displacement = dataclasses.replace(material.displacement, level=level)
    return dataclasses.replace(model, materials=[dataclasses.replace(material, displacement=displacement)])


def level_variants(model: Asset, cfg: Config) -> list[tuple[str, str, Asset]]:
    """``model`` at each of its coarser levels, scored beside it (which is the finest)."""
    return [(f"ours_l{level}", f"Ours, level {level}", at_level(model, level))
            for level in sorted(cfg.latent.tessellation_levels)[:-1]]


def displaced_latent(asset: Asset, start: Asset, cfg: Config, moving: bool) -> DisplacedMesh:
    """The run's textured mesh (``mesh_latent``) as a ``DisplacedMesh`` fitted at the run's levels."""
    if moving:
        raise ConfigError("displace fits a still model: give a static mesh, or --static for a skinned one")
    return DisplacedMesh(mesh_latent(asset, start, cfg, False), start.materials[0].displacement,
                         cfg.latent.tessellation_levels, cfg.latent.texture_scales)


def write_displacement(model: Asset, guess: InitialGuess, cfg: Config, folder: Path,
                       methods: list[MethodResult]) -> list[dict]:
    """Write ``base.glb``, the displacement maps and ``lodK.glb`` (module docstring) into
    ``folder``; the rows of the report's levels table."""
    levels = sorted(cfg.latent.tessellation_levels)
    displacement = model.materials[0].displacement
    io.save(model, folder / "base.glb")
    heights = displacement.heights
    write_png(heights.data.numpy(), folder / "displacement.png", bits=16)
    write_exr(heights.data.numpy(), folder / "displacement.exr")
    scores = {m.key: m for m in methods}
    bakes = {key: asset for key, _, asset in guess.comparisons}
    base_bytes, base_gpu = (folder / "base.glb").stat().st_size, gpu_bytes(folder / "base.glb")["total"]
    rows = []
    for level in levels:
        drawn = written_level(model, level)
        io.save(drawn, folder / f"lod{level}.glb")
        ours = scores["ours" if level == levels[-1] else f"ours_l{level}"]
        start = scores["start" if level == levels[-1] else f"start_l{level}"]
        row = {"level": level, "triangles": drawn.mesh.num_triangles, "bytes": base_bytes, "gpu_bytes": base_gpu,
               "lod_bytes": (folder / f"lod{level}.glb").stat().st_size,
               "lod_gpu_bytes": gpu_bytes(folder / f"lod{level}.glb")["total"], "psnr": ours.psnr, "flip": ours.flip,
               "start_psnr": start.psnr, "start_flip": start.flip}
        baked = scores.get(f"bake_l{level}")
        if baked is not None:
            data = to_glb_bytes(bakes[f"bake_l{level}"])
            row.update({"bake_triangles": baked.triangles, "bake_bytes": len(data), "bake_gpu_bytes": glb_gpu_bytes(data),
                        "bake_psnr": baked.psnr, "bake_flip": baked.flip})
        rows.append(row)
    return rows


def written_level(model: Asset, level: int | None = None) -> Asset:
    """``model`` tessellated and displaced at ``level`` (default its own) as files hold it: with
    engine shading, on the displaced geometry's own normals, the normal map re-expressed so that
    every texel shades as the base's interpolated frame shades it (``io.normal_frames.on_own_normals``):
    a rasterizer draws the same picture either way, and renderers that light by the facets as
    well (Cycles) or filter the map their own way agree with it far better (``docs/benchmarks.md``)."""
    return on_own_normals(tessellated(model, level))


def glb_gpu_bytes(data: bytes) -> int:
    """``io.gpu_memory.gpu_bytes`` total of a glb held in memory."""
    with tempfile.TemporaryDirectory(prefix="lookalike-gpu-") as scratch:
        path = Path(scratch) / "model.glb"
        path.write_bytes(data)
        return gpu_bytes(path)["total"]


def write_exr(heights: np.ndarray, path: Path) -> None:
    """``heights [S, S, 1]`` as a one-channel float32 EXR, where the ``OpenEXR`` package is
    installed (else nothing)."""
    try:
        import OpenEXR
    except ImportError:
        return
    with OpenEXR.File({"type": OpenEXR.scanlineimage}, {"Y": np.ascontiguousarray(heights[..., 0], np.float32)}) as exr:
        exr.write(str(path))


DISPLACE = Application(command="displace", outdir_suffix="-displaced", initial_guess=displace_guess,
                       defaults=DISPLACE_DEFAULTS, start_label="Classic displacement bake", latent=displaced_latent,
                       variants=level_variants, every_variant_gains=True, written_form=written_level,
                       files=write_displacement)
"""``displace``: a base mesh with a displacement map, fitted at every tessellation level."""


def displace(input: str | Path | Asset, outdir: str | Path | None = None, *, config: Config | str | Path | None = None,
             **keywords) -> RunResult:
    return run(DISPLACE, input, outdir, config=config, **keywords)


displace.__doc__ = keywords_doc(DISPLACE, "Fit a base mesh with a displacement map that looks like ``input`` at every "
                                "tessellation level into ``outdir``.",
                                ("triangles", "ratio", "tessellation_levels", "displacement_shading", "texture_size",
                                 "resolution",
                                 "time_budget", "iterations", "seed", "export_obj", "compress"))
