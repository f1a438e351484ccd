"""A path-traced reference for a run (``reference.renderer = "mitsuba"``; paper Sec. 5.5,
"Baking path traced lighting"): the input path traced under fixed lighting, its views kept in
the output folder, and a start that can learn the light a rasterizer cannot compute.
"""

from __future__ import annotations

import dataclasses
import hashlib
from pathlib import Path

import numpy as np
import torch

from ..asset import Asset, PunctualLight, Texture
from ..asset.material import unlit_material
from ..errors import ConfigError
from ..fit.reference import PathTracedReference
from ..init.lighting_bake import SAMPLE_BUDGET, bake_lighting
from ..io.atomic import save_array_atomic
from ..io.environment_map import read_environment_map
from ..settings import Config
from ..shading.fixed_lighting import FixedLighting, environment_lighting, studio_lighting
from ..shading.light import PointLight

CACHE_FOLDER = "pathtraced-views"
"""The output folder's sub-folder that keeps the path-traced views (``PathTracedReference``)."""

def fixed_lighting(cfg: Config, asset: Asset) -> FixedLighting:
    """``reference.lighting`` around ``asset``: the generated studio, or its environment map
    (``AssetError`` naming the file where it is not one Mitsuba reads,
    ``lookalike.io.environment_map``)."""
    centre, radius = asset.mesh.bounding_sphere()
    if cfg.reference.lighting == "studio":
        return studio_lighting(centre, radius)
    path = Path(cfg.reference.lighting)
    read_environment_map(path)
    return environment_lighting(path.resolve(), centre)


def path_traced_reference(asset: Asset, cfg: Config, moving: bool) -> PathTracedReference:
    """The input path traced under ``reference.lighting`` (``reference.spp``,
    ``reference.max_depth``), its views kept in ``OUTDIR/pathtraced-views``; ``ConfigError``
    for what it cannot draw (an animation, an implicit surface)."""
    if moving:
        raise ConfigError("a path-traced reference is still: simplify an animated input's bind pose with --static")
    if asset.field is not None:
        raise ConfigError("a path-traced reference draws meshes: an implicit surface is its own reference")
    cache = Path(cfg.io.outdir) / CACHE_FOLDER if cfg.io.outdir else None
    lighting = fixed_lighting(cfg, asset)
    if cfg.reference.unlit:  # no analytic part: the emission holds everything
        light = lighting.analytic
        lighting = dataclasses.replace(lighting, analytic=PointLight(position=light.position,
                                                                     intensity=torch.zeros_like(light.intensity)))
    return PathTracedReference(asset, lighting, cfg.reference.spp, cfg.reference.max_depth, cache, cfg.optim.seed)


def with_emission(start: Asset) -> Asset:
    """``start`` whose materials emit nothing given a black emission map the size of their base
    colour, so that the fit can learn the light our rasterizer does not compute (the paper's
    ambient term)."""
    materials = [material if material.emissive is not None else
                 dataclasses.replace(material, emissive=Texture(torch.zeros(*material.kd.data.shape[:2], 3),
                                                                wrap=material.kd.wrap))
                 for material in start.materials]
    return dataclasses.replace(start, materials=materials)


def with_baked_lighting(start: Asset, reference: PathTracedReference) -> Asset:
    """``start`` whose materials emit the light ``reference`` path traces, baked onto its atlas
    (``lookalike.init.lighting_bake``) at the size of their base colour: the start of a fit whose
    lighting has no part a rasterizer computes (an environment map, or ``--unlit``), where the
    emission is the whole appearance. Kept beside the reference's views (``CACHE_FOLDER``) under
    a hash of the reference and the start, so a resumed run reads it back."""
    size = int(start.materials[0].kd.data.shape[0])
    digest = hashlib.sha256(f"{reference.key}:{start.fingerprint()}:{size}:{SAMPLE_BUDGET}".encode()).hexdigest()[:32]
    path = None if reference.cache is None else reference.cache / f"lighting-{digest}.npy"
    if path is not None and path.is_file():
        emission = Texture(torch.from_numpy(np.load(path)))
    else:
        emission = bake_lighting(reference.asset, start.mesh, reference.scene, size, seed=reference.seed)
        if path is not None:
            save_array_atomic(path, emission.data.numpy())
    return dataclasses.replace(start, materials=[dataclasses.replace(m, emissive=dataclasses.replace(
        emission, wrap=m.kd.wrap)) for m in start.materials])


def lit_as_fitted(model: Asset, light: PointLight, unlit: bool) -> Asset:
    """``model`` as it is written after a fit under fixed lighting: with its analytic part,
    ``light`` (batch 1), as the point light a viewer is to light it with; or, ``unlit``, its
    materials unlit (their emission is their colour, ``Material.unlit``) and no light."""
    if unlit:
        return dataclasses.replace(model, materials=[unlit_material(m, m.emissive) for m in model.materials], lights=[])
    return dataclasses.replace(model, lights=[PunctualLight(position=light.position[0].detach().clone(),
                                                            intensity=light.intensity[0].detach().clone())])
