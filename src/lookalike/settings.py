"""Every setting of a run, each default written once, and their TOML form.

A run is described by :class:`Config`, a tree of small dataclasses that maps one to one onto
a TOML file (one table per section)::

    [latent]
    triangles = 1500
    texture_size = 1024

    [optim]
    time_budget = 600.0

``None`` means "not set". Every run writes its complete configuration to
``OUTDIR/config.toml``; passing that file back with ``--config`` repeats the run. An
application (``lookalike.jobs.run.Application``) starts from its own ``Config``; the command
line's help and the API's docstrings state the defaults by reading them from there
(``setting_help``), so that what they say is what a run uses.

This module imports no torch (an import-linter contract checks it), so that the command line
and the settings files work without loading the numerical stack.
"""

from __future__ import annotations

import dataclasses
import math
import re
import tomllib
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import tomli_w

from .errors import ConfigError
from .limits import (
    MAX_LAYERS,
    MAX_PATH_DEPTH,
    MAX_PATH_SPP,
    MAX_POOL_BYTES,
    MAX_RESOLUTION,
    MAX_SKIN_CANDIDATES,
    MAX_SPP,
    MAX_TESSELLATION_LEVEL,
    MAX_TEXTURE_SIZE,
    MAX_VIEWS,
)

LOSSES = ("l1-tonemapped", "l2-tonemapped", "l2", "smape", "relative-l2")
"""The image losses ``optim.loss`` names (``lookalike.fit.losses.IMAGE_LOSSES``)."""
INITS = ("bake", "source", "average", "random", "sphere")
WARM_INITS = ("bake", "source")
FIELD_SUFFIXES = (".py", ".glsl")
"""The inputs that are implicit surfaces (``lookalike.io.field_python``, ``lookalike.io.field_glsl``)."""
ALPHA_EXPORTS = ("auto", "mask", "blend")
SHADING_CONVENTIONS = ("engine", "recomputed")
"""The values of ``LatentConfig.displacement_shading`` (``lookalike.asset.material.Displacement.shading``)."""
POSITION_STEPS = ("uniform", "local")
MIP_FOOTPRINTS = ("supersampled", "engine")
"""How texture lookups choose their mip level (``render.mip_footprint``)."""
RENDERERS = ("ours", "mitsuba")
"""The reference renderers ``reference.renderer`` names."""
DEVICES = ("auto", "cuda", "cpu")
"""The devices ``render.device`` names (``lookalike.devices.resolve_device``)."""


@dataclass
class IOConfig:
    """Files.

    Attributes:
        input: the asset to simplify (any format ``lookalike.io.load`` reads).
        init_mesh: a low-poly mesh of the user's to start from instead of our decimation
            (its UVs and textures are kept where it has a usable atlas; else a fresh atlas is
            unwrapped and baked); empty for our decimation.
        outdir: where ``model.glb``, ``report.html``, ``metrics.json``, ``config.toml`` go.
        export_obj: also write ``model.obj`` (with ``.mtl`` and PNG textures).
        compress: also write ``model.compressed.glb``, as an engine ships a model (KTX2 mip
            chains, quantised and meshopt-compressed geometry: ``lookalike.jobs.compressed_model``),
            and score it beside ours.
        level_above: a level of a chain's (``jobs.lod``): the fitted model of the level above,
            decimated, is a second start, taken where it scores higher on the validation views;
            empty for none.
    """

    input: str = ""
    init_mesh: str = ""
    level_above: str = ""
    outdir: str = ""
    export_obj: bool = False
    compress: bool = False


