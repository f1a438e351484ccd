"""The fit's parts as a run's settings (``lookalike.settings.Config``) describe them: the
loop's settings and the objective. Kept apart from the settings, which import no torch."""

from __future__ import annotations

from ..settings import Config, emissive_learning_rate, learning_rates, outline_views, start_defaults
from ..shading.shadow_maps import ShadowMapping
from ..shading.texturing import ENGINE_FOOTPRINT, FOOTPRINT_SCALE
from .loop import LoopSettings
from .objective import Objective


def loop_settings(config: Config, outline: bool) -> LoopSettings:
    """The loop's settings for ``config``: learning rates of the ``"positions"``,
    ``"textures"``, ``"emissive"``, ``"displacement"`` and ``"weights"`` groups, and the outline views per step on
    top of the batch where ``outline`` (a latent whose coverage is geometry's alone), at most the
    pool's views besides the batch."""
    opt, views = config.optim, config.views
    lr_positions, lr_textures = learning_rates(config)
    count = outline_views(config) if outline else 0
    if views.pool_size:
        count = min(count, views.pool_size - views.batch_size)
    lr_emissive = emissive_learning_rate(config)
    lr_displacement = lr_textures if opt.lr_displacement is None else opt.lr_displacement
    return LoopSettings(learning_rates={"positions": lr_positions, "textures": lr_textures, "emissive": lr_emissive,
                                        "displacement": lr_displacement, "weights": opt.lr_weights},
                        views_per_step=views.batch_size + count, iterations=opt.iterations, lr_decay=opt.lr_decay,
                        lr_decades=start_defaults(config).lr_decades if opt.lr_decades is None else opt.lr_decades,
                        seed=opt.seed,
                        validate_every=opt.validate_every, rollback_lr_factor=opt.rollback_lr_factor,
                        max_rollbacks=opt.max_rollbacks, position_backoff=opt.position_backoff)


def objective(config: Config) -> Objective:
    """The objective of ``config``: its image loss, outline weight and Laplacian schedule."""
    opt = config.optim
    return Objective(opt.loss, config.views.batch_size, outline_weight=opt.outline_weight,
                     regularizer_weight=opt.laplacian_weight, min_fraction=opt.laplacian_min_fraction,
                     decay_fraction=opt.laplacian_decay_fraction)


def lookup_footprint(config: Config) -> float:
    """The models' texture lookup footprint for ``render.mip_footprint``: ``ENGINE_FOOTPRINT``
    for ``"engine"``, else ``FOOTPRINT_SCALE`` (``lookalike.shading.texturing``)."""
    return ENGINE_FOOTPRINT if config.render.mip_footprint == "engine" else FOOTPRINT_SCALE


def shadow_mapping(config: Config) -> ShadowMapping | None:
    """How the run's renders draw shadows (``render.shadows``, ``render.shadow_layers``,
    ``render.shadow_resolution``): ``None`` where they draw none."""
    ren = config.render
    return ShadowMapping(ren.shadow_layers, ren.shadow_resolution) if ren.shadows else None
