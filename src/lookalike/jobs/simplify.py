"""``simplify``: the paper's main application: decimation (or the user's own low-poly mesh,
``init_mesh``) with a UV atlas and the classic bake, fitted by appearance (paper Sec. 4 and 6).

A skinned input with animations is fitted over them (paper Sec. 5.3, ``jobs.animated``);
``static`` simplifies its bind pose into a still model. Everything else is the shared run
(``jobs.run``).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from .. import io
from ..asset import Asset, Mesh
from ..asset.parts import aggregate_traits
from ..init.decimate import CANDIDATES, FIELD_CANDIDATES, Setting, decimate_reported
from ..init.initial_guess import (InitialGuess, Ranges, decimation_baseline, initial_guess, initial_guess_from_mesh,
                                  smooth_shaded)
from ..init.sphere_start import tessellated_sphere
from ..io.field_asset import finer_field_mesh
from ..phases import phase
from ..settings import Config
from .run import TEXTURE_STREAM, Application, keywords_doc, run
from .run_result import RunResult


def build_initial_guess(asset: Asset, cfg: Config, count: int | None) -> InitialGuess:
    """The user's mesh (``cfg.io.init_mesh``) with its own textures or a bake; for
    ``latent.init = "sphere"``, a tessellated sphere of ``count`` triangles around the input
    (its bounding sphere) with the input's mean material, beside plain decimation as the
    baseline; else our decimation (of ``decimation_input``, among its candidates) to ``count``
    triangles with ``cfg.latent.init``'s textures, how far it strays from the input as the
    guess's ``start_distance``. Where the input is an
    implicit surface and the start a bake, the same mesh baked on smooth normals
    (``smooth_shaded``) is offered as an alternative start (``jobs.run.take_best_start``): a
    field's hard edges are where decimation strays most, and its model is written on crease
    normals either way (``jobs.reference_kinds.FieldInput``)."""
    size = cfg.latent.texture_size
    if cfg.io.init_mesh:
        lod = io.load(cfg.io.init_mesh)
        return initial_guess_from_mesh(asset, lod, Path(cfg.io.init_mesh).name, size)
    clamp = cfg.clamp
    ranges = Ranges(kd=clamp.kd, ks=(clamp.gamma, clamp.roughness, clamp.metalness))
    rng = np.random.default_rng((cfg.optim.seed, TEXTURE_STREAM))
    with phase("decimation"):
        source, settings = decimation_input(asset)
        decimated, report = decimate_reported(source, count, settings=settings)
    if cfg.latent.init == "sphere":
        centre, radius = asset.mesh.bounding_sphere()
        guess = initial_guess(asset, tessellated_sphere(centre, radius, count), "average", size, ranges, rng)
        return dataclasses.replace(guess, baseline=decimation_baseline(asset, decimated),
                                   notes=["started from a tessellated sphere around the input (--init sphere)"])
    guess = dataclasses.replace(initial_guess(asset, decimated, cfg.latent.init, size, ranges, rng),
                                start_distance=report.as_dict())
    if asset.field is not None and guess.bake is not None:
        guess.alternatives.append((SMOOTH_START, smooth_shaded(asset, guess.start, size)))
        guess.alternative_distances[SMOOTH_START] = guess.start_distance
    return guess


SMOOTH_START = "the classic bake on smooth normals"
"""The label of the alternative start of a field (``smooth_shaded``)."""
FIELD_START_CELLS = 640
"""Marching cubes across an implicit surface's bounds for the mesh its start is decimated from."""
FIELD_START_BLOCK = 8
"""... evaluated near the surface only, in blocks of this many cubes."""


def decimation_input(asset: Asset) -> tuple[Mesh, tuple[Setting, ...]]:
    """The mesh decimated for the start and the decimation's candidates: the input's own mesh
    and ``CANDIDATES``, or for an implicit surface its marching cubes at ``FIELD_START_CELLS``
    (``io.field_asset.finer_field_mesh``) and ``FIELD_CANDIDATES``: the mesh a field is loaded
    with is coarser, its hard edges rounded off and its chords inside its curves, and a
    decimation of it keeps those; one of the finer mesh places its vertices on the field's
    corners and curves (``docs/benchmarks.md``)."""
    if asset.field is None:
        return asset.mesh, CANDIDATES
    return finer_field_mesh(asset, FIELD_START_CELLS, FIELD_START_BLOCK), FIELD_CANDIDATES


def aggregate_remarks(asset: Asset) -> list[str]:
    """One line suggesting ``lookalike cards`` where ``asset`` looks like aggregate geometry
    (``lookalike.asset.parts.aggregate_traits``), else none."""
    traits = aggregate_traits(asset)
    if traits is None:
        return []
    return [f"the input looks like aggregate geometry ({traits}): decimation melts such parts into blobs; "
            "lookalike cards approximates them with alpha-textured cards"]


SIMPLIFY = Application(command="simplify", outdir_suffix="-lookalike", initial_guess=build_initial_guess,
                       remarks=aggregate_remarks, runs_on_gpu=True)
"""``simplify``: decimation (or the user's mesh) and the classic bake, fitted."""


def simplify(input: str | Path | Asset, outdir: str | Path | None = None, *, config: Config | str | Path | None = None,
             **keywords) -> RunResult:
    return run(SIMPLIFY, input, outdir, config=config, **keywords)


simplify.__doc__ = keywords_doc(SIMPLIFY, "Simplify the asset in ``input`` into ``outdir``: ``model.glb``, "
                                "``report.html``, ``metrics.json`` and ``config.toml``.")