@dataclass
class LatentConfig:
    """The low-poly model being optimised.

    Attributes:
        triangles: target triangle count of the initial mesh; where set, ``ratio`` is ignored
            (and setting it through options or a file clears ``ratio``).
        ratio: target count as a fraction of the input's (used where ``triangles`` is unset).
        texture_size: side S of the square base colour, specular and normal textures.
        init: how the textures start: ``"bake"`` (a fresh atlas with the classic projection
            bake of the input, ``lookalike.init.projection_bake``: normals, colours and specular from rays
            along the low-poly normals), ``"source"`` (the input's own UVs and textures, where it
            has one material with UVs; else as ``"average"``), ``"average"`` (a fresh atlas
            holding the input's mean material) or ``"random"`` (a fresh atlas with uniform
            noise, as in the paper), or ``"sphere"`` (the paper's start for implicit surfaces: the
            mesh too starts as a tessellated sphere around the input, with its mean material, and
            the Laplacian regulariser holds the positions' own smoothness, not their change's).
            Fresh normal maps start flat.
        texture_scales: how far each level of the textures moves per step, relative to a
            plain texture, finest level first, then levels of 2, 4 and 8 texels
            (``lookalike.fit.texture_pyramid``): the fine level takes small steps, so texels the
            views seldom reach do not grow grain, and the coarse levels carry what many texels
            agree on. ``(1, 0, 0, 0)`` is a plain texture.
        constant_colour: hold base colour and specular as one value each where the input's
            are one value (an untextured scan), so that the fit cannot paint shading into them;
            the normal map carries the relief.
        static: for a skinned input with animations, simplify its bind pose alone and write a
            static model, instead of fitting the model and its skinning weights over the
            animations (``lookalike.fit.skinned_mesh``).
        skin_candidates: joints per vertex whose weights a skinned fit trains (those that weigh
            most on the input's surface nearby, ``lookalike.init.skin_weights``); the export
            keeps the 4 largest.
        alpha_mode: how a model with trained alpha is written: ``"auto"`` as the input's
            materials do (``BLEND`` if one blends, else ``MASK``), ``"mask"`` (alpha-tested at a
            cutoff the fit chooses on its validation views: engines draw it without sorting) or
            ``"blend"``. ``"auto"`` trains the mode it writes; ``"blend"`` trains soft
            (blended) alpha, which moves coverage where a straight-through mask does not;
            ``"mask"`` starts as blended and narrows to the alpha test over ``mask_anneal``
            (``lookalike.jobs.alpha_export``).
        mask_anneal: for ``alpha_mode = "mask"``, the share of the run over which the coverage
            ramp narrows from blended alpha (width 1) to the hard alpha test (0), linearly
            (``Material.coverage_ramp``), so that the fit converges on the model as engines draw
            it; once it is 0, the test's straight-through gradient trains on. 0 trains blended
            alpha throughout and thresholds it at the end.
        fitted_mips: every mip level of every map is a latent variable of its own (a residual
            over the box filter of the level above, ``lookalike.fit.fitted_mips``), fitted to
            the views that see it; written as KTX2 mip chains (``lookalike.io.ktx2``). Off,
            the mips are the box filter of the texture, as an engine builds them from a PNG.
        tessellation_levels: for ``displace``, the levels of subdivision (each 1 -> 4 triangles)
            the base mesh and its maps must look right at; each step draws the next in turn.
        displacement_shading: for ``displace``, ``"engine"`` (a vertex moves along the base's
            interpolated normal, which also shades it, the normal map in the base's
            interpolated frame: one normal map serves every level, as tessellating engines
            draw it) or ``"recomputed"`` (along the subdivided mesh's own normal, shading
            following the displaced geometry, as Blender's Displace modifier does).
        hold_planes: for an implicit surface, the corners of every face of the start that lies
            on a plane of the field stay on that plane through the fit (on the line or point
            where two or more such planes meet: ``lookalike.asset.field_planes``), so that its
            flat faces stay as flat as the field's.
    """

    triangles: int | None = None
    ratio: float | None = 0.02
    texture_size: int = 1024
    init: str = "bake"
    texture_scales: tuple[float, float, float, float] = (0.25, 0.25, 0.25, 0.25)
    constant_colour: bool = True
    static: bool = False
    skin_candidates: int = 8
    alpha_mode: str = "auto"
    mask_anneal: float = 1.0
    fitted_mips: bool = False
    tessellation_levels: tuple[int, ...] = (0, 1, 2, 3)
    displacement_shading: str = "engine"
    hold_planes: bool = True


@dataclass
class RenderConfig:
    """Rendering of training images.

    Attributes:
        resolution: side, in pixels, of the square training images (and of report images).
        target_spp: supersampling of reference images, in samples *per axis*: the reference
            is rendered at ``resolution * target_spp`` pixels per side and box-filtered down,
            i.e. ``target_spp**2`` samples per pixel.
        latent_msaa: samples per axis for the latent model (MSAA, paper Sec. 6.2): in
            training, coverage is sampled ``latent_msaa**2`` times per pixel and shading once,
            at a random covered sample (stochastic MSAA); in scoring, every sample is shaded,
            as the reference is. 1 disables.
        horizon_share: the share of training views whose light also tests the geometric
            horizon (``lookalike.shading.light.PointLight``): no light where the geometric
            surface faces away from it, as Cycles and most offline renderers shade, while the
            other views light by the shading normal alone, as real-time engines do. Fitting
            against both keeps the normal map right in both kinds of renderer.
        layers: depth-peeled layers composited in every render of the models
            (``lookalike.shading.pipeline``): 1 shows the nearest surface only; alpha-
            textured foliage needs several (the paper peels 8). The reference peels
            ``reference_layers``.
        mip_footprint: how the models' texture lookups choose their mip level
            (``lookalike.shading.texturing``): ``"supersampled"``, the footprint narrowed to a
            pixel box's filter, as supersampling renderers (Cycles, the reference) filter; or
            ``"engine"``, the GPU's level at the pixel's derivatives, as real-time engines draw
            (each level of ``lookalike lod``, whose mips are fitted for them).
        device: where the tensors live and the kernels run (``lookalike.devices``): ``"cuda"``
            (the GPU, with the ``[cuda]`` extra), ``"cpu"``, or ``"auto"``, the GPU where torch
            sees one and numba-cuda is installed, else the CPU. The same seed gives the same
            bytes on the same device; the CPU and the GPU agree to float tolerance.
        shadows: the reference and the models shadow themselves under each view's point light
            (deep opacity shadow maps, ``lookalike.shading.shadow_maps``), as Cycles with
            shadows draws them: leaves shadow leaves, and cards learn to cast alike. Off,
            every point whose normal faces the light is lit, as real-time engines without
            shadow maps draw.
        shadow_layers: depth-peeled layers of each light's shadow map: how many shadowing
            surfaces, nearest the light first, a point's light passes (beyond them it passes
            freely).
        shadow_resolution: side, in pixels, of each light's shadow map (square, just holding the
            model's bounding sphere): the sharpness of shadow edges against the cost of each
            render.
    """

    resolution: int = 512
    target_spp: int = 2
    latent_msaa: int = 2
    horizon_share: float = 0.5
    layers: int = 1
    mip_footprint: str = "supersampled"
    device: str = "auto"
    shadows: bool = False
    shadow_layers: int = 4
    shadow_resolution: int = 256

    @property
    def reference_layers(self) -> int:
        """Layers the reference peels: 1 where the models peel 1, else ``MAX_LAYERS`` (16, as
        deep as the judge's Cycles sees through transparent surfaces; peeling stops earlier
        where nothing more shows). Dense foliage is deeper than the models' layers (a conifer
        has a quarter of its coverage beyond the 8th), and a reference cut short teaches the
        fit a sparse, pale look that no other renderer shows."""
        return 1 if self.layers == 1 else MAX_LAYERS


