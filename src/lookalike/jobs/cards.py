"""``cards``: foliage and other aggregate geometry as alpha-textured cards (paper Sec. 5.4).

Trees, bushes, grass, hair, chains: their look emerges from thousands of small disjoint parts,
which decimation melts into blobs or loses. ``cards`` starts from a billboard cloud instead
(``lookalike.init.billboard_cloud``: the input's parts clustered by position and orientation,
one textured quad per cluster, or one per part where the budget allows, its base colour and
alpha baked by projection), with the large solid parts (a trunk, a pot) kept beside the cards
as a decimated mesh where the budget allows (``lookalike.init.trunk_and_cards``). Where the
input is already cards of one leaf texture (game foliage), a second start keeps that texture
on fewer, larger leaf quads (``lookalike.init.leaf_texture_cards``); the run keeps whichever
start scores higher on its validation views, as written. It fits the vertices, base colour +
alpha, specular and normal map (of a start that keeps the input's textures, the vertices and a
tint per material, ``lookalike.fit.tinted_mesh``) against renders of the input, with
``render.layers`` depth-peeled layers composited back to front, both sides of each card lit.
Each vertex steps by its own size (``lookalike.fit.position_steps``). The loss is the paper's
for this application, squared L2 on tone-mapped colour. ``model.glb`` is alpha-tested
(``MASK``, its test trained in over the run and its cutoff chosen on the validation views:
engines draw it without sorting) or blended (``alpha_mode="blend"``), double-sided, its colour
filled under unseen texels (``lookalike.jobs.alpha_export``). Everything else is the shared run
(``jobs.run``); the report scores plain decimation and the start beside ours, and what it
writes is never below the start as written, in our draw or in an engine's (one lookup and one
alpha test per pixel), the start's base colour on the fitted cards offered beside the fit
(``jobs.written_model``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from ..asset import Asset
from ..errors import ConfigError
from ..init import decimate
from ..fit.latent import Latent
from ..fit.tinted_mesh import TintedMesh, surface_of
from ..init.leaf_texture_cards import LEAF_TEXTURE_START, leaf_texture_cards
from ..init.trunk_and_cards import trunk_and_cards
from ..init.initial_guess import InitialGuess, decimation_baseline
from ..phases import phase
from ..settings import Config, LatentConfig, OptimConfig, RenderConfig, ViewsConfig
from .run import TEXTURE_STREAM, Application, keywords_doc, mesh_latent, run
from .run_result import RunResult

CARDS_DEFAULTS = Config(
    latent=LatentConfig(ratio=0.01, alpha_mode="mask"),
    render=RenderConfig(layers=8),
    views=ViewsConfig(pool_size=32),
    optim=OptimConfig(loss="l2-tonemapped", lr_positions=0.002, lr_textures=0.03, position_steps="local"),
)
"""Where a ``cards`` run's settings start: a smaller share of the input's triangles (the
paper's trees keep 0.4-0.8 %), 8 depth-peeled layers as the paper peels, squared L2 on
tone-mapped colour, a pool of 32 views (each reference view of peeled foliage costs several
single-layer ones), alpha-tested output; the texels' large steps of a coarse start (the
projected bake is only a rough picture of the cards' final look), and vertices stepping by at
most a mesh's cold-start rate, less on cards smaller than ``LOCAL_STEP_SIZE`` (a card that moves
by more than about a hundredth of its size per step tears from the leaves it stands for)."""


def cards_guess(asset: Asset, cfg: Config, count: int | None) -> InitialGuess:
    """The billboard cloud of ``asset`` with ``count`` triangles and ``cfg.latent.texture_size``
    textures, its large solid parts (a trunk, a pot) kept beside the cards as a decimated mesh
    where the budget allows (``lookalike.init.trunk_and_cards``; how far that mesh strays from
    those parts is the guess's ``start_distance``), and plain decimation to the same count as
    the baseline; where the input is already cards of one leaf texture, the start that keeps
    it (``lookalike.init.leaf_texture_cards``) as an alternative. Raises ``ConfigError`` for
    settings that do not apply (``io.init_mesh``, ``latent.init`` other than ``"bake"``)."""
    if cfg.io.init_mesh or count is None:
        raise ConfigError("cards starts from its own billboard cloud: io.init_mesh does not apply")
    if cfg.latent.init != "bake":
        raise ConfigError(f"cards bakes its cards by projection: latent.init must be 'bake', not {cfg.latent.init!r}")
    with phase("billboard cloud"):
        cloud = trunk_and_cards(asset, count, cfg.latent.texture_size,
                                np.random.default_rng((cfg.optim.seed, TEXTURE_STREAM)))
    with phase("leaf texture kept"):
        kept = leaf_texture_cards(asset, count, np.random.default_rng((cfg.optim.seed, TEXTURE_STREAM, 1)))
    with phase("decimation"):
        decimated = decimate(asset.mesh, count)
    return InitialGuess(start=cloud.asset, baseline=decimation_baseline(asset, decimated), bake=None,
                        notes=list(cloud.notes), start_distance=cloud.kept_distance,
                        alternatives=[] if kept is None else [(LEAF_TEXTURE_START, kept)])


def keeps_input_textures(asset: Asset, start: Asset) -> bool:
    """Whether every material of ``start`` has one of ``asset``'s own base colour textures (the
    start that keeps the input's leaf texture; a billboard cloud's atlas is baked anew)."""
    own = [m.kd.data for m in asset.materials]
    return all(any(data.shape == m.kd.data.shape and torch.equal(data, m.kd.data) for data in own)
               for m in start.materials)


def cards_latent(asset: Asset, start: Asset, cfg: Config, moving: bool) -> Latent:
    """The run's textured mesh (``mesh_latent``), or for a start that keeps the input's
    textures a ``TintedMesh``: its vertices and a tint per material fitted, its texels held."""
    if moving or not keeps_input_textures(asset, start):
        return mesh_latent(asset, start, cfg, moving)
    return TintedMesh(mesh_latent(asset, surface_of(start), cfg, False), start)


CARDS = Application(command="cards", outdir_suffix="-cards", initial_guess=cards_guess,
                    start_label="Billboard cloud", defaults=CARDS_DEFAULTS, latent=cards_latent, engine_checked=True)
"""``cards``: a billboard cloud, fitted."""


def cards(input: str | Path | Asset, outdir: str | Path | None = None, *, config: Config | str | Path | None = None,
          **keywords) -> RunResult:
    return run(CARDS, input, outdir, config=config, **keywords)


cards.__doc__ = keywords_doc(CARDS, "Approximate the aggregate geometry in ``input`` with alpha-textured cards "
                             "into ``outdir``.", ("triangles", "ratio", "texture_size", "resolution", "time_budget",
                                                  "iterations", "seed", "alpha_mode", "export_obj", "compress"))