@dataclass
class ViewsConfig:
    """Cameras and lights.

    Attributes:
        batch_size: views per optimisation step (the paper uses 1 to 8; on a CPU, more
            single-view steps beat fewer larger ones in the same time).
        pool_size: reference images rendered before optimising, from which mini-batches are
            drawn; 0 renders fresh random views at every step instead.
        refresh_every: steps between renders of one new view into the pool (replacing its
            oldest); 0 keeps the pool fixed.
        refresh_triangles: inputs of up to this many triangles refresh a view every
            ``refresh_every`` steps; larger ones proportionally less often
            (``refresh_interval``), so that refreshing costs about the same per step at any
            size (a render's cost grows with the input). A count, not a clock, so that runs
            stay reproducible.
        relight: keep each pool camera's G-buffer instead of its image and light it again
            with a fresh random light whenever it is drawn (``lookalike.shading.relight``):
            lights keep varying, and the reference's triangles are touched once per camera.
            Off by default: it trains no better than stored images at the same cost
            (``docs/benchmarks.md``), and with ``refresh_triangles`` the step's cost is
            bounded either way.
        heldout: views of the report, drawn from ``heldout_seed`` and never trained on.
        heldout_seed: seed of the held-out views (fixed so that runs stay comparable).
        validation: views, drawn from ``validation_seed`` and never trained on, on which the
            model is scored every ``optim.validate_every`` steps: the best-scoring state is the
            one kept (the training loss of one-view batches is too noisy to choose by), and the
            scores are the run's convergence curve. 0 chooses by the training loss instead.
        validation_seed: seed of the validation views (not the held-out ones: the report's
            scores stay independent of the choice).
        rest_share: for an animated input, the share of training views that show the rest
            pose; the others show a random clip at a random time. Held-out and validation views
            are spread over every clip (``lookalike.shading.view_sampling``).
        distance_spread: training cameras stand at the framing distance times ``2^u``, ``u``
            uniform in ``[-distance_spread / 2, distance_spread / 2]`` (octaves): a model fitted
            for one screen size then also sees the sizes around it, so that the mip levels
            next to its own get gradients too. Held-out and validation views keep the framing
            distance.
    """

    batch_size: int = 1
    pool_size: int = 64
    refresh_every: int = 2
    refresh_triangles: int = 250_000
    relight: bool = False
    heldout: int = 16
    heldout_seed: int = 20_210_809
    validation: int = 4
    validation_seed: int = 20_211_021
    rest_share: float = 0.125
    distance_spread: float = 0.0


@dataclass
class ReferenceConfig:
    """What draws the reference views (paper Sec. 5.5: any renderer can).

    Attributes:
        renderer: ``"ours"``, the input through our own rasterizer under a random point light
            per view; or ``"mitsuba"``, the input path traced by Mitsuba 3 under fixed
            ``lighting`` (``lookalike.shading.path_tracing``): soft shadows, bounced light and
            the environment are learned into an emission map and the base colour, and the
            model is fitted and exported with the lighting's analytic part, a point light.
        lighting: the path tracer's fixed lighting: ``"studio"`` (generated around the object,
            ``lookalike.shading.fixed_lighting``) or an environment map file (``.hdr``,
            ``.exr``).
        spp: samples per pixel of a path-traced view.
        max_depth: longest path (2: direct light only); what a path tracer adds over a
            rasterizer comes from the bounces.
        unlit: with a path-traced reference, fit and write the model unlit: no analytic light,
            the whole appearance in the emission, written as ``KHR_materials_unlit`` base
            colour (clipped to [0, 1]) for viewers that should add no light of their own.
    """

    renderer: str = "ours"
    lighting: str = "studio"
    spp: int = 64
    max_depth: int = 8
    unlit: bool = False

    @property
    def path_traced(self) -> bool:
        """Whether the reference views are path traced (each costs seconds: rendered once,
        cached in the output folder, never refreshed)."""
        return self.renderer == "mitsuba"


@dataclass
class OptimConfig:
    """The optimisation (paper Sec. 6.3).

    Attributes:
        time_budget: wall-clock seconds for the whole run (loading to report); the number of
            iterations is derived from it after timing the first steps unless ``iterations``
            is given.
        iterations: fixed number of optimisation steps, or ``None`` to follow the budget.
        seed: seeds torch and numpy; same seed, same result.
        loss: image loss, one of ``LOSSES`` (see ``lookalike.fit.losses``).
        lr_positions: Adam's lr_0 for vertex positions, in units of the bounding-sphere
            radius; ``None`` picks ``COLD_START``'s (the paper's [0.001, 0.003] for a
            decimated start) where the textures start from scratch (``average``, ``random``),
            ``WARM_START``'s where they start close (``bake``, ``source``, or a user's mesh
            fitted onto the surface, ``io.init_mesh``; see ``start_defaults``).
        lr_textures: Adam's lr_0 for texels (values in [0, 1]); ``None`` picks
            ``COLD_START``'s or ``WARM_START``'s, as for ``lr_positions`` (``FIELD_START``'s for
            an implicit surface's start, ``start_defaults``).
        lr_emissive: Adam's lr_0 for the emission map (where the input emits, or the reference
            is path traced), in units of the start's brightest emission (at least 1; see
            ``lookalike.fit.textured_mesh``); ``None``: ``emissive_learning_rate``.
        lr_displacement: Adam's lr_0 for the heights of a displacement map (values in [0, 1]
            of its range, ``lookalike.fit.displaced_mesh``); ``None`` takes the texels' rate.
        lr_weights: Adam's lr_0 for the logits of the skinning weights of an animated input
            (``lookalike.fit.skinned_mesh``).
        lr_decay: k in lr_t = lr_0 * 10^(-k t); ``None`` stretches the schedule over the run,
            k = decades / iterations, with ``COLD_START``'s two decades (the paper's; its 0.0002
            is that for its 10k steps) or ``WARM_START``'s one, as for ``lr_positions`` (see
            ``lookalike.fit.schedule``), or ``lr_decades`` where set.
        lr_decades: decades the learning rate falls over the run where ``lr_decay`` is unset;
            ``None`` takes the start's (``StartDefaults.lr_decades``).
        outline_views: extra views per step, drawn with the batch, on which only the latent's
            antialiased coverage is rendered and compared (L1) with the reference's: cheap
            gradients for the vertices on the outline. ``None`` picks the warm or cold default
            (see ``outline_views``); 0 turns the term off. A pool smaller than the batch plus
            these gives fewer; without a pool (``views.pool_size`` 0) they are fresh reference
            renders too; latents with alpha do without them.
        outline_weight: weight of that coverage L1 against the image loss.
        laplacian_weight: lambda_0; ``None`` takes 0.25 * L_image / L_laplacian at the start.
        laplacian_min_fraction: lambda_min = this * lambda_0 (the paper's 2 %).
        laplacian_decay_fraction: fraction of the run after which lambda_t - lambda_min has
            fallen to 1 % of lambda_0 - lambda_min (see ``lookalike.fit.schedule``; 0.2
            reproduces the paper's k = 1e-6 on its 10k-step runs).
        validate_every: steps between scorings on the validation views (``views.validation``).
        validation_flip_share: how much FLIP weighs in the validation score that chooses the
            best state and what is written (``lookalike.report.metrics.perceptual_score``): the
            score is ``(1 - share) * PSNR + share * (-20 log10 FLIP)``, both in dB, so that of
            two states with the same PSNR the one with less perceptual error (grain, blotches)
            is kept. 0 scores PSNR alone; ``None`` picks ``validation_flip_share``'s default for
            the input (``FIELD_FLIP_SHARE`` for an implicit surface, else 0).
        checkpoint_seconds: write ``OUTDIR/checkpoint.pt`` at most this often.
        rollback_lr_factor: a non-finite step rolls back and multiplies the lr by this.
        max_rollbacks: give up (keeping the best state) after this many rollbacks in a row.
        position_backoff: where a validation scores this many dB below the best so far, the
            model returns to the best state and the position learning rate halves (0: never):
            a smooth surface that the rate shakes more than it fits gets a rate it can use,
            while thin parts that need steps of a pixel keep them (``lookalike.fit.loop``).
        position_steps: ``"uniform"``: every vertex steps by ``lr_positions``; ``"local"``: a
            vertex steps by ``lr_positions`` times its local size against ``LOCAL_STEP_SIZE``
            (at most 1; ``lookalike.fit.position_steps``), so that a small card moves as far
            for its size as a large one.
    """

    time_budget: float = 600.0
    iterations: int | None = None
    seed: int = 0
    loss: str = "l1-tonemapped"
    lr_positions: float | None = None
    lr_textures: float | None = None
    lr_emissive: float | None = None
    lr_displacement: float | None = None
    lr_weights: float = 0.1
    lr_decay: float | None = None
    lr_decades: float | None = None
    outline_views: int | None = None
    outline_weight: float = 1.0
    laplacian_weight: float | None = None
    laplacian_min_fraction: float = 0.02
    laplacian_decay_fraction: float = 0.2
    validate_every: int = 25
    validation_flip_share: float | None = None
    checkpoint_seconds: float = 60.0
    rollback_lr_factor: float = 0.5
    max_rollbacks: int = 8
    position_backoff: float = 0.0
    position_steps: str = "uniform"


@dataclass
class ClampConfig:
    """Valid ranges, enforced after every step.

    Attributes:
        kd: range of base colour and alpha.
        gamma, roughness, metalness: ranges of the three specular channels.
        normal_max_slope: largest |x / z| and |y / z| of a tangent-space normal (3 allows
            tilts of about 72 degrees along each tangent axis).
    """

    kd: tuple[float, float] = (0.0, 1.0)
    gamma: tuple[float, float] = (0.0, 1.0)
    roughness: tuple[float, float] = (0.08, 1.0)
    metalness: tuple[float, float] = (0.0, 1.0)
    normal_max_slope: float = 3.0


@dataclass
class Config:
    """Every setting of one run, of any application."""

    io: IOConfig = field(default_factory=IOConfig)
    latent: LatentConfig = field(default_factory=LatentConfig)
    render: RenderConfig = field(default_factory=RenderConfig)
    views: ViewsConfig = field(default_factory=ViewsConfig)
    reference: ReferenceConfig = field(default_factory=ReferenceConfig)
    optim: OptimConfig = field(default_factory=OptimConfig)
    clamp: ClampConfig = field(default_factory=ClampConfig)

    def validate(self) -> Config:
        """Raise ``ConfigError`` naming the first invalid setting; return ``self``."""
        lat, ren, vw, opt, ref = self.latent, self.render, self.views, self.optim, self.reference
        checks = [
            (lat.triangles is None or lat.triangles > 0,
             f"target triangle count must be positive, got {lat.triangles} (latent.triangles)"),
            (lat.ratio is None or 0.0 < lat.ratio < 1.0, f"latent.ratio must lie in (0, 1), not {lat.ratio}"),
            (lat.triangles is not None or lat.ratio is not None, "give latent.triangles or latent.ratio"),
            (4 <= lat.texture_size <= MAX_TEXTURE_SIZE,
             f"latent.texture_size (--texture-size) must lie in [4, {MAX_TEXTURE_SIZE}], not {lat.texture_size}"),
            (lat.init in INITS, f"latent.init must be one of {', '.join(INITS)}, not {lat.init!r}"),
            (all(scale >= 0 for scale in lat.texture_scales) and lat.texture_scales[0] > 0,
             f"latent.texture_scales must not be negative, and the first must be positive: {lat.texture_scales}"),
            (len(lat.tessellation_levels) >= 1 and len(set(lat.tessellation_levels)) == len(lat.tessellation_levels)
             and all(0 <= level <= MAX_TESSELLATION_LEVEL for level in lat.tessellation_levels),
             f"latent.tessellation_levels (--levels) must be distinct levels in [0, {MAX_TESSELLATION_LEVEL}], "
             f"not {','.join(map(str, lat.tessellation_levels))}"),
            (16 <= ren.resolution <= MAX_RESOLUTION,
             f"render.resolution (--resolution) must lie in [16, {MAX_RESOLUTION}], not {ren.resolution}"),
            (1 <= ren.target_spp <= MAX_SPP, f"render.target_spp must lie in [1, {MAX_SPP}], not {ren.target_spp}"),
            (1 <= ren.latent_msaa <= MAX_SPP, f"render.latent_msaa must lie in [1, {MAX_SPP}], not {ren.latent_msaa}"),
            (0 <= ren.horizon_share <= 1, f"render.horizon_share must lie in [0, 1], not {ren.horizon_share}"),
            (1 <= ren.layers <= MAX_LAYERS, f"render.layers must lie in [1, {MAX_LAYERS}], not {ren.layers}"),
            (ren.layers == 1 or not vw.relight,
             "views.relight keeps the nearest surface's G-buffer only: it needs render.layers = 1"),
            (1 <= ren.shadow_layers <= MAX_LAYERS,
             f"render.shadow_layers must lie in [1, {MAX_LAYERS}], not {ren.shadow_layers}"),
            (16 <= ren.shadow_resolution <= MAX_RESOLUTION,
             f"render.shadow_resolution must lie in [16, {MAX_RESOLUTION}], not {ren.shadow_resolution}"),
            (not (ren.shadows and vw.relight),
             "views.relight lights a stored G-buffer again, which casts no shadows: it needs render.shadows off"),
            (lat.displacement_shading in SHADING_CONVENTIONS,
             f"latent.displacement_shading (--shading) must be one of {', '.join(SHADING_CONVENTIONS)}, not "
             f"{lat.displacement_shading!r}"),
            (lat.alpha_mode in ALPHA_EXPORTS,
             f"latent.alpha_mode must be one of {', '.join(ALPHA_EXPORTS)}, not {lat.alpha_mode!r}"),
            (1 <= vw.batch_size <= MAX_VIEWS, f"views.batch_size must lie in [1, {MAX_VIEWS}], not {vw.batch_size}"),
            (vw.pool_size == 0 or vw.batch_size <= vw.pool_size <= MAX_VIEWS,
             f"views.pool_size must be 0 or lie in [views.batch_size, {MAX_VIEWS}], not {vw.pool_size}"),
            (vw.pool_size * ren.resolution ** 2 * 8 <= MAX_POOL_BYTES,
             f"views.pool_size x render.resolution^2 x 8 bytes must stay within {MAX_POOL_BYTES >> 30} GiB "
             f"({vw.pool_size} views of {ren.resolution}^2 need {vw.pool_size * ren.resolution ** 2 * 8 / 2 ** 30:.1f})"),
            (vw.heldout <= MAX_VIEWS and vw.validation <= MAX_VIEWS,
             f"views.heldout and views.validation must be at most {MAX_VIEWS}"),
            (vw.refresh_every >= 0, f"views.refresh_every must not be negative, not {vw.refresh_every}"),
            (vw.refresh_triangles > 0, f"views.refresh_triangles must be positive, not {vw.refresh_triangles}"),
            (vw.heldout >= 1, f"views.heldout must be at least 1, not {vw.heldout}"),
            (vw.validation >= 0, f"views.validation must not be negative, not {vw.validation}"),
            (0 <= vw.rest_share <= 1, f"views.rest_share must lie in [0, 1], not {vw.rest_share}"),
            (0 <= vw.distance_spread <= 4, f"views.distance_spread must lie in [0, 4] octaves, not {vw.distance_spread}"),
            (1 <= lat.skin_candidates <= MAX_SKIN_CANDIDATES,
             f"latent.skin_candidates must lie in [1, {MAX_SKIN_CANDIDATES}], not {lat.skin_candidates}"),
            (opt.validate_every >= 1, f"optim.validate_every must be at least 1, not {opt.validate_every}"),
            (opt.validation_flip_share is None or 0 <= opt.validation_flip_share <= 1,
             f"optim.validation_flip_share must lie in [0, 1], not {opt.validation_flip_share}"),
            (opt.time_budget > 0, f"optim.time_budget must be positive, not {opt.time_budget}"),
            (opt.iterations is None or opt.iterations >= 0,
             f"optim.iterations must not be negative, not {opt.iterations}"),
            (opt.loss in LOSSES, f"optim.loss must be one of {', '.join(LOSSES)}, not {opt.loss!r}"),
            (all(lr is None or lr >= 0 for lr in (opt.lr_positions, opt.lr_textures, opt.lr_emissive,
                                                   opt.lr_displacement, opt.lr_weights)),
             "learning rates must not be negative"),
            (opt.lr_decay is None or opt.lr_decay >= 0, "optim.lr_decay must not be negative"),
            (opt.lr_decades is None or opt.lr_decades >= 0, "optim.lr_decades must not be negative"),
            (opt.outline_views is None or opt.outline_views >= 0, "optim.outline_views must not be negative"),
            (opt.outline_weight >= 0, "optim.outline_weight must not be negative"),
            (self.clamp.normal_max_slope > 0, "clamp.normal_max_slope must be positive"),
            (opt.laplacian_weight is None or opt.laplacian_weight >= 0,
             "optim.laplacian_weight must not be negative"),
            (0 <= opt.laplacian_min_fraction <= 1, "optim.laplacian_min_fraction must lie in [0, 1]"),
            (opt.laplacian_decay_fraction > 0, "optim.laplacian_decay_fraction must be positive"),
            (0 < opt.rollback_lr_factor < 1, "optim.rollback_lr_factor must lie in (0, 1)"),
            (opt.position_backoff >= 0, "optim.position_backoff must not be negative"),
            (opt.position_steps in POSITION_STEPS,
             f"optim.position_steps must be one of {', '.join(POSITION_STEPS)}, not {opt.position_steps!r}"),
            (0 <= lat.mask_anneal <= 1, f"latent.mask_anneal must lie in [0, 1], not {lat.mask_anneal}"),
            (ren.mip_footprint in MIP_FOOTPRINTS,
             f"render.mip_footprint must be one of {', '.join(MIP_FOOTPRINTS)}, not {ren.mip_footprint!r}"),
            (ren.device in DEVICES,
             f"render.device (--device) must be one of {', '.join(DEVICES)}, not {ren.device!r}"),
            (ref.renderer in RENDERERS,
             f"reference.renderer (--reference) must be one of {', '.join(RENDERERS)}, not {ref.renderer!r}"),
            (1 <= ref.spp <= MAX_PATH_SPP, f"reference.spp (--spp) must lie in [1, {MAX_PATH_SPP}], not {ref.spp}"),
            (2 <= ref.max_depth <= MAX_PATH_DEPTH,
             f"reference.max_depth must lie in [2, {MAX_PATH_DEPTH}], not {ref.max_depth}"),
            (ref.path_traced or not ref.unlit, "reference.unlit (--unlit) fits the light of a path-traced "
             "reference: give --reference mitsuba"),
            (not (ref.path_traced and vw.relight), "views.relight lights our own G-buffers again: it cannot relight "
             "a path-traced reference (--reference mitsuba)"),
            (not ref.path_traced or ren.layers == 1, "a path-traced reference fits one surface layer (render.layers "
             "= 1): the path tracer sees through alpha itself"),
        ]
        for ok, message in checks:
            if not ok:
                raise ConfigError(message)
        return self


class StartDefaults(NamedTuple):
    """Optimiser settings that depend on how close the textures start (``latent.init``):
    the learning rates' lr_0 (``learning_rates``), the decades they fall over the run
    (``lookalike.fit.schedule.learning_rate_decay``) and the outline views (``outline_views``)."""

    lr_positions: float
    lr_textures: float
    lr_decades: float
    outline_views: int


COLD_START = StartDefaults(lr_positions=0.002, lr_textures=0.03, lr_decades=2.0, outline_views=0)
"""Where the textures start from scratch (``average``, ``random``)."""
WARM_START = StartDefaults(lr_positions=0.0003, lr_textures=0.005, lr_decades=1.0, outline_views=2)
"""Where the textures start from a bake or the input's own maps (``WARM_INITS``)."""
FIELD_START = WARM_START._replace(lr_textures=0.0005)
"""Where the input is an implicit surface (``FIELD_SUFFIXES``) and the textures start as its own
material and normals sampled at the marching-cubes surface: exact but where the surface moves,
so the texels need small corrections only, and ``WARM_START``'s texel rate leaves a blotchy
grain in roughness and metalness that perceptual error sees on a field's flat materials."""
SPHERE_START = StartDefaults(lr_positions=0.01, lr_textures=0.03, lr_decades=2.0, outline_views=2)
"""Where the mesh too starts from scratch (``sphere``): its vertices travel a good part of the
radius, and the outline views pull the silhouette into shape."""


def field_input(config: Config) -> bool:
    """Whether the run's input (``io.input``) is an implicit surface (``FIELD_SUFFIXES``)."""
    return Path(config.io.input).suffix.lower() in FIELD_SUFFIXES


def start_defaults(config: Config) -> StartDefaults:
    """``WARM_START`` for a user's mesh (``io.init_mesh``: it is fitted onto the input's surface
    and baked or keeps its own maps, ``lookalike.init.conform``) and for ``WARM_INITS``
    (``FIELD_START`` where the input is an implicit surface), ``SPHERE_START`` for ``sphere``,
    else ``COLD_START``."""
    if config.io.init_mesh or config.latent.init in WARM_INITS:
        return FIELD_START if field_input(config) else WARM_START
    return SPHERE_START if config.latent.init == "sphere" else COLD_START


FIELD_FLIP_SHARE = 0.5
"""``optim.validation_flip_share`` where the input is an implicit surface: PSNR and FLIP weigh
the same. A field's start already holds its own material, so what the fit changes in its maps
is small, and a PSNR that climbs by a fraction of a dB can come with grain that FLIP sees."""


def validation_flip_share(config: Config) -> float:
    """``optim.validation_flip_share`` where set, else ``FIELD_FLIP_SHARE`` for an implicit
    surface (``field_input``) and 0 (PSNR alone, no FLIP computed) for any other input."""
    share = config.optim.validation_flip_share
    if share is not None:
        return share
    return FIELD_FLIP_SHARE if field_input(config) else 0.0


def learning_rates(config: Config) -> tuple[float, float]:
    """Adam's ``(lr_0 of positions, lr_0 of texels)``: ``optim.lr_positions`` and
    ``optim.lr_textures`` where set, else ``start_defaults``'s for ``latent.init`` and the input.

    Why two sets: Adam moves every parameter by about its learning rate at each step whatever
    the gradient's size, so the rate sets a noise floor; from a good bake the cold rates first
    push the model down to that floor, while the warm ones keep the climb monotone. Warm rates
    fall one decade over the run, not two, so that the outline still moves late in short runs
    (measurements: ``docs/benchmarks.md``).
    """
    opt, default = config.optim, start_defaults(config)
    return (default.lr_positions if opt.lr_positions is None else opt.lr_positions,
            default.lr_textures if opt.lr_textures is None else opt.lr_textures)


def bakes_lighting(config: Config) -> bool:
    """Whether a path-traced reference's lighting has no part our rasterizer computes (``--unlit``,
    or an environment map alone), so that the emission is the whole appearance and starts as the
    classic bake of the lighting (``lookalike.jobs.path_traced.with_baked_lighting``)."""
    reference = config.reference
    return reference.path_traced and (reference.unlit or reference.lighting != "studio")


def emissive_learning_rate(config: Config) -> float:
    """Adam's lr_0 of the emission map: ``optim.lr_emissive`` where set; where the reference is
    path traced under a light our rasterizer computes, ``COLD_START``'s texel rate, since the
    emission then starts black, far from the light it must learn; else (the emission starts as
    the input's own, or as the lighting baked, ``bakes_lighting``) the texels' (``learning_rates``)."""
    if config.optim.lr_emissive is not None:
        return config.optim.lr_emissive
    cold = config.reference.path_traced and not bakes_lighting(config)
    return COLD_START.lr_textures if cold else learning_rates(config)[1]


def outline_views(config: Config) -> int:
    """``optim.outline_views`` where set, else the warm or cold default for ``latent.init``.

    Why: from a good bake the remaining error sits at the outline, which only vertex positions
    move, and one view per step gives them a noisy gradient; a few cheap coverage-only views make
    it steadier (measurements: ``docs/benchmarks.md``). Random starts keep the paper's loss.
    """
    if config.optim.outline_views is not None:
        return config.optim.outline_views
    return start_defaults(config).outline_views


def refresh_interval(config: Config, input_triangles: int) -> int:
    """Steps between refreshes of the view pool for an input of ``input_triangles``:
    ``refresh_every * max(1, input_triangles * render.reference_layers / refresh_triangles)``,
    rounded up (0: no refresh, as for a path-traced reference, whose views are rendered once). A refresh renders the input once, at a cost about proportional
    to its triangles times the layers its reference peels, so the cost per step stays that of a
    single-layer input of ``refresh_triangles``."""
    every = 0 if config.reference.path_traced else config.views.refresh_every
    drawn = input_triangles * config.render.reference_layers
    return math.ceil(every * max(1.0, drawn / config.views.refresh_triangles)) if every else 0

def parse_duration(text: str | float) -> float:
    """Seconds in ``"90"``, ``"90s"``, ``"10m"``, ``"1h"``, ``"1h30m"`` or a number.

    Raises ``ConfigError`` for anything else or for a duration that is not positive.
    """
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        seconds = float(text)
    else:
        s = str(text).strip().lower()
        parts = re.fullmatch(r"(?:(\d+(?:\.\d*)?)h)?(?:(\d+(?:\.\d*)?)m)?(?:(\d+(?:\.\d*)?)s?)?", s)
        if not s or parts is None:
            raise ConfigError(f"cannot read the duration {text!r}: use e.g. 90, 90s, 10m or 1h")
        h, m, sec = (float(p) if p else 0.0 for p in parts.groups())
        seconds = 3600 * h + 60 * m + sec
    if not math.isfinite(seconds) or seconds <= 0:
        raise ConfigError(f"the duration {text!r} must be positive")
    return seconds


def config_to_dict(config: Config) -> dict[str, dict[str, Any]]:
    """Nested plain dict of ``config`` without ``None`` values (tuples become lists), and
    without ``latent.ratio`` where ``latent.triangles`` is set."""
    out = {}
    if config.latent.triangles is not None:  # the count it names wins: the ratio is not used
        config = dataclasses.replace(config, latent=dataclasses.replace(config.latent, ratio=None))
    for section in dataclasses.fields(config):
        values = dataclasses.asdict(getattr(config, section.name))
        out[section.name] = {k: list(v) if isinstance(v, tuple) else v for k, v in values.items() if v is not None}
    return out


def to_toml(config: Config) -> str:
    """The TOML text of ``config`` (every setting, defaults included)."""
    return tomli_w.dumps(config_to_dict(config))


def config_from_dict(data: dict[str, Any], base: Config | None = None, origin: str = "configuration") -> Config:
    """``base`` (default: all defaults) with the values of ``{section: {key: value}}`` applied.

    Raises ``ConfigError`` naming ``origin`` for an unknown section or key or a value of
    the wrong type; the result is validated.
    """
    config = dataclasses.replace(base) if base is not None else Config()
    if isinstance(data.get("latent"), dict):
        config = _one_count(config, data["latent"], origin)
    sections = {f.name: f for f in dataclasses.fields(Config)}
    for name, values in data.items():
        if name not in sections:
            raise ConfigError(f"{origin}: unknown section [{name}]; known: {', '.join(sections)}")
        if not isinstance(values, dict):
            raise ConfigError(f"{origin}: [{name}] must be a table")
        current = getattr(config, name)
        setattr(config, name, _apply(current, values, f"{origin}: [{name}]"))
    return config.validate()


def _apply(section, values: dict[str, Any], where: str):
    """A copy of the dataclass ``section`` with ``values`` set, each checked against its field's type."""
    hints = typing.get_type_hints(type(section))
    known = [f.name for f in dataclasses.fields(section)]
    changes = {}
    for key, value in values.items():
        if key not in known:
            raise ConfigError(f"{where}: unknown key {key!r}; known: {', '.join(known)}")
        changes[key] = _coerce(key, value, hints[key], where)
    return dataclasses.replace(section, **changes)


def _coerce(key: str, value: Any, hint: Any, where: str) -> Any:
    """``value`` checked against the annotation ``hint`` (ints are accepted for floats)."""
    if key == "time_budget":
        return parse_duration(value)
    options = typing.get_args(hint) if typing.get_origin(hint) in (types.UnionType, typing.Union) else (hint,)
    if value is None and type(None) in options:
        return None
    for option in options:
        if typing.get_origin(option) is tuple:
            args = typing.get_args(option)
            variadic = len(args) == 2 and args[1] is Ellipsis
            whole = args[0] is int
            if (isinstance(value, (list, tuple)) and (variadic or len(value) == len(args))
                    and all(type(v) is int if whole else _is_number(v) for v in value)):
                return tuple(v if whole else float(v) for v in value)
        elif option is float and _is_number(value):
            return float(value)
        elif option in (int, str, bool) and type(value) is option:
            return value
    raise ConfigError(f"{where}: {key} = {value!r} has the wrong type (expected {hint})")


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def load_config(path: str | Path, defaults: Config | None = None) -> Config:
    """Read a run's TOML file; missing settings keep those of ``defaults`` (default: ``Config()``).
    A file that sets ``latent.triangles`` clears the defaults' ``ratio`` and vice versa."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such configuration file") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise ConfigError(f"{path}: not a valid TOML file: {e}") from None
    return config_from_dict(data, base=defaults or Config(), origin=str(path))


def _one_count(config: Config, latent: dict[str, Any], origin: str) -> Config:
    """``config`` with ``latent.ratio`` cleared where ``latent`` (settings about to be applied)
    sets ``triangles``, and ``latent.triangles`` cleared where it sets ``ratio``; ``ConfigError``
    naming ``origin`` where it sets both."""
    if latent.get("triangles") is not None and latent.get("ratio") is not None:
        raise ConfigError(f"{origin}: give latent.triangles or latent.ratio, not both")
    cleared = {other: None for key, other in (("triangles", "ratio"), ("ratio", "triangles"))
               if latent.get(key) is not None}
    return dataclasses.replace(config, latent=dataclasses.replace(config.latent, **cleared)) if cleared else config


def with_overrides(base: Config | str | Path | None, defaults: Config | None = None, **overrides: Any) -> Config:
    """``base`` (a ``Config``, a TOML file, or ``None`` for ``defaults``, themselves by default
    ``Config()``; a file's missing settings keep those of ``defaults``) with the non-``None``
    ``overrides`` applied, each named after a field of one section (``triangles`` sets
    ``latent.triangles``; command-line options and keyword arguments map this way). Setting
    ``triangles`` clears a configured ``ratio`` and vice versa. Validated."""
    config = load_config(base, defaults) if isinstance(base, (str, Path)) \
        else dataclasses.replace(base or defaults or Config())
    changes: dict[str, dict[str, Any]] = {}
    for key, value in overrides.items():
        if value is not None:
            changes.setdefault(section_of(key), {})[key] = value
    return config_from_dict(changes, base=config, origin="options")


def section_of(key: str) -> str:
    """The section of ``Config`` that holds the setting ``key`` (``"texture_size"`` ->
    ``"latent"``); ``KeyError`` for an unknown key. Setting names are unique across sections,
    so that options and keyword arguments can name them alone."""
    return _SECTIONS[key]


def setting_value(config: Config, key: str) -> Any:
    """The value of the setting ``key`` in ``config``."""
    return getattr(getattr(config, section_of(key)), key)


def setting_help(key: str) -> str:
    """The first sentence of the setting ``key``'s description in its section's docstring
    (``Attributes:``), for ``--help`` texts and generated docstrings."""
    doc = type(getattr(Config(), section_of(key))).__doc__ or ""
    match = re.search(rf"^\s+{key}: (.*?)(?=^\s+\w+(?:, \w+)*: |\Z)", doc, flags=re.S | re.M)
    if match is None:
        raise KeyError(f"{key} has no description in its section's docstring")
    text = " ".join(match.group(1).split())
    return re.split(r"(?<=[^.]\.)\s|(?<=:)\s(?=``)", text, maxsplit=1)[0].rstrip(".:")


_SECTIONS = {key.name: name for name, section in typing.get_type_hints(Config).items()
             for key in dataclasses.fields(section)}
