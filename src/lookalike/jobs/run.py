"""The run that every application shares: from an input file to ``OUTDIR/model.glb``, its
report and metrics (paper Sec. 4 and 6), in named phases:

1. ``settings_of_run``: the application's defaults, a settings file, the keyword settings (or,
   resumed, the checkpoint's); 2. ``load_input``; 3. ``starting_point``: the initial guess (or
   the checkpoint's) and the checkpointer; 4. ``reference_views``: held-out, validation and
   training views of the reference; 5. ``score_baselines``; 6. ``optimise``, within what the
   time budget leaves; 7. ``compare_bind_pose`` (an animated input's ``compare_static``);
   8. ``write_outputs``. A skinned input with clips is fitted over them (``jobs.animated``).

How to add an application (``jobs/cards.py`` is the example): write ``jobs/NAME.py`` with
(1) its initial guess, ``(input, cfg, count) -> InitialGuess`` (``lookalike.init``); (2) where
its reference is not the input drawn by its own renderer, its ``reference``, ``(input, cfg,
moving) -> RunReference`` (``jobs.reference_kinds``: a kind of input brings its baselines and
report lines with it); (3) where the model is not a textured mesh, its
``latent``, ``(input, start, cfg, moving) -> Latent`` (``lookalike.fit.latent``); (4) its
``defaults``, a ``Config`` holding only what differs; (5) ``APP = Application(...)`` and
``def NAME(input, outdir=None, **keywords): return run(APP, input, outdir, **keywords)`` with
``NAME.__doc__`` from ``keywords_doc``; (6) ``commands/NAME.py`` from
``commands._options``; (7) tests of its initial guess and of one short run. Where it needs a
branch in this run, the run lacks a part: add a field to ``Application``, not the branch.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Iterator

import numpy as np

from .. import io
from ..asset import Asset, Material
from ..devices import CPU, device_label, moved, resolve_device
from ..errors import ConfigError, DeviceError
from ..fit.checkpoint import Checkpointer, read_checkpoint
from ..fit.from_settings import lookup_footprint, loop_settings, objective, shadow_mapping
from ..fit.latent import Latent
from ..fit.loop import FitResult, Fitter
from ..fit.progress_bar import CountedReference
from ..fit.reference import Reference, reference_on
from ..fit.skinned_mesh import SkinnedMesh
from ..fit.textured_mesh import TexturedMesh, constant_channels, render_asset
from ..fit.training_views import FreshViews, ViewPool, light_sampler, view_sampler
from ..init.initial_guess import InitialGuess, target_triangle_count, uses_alpha
from ..init.skin_weights import transfer_skin
from ..io.atomic import write_text_atomic
from ..limits import MAX_LAYERS, MAX_WORKERS
from ..phases import Profile, phase, recording
from ..report.heldout import AssetRenderer, HeldoutViews
from ..report.record import MethodResult, RunRecord
from ..shading.peeled_layers import LayerCount
from ..shading.texturing import ENGINE_FOOTPRINT
from ..settings import (Config, config_to_dict, refresh_interval, section_of, setting_help, setting_value, to_toml,
                        validation_flip_share, with_overrides)
from ..threads import CoreShare, set_threads
from . import animated
from .alpha_export import ALPHA_CANDIDATES, AlphaChoice, annealed_alpha, training_start, written_alpha
from .bind_pose import BIND_POSE_STAGE, bind_pose_fit
from .compressed_model import COMPRESSED_NAME, check_compression_tools, compress_seconds, write_compressed
from .input_asset import prepare_input
from .outdir import CHECKPOINT_NAME, check_outdir, left_as_found, prepare_outdir
from .outputs import (CONFIG_NAME, MODEL_NAME, REPORT_NAME, OptionalOutputs, staged_outputs, write_model,
                      write_record)
from .reference_coverage import check_reference_coverage
from .reference_kinds import RunReference, run_reference
from .resume import CHECKPOINT_APPLICATION, check_same_command, check_same_input, resumed_config
from .run_result import RunResult
from .written_model import MIXES, WrittenModel, with_edge_texels_taken

log = logging.getLogger(__name__)

OUTPUT_TIME_FACTOR = 2.0
"""The outputs are estimated to take this many times the slowest held-out scoring before the
fit (scoring ours, and the report's pictures), once more for each further scoring after the fit
(an animated run's moving picture, the bind-pose fit's), and for a model with trained alpha the
validation renders of its candidate cutoffs (``lookalike.jobs.alpha_export``)."""

OUTPUT_TIME_MARGIN = 10.0
"""Plus these seconds (writing the glTF, a displaced model's levels, and the report's pictures)."""

POOL_STREAM, TEXTURE_STREAM = 1, 2
"""Independent random streams derived from the seed: ``default_rng((seed, stream))`` (the
optimisation loop itself draws from ``default_rng(seed)``)."""


def mesh_latent(asset: Asset, start: Asset, cfg: Config, moving: bool) -> Latent:
    """The textured low-poly mesh that starts as ``start`` (with trained skinning weights where
    ``moving``), in the frame of ``asset``'s bind pose."""
    centre, radius = asset.mesh.bounding_sphere()
    surface = {"centre": centre, "radius": radius, "limits": cfg.clamp, "msaa": cfg.render.latent_msaa,
               "train_alpha": uses_alpha(start), "layers": cfg.render.layers,
               "constant": constant_channels(asset) if cfg.latent.constant_colour else frozenset(),
               "texture_scales": cfg.latent.texture_scales, "position_steps": cfg.optim.position_steps,
               "mask_anneal": cfg.latent.mask_anneal, "fitted_mips": cfg.latent.fitted_mips,
               "footprint": lookup_footprint(cfg), "shadows": shadow_mapping(cfg),
               "absolute_laplacian": cfg.latent.init == "sphere"}
    return (SkinnedMesh if moving else TexturedMesh).from_asset(start, **surface)


def scoring_draw(cfg: Config) -> AssetRenderer:
    """How a run draws ours and the baselines on its held-out and validation views:
    ``render_asset`` at ``render.resolution``, with ``render.latent_msaa`` samples per axis, each
    shaded, ``render.layers`` layers, the texture footprint of ``render.mip_footprint`` and the
    shadows of ``render.shadows``, as the reference draws them."""
    return partial(render_asset, resolution=cfg.render.resolution, msaa=cfg.render.latent_msaa,
                   layers=cfg.render.layers, footprint=lookup_footprint(cfg), shadows=shadow_mapping(cfg))


def engine_draw(cfg: Config) -> AssetRenderer:
    """How an engine draws a model, for runs that check their written model there too
    (``Application.engine_checked``): ``scoring_draw`` with one sample per pixel (one texture
    lookup and one alpha test each, as a rasterizer draws an alpha-tested material without alpha
    to coverage) at the engine's mip level (``ENGINE_FOOTPRINT``)."""
    return partial(scoring_draw(cfg), msaa=1, footprint=ENGINE_FOOTPRINT)


def no_remarks(asset: Asset) -> list[str]:
    """Nothing to say about the input."""
    return []


def no_variants(model: Asset, cfg: Config) -> list[tuple[str, str, Asset]]:
    """No other form of the result to score."""
    return []


def as_fitted(model: Asset) -> Asset:
    """The fitted model as it is."""
    return model


def no_files(model: Asset, guess: InitialGuess, cfg: Config, folder: Path,
             methods: list[MethodResult]) -> list[dict] | None:
    """No files of the application's own, and no table for the report."""
    return None


@dataclass(frozen=True)
class Application:
    """What one application of the fit brings to the run they share (``run``).

    Attributes:
        command: its ``lookalike`` subcommand; a checkpoint resumes under the same one.
        outdir_suffix: the default output folder is the input's name + this.
        initial_guess: ``(input, cfg, count) -> InitialGuess``, ``count`` the target triangle
            count (``None`` where ``cfg.io.init_mesh`` gives the mesh).
        defaults: the settings a run starts from, before a settings file and the keywords.
        start_label: the label its start is scored under beside the baselines, or ``None``
            (then a start that is a classic bake is scored as "Classic bake").
        remarks: ``input -> [str]``, what to say about the input (logged, and in the report).
        reference: ``(input, cfg, moving) -> RunReference``, what the views show, and what
            that kind of reference brings to the run (``jobs.reference_kinds``).
        latent: ``(input, start, cfg, moving) -> Latent``, the model the loop fits.
        variants: ``(model, cfg) -> [(key, label, asset)]``, other forms of the written model
            scored beside it (e.g. a displaced model at each tessellation level).
        every_variant_gains: choose the fit's state on the least gain over the start among the
            model and its ``variants`` (each must gain), not on their mean
            (``WrittenModel.every_form_gains``).
        written_form: ``model -> asset``, what ``model.glb`` holds (e.g. a displaced model
            tessellated at its level, for viewers that cannot displace).
        files: ``(model, guess, cfg, folder, methods) -> rows or None``, writes the
            application's own files into the output folder (given the initial guess and all the
            scored methods) and returns the rows of its table in the report and the metrics
            (``RunRecord.levels``).
        runs_on_gpu: its latent and variants have run on a GPU (``run_device``).
        engine_checked: its written model must gain on the start in an engine's draw too
            (``engine_draw``, ``jobs.written_model``), the start's base colour on the fitted
            model offered beside the fit.
    """

    command: str
    outdir_suffix: str
    initial_guess: Callable[[Asset, Config, int | None], InitialGuess]
    defaults: Config = field(default_factory=Config)
    start_label: str | None = None
    remarks: Callable[[Asset], list[str]] = no_remarks
    reference: Callable[[Asset, Config, bool], RunReference] = run_reference
    latent: Callable[[Asset, Asset, Config, bool], Latent] = mesh_latent
    variants: Callable[[Asset, Config], list[tuple[str, str, Asset]]] = no_variants
    every_variant_gains: bool = False
    written_form: Callable[[Asset], Asset] = as_fitted
    files: Callable[[Asset, InitialGuess, Config, Path, list[MethodResult]], list[dict] | None] = no_files
    runs_on_gpu: bool = False
    engine_checked: bool = False


@dataclass(frozen=True)
class RunOptions:
    """How one run goes, as opposed to what it makes (the settings, ``lookalike.settings``).

    Attributes:
        resume: continue the run whose ``checkpoint.pt`` is in the output folder bit-exactly,
            with the settings and initial guess stored in it (settings given again are ignored,
            and a warning names them; a new ``time_budget`` is this session's); the input must
            be the same asset.
        force: overwrite an existing output folder.
        progress: show a progress bar.
        profile: record where the time goes (``lookalike.phases``) into ``metrics.json``.
        threads: pin the threads of every parallel part (``lookalike.threads``); ``None``
            adapts them to other busy programs.
        material_override: render the input with this material on every triangle (e.g. a
            colour for untextured scans).
        compare_static: for an animated input, also run the bind-pose fit (``latent.static``,
            a budget of its own) into ``OUTDIR/bind-pose-fit/`` and score it beside ours.
    """

    resume: bool = False
    force: bool = False
    progress: bool = True
    profile: bool = False
    threads: int | None = None
    material_override: Material | None = None
    compare_static: bool = False


OPTION_NAMES = tuple(f.name for f in dataclasses.fields(RunOptions))


def split_keywords(keywords: dict) -> tuple[RunOptions, dict]:
    """``keywords`` as ``(RunOptions, settings)``: the fields of ``RunOptions``, and settings
    by name (``texture_size`` is ``latent.texture_size``; paths become strings). ``TypeError``
    naming an unknown keyword, as Python does."""
    options, settings = {}, {}
    for key, value in keywords.items():
        if key in OPTION_NAMES:
            options[key] = value
            continue
        try:
            section_of(key)
        except KeyError:
            raise TypeError(f"unexpected keyword argument {key!r}: neither a setting (lookalike.settings) nor "
                            f"one of {', '.join(OPTION_NAMES)}") from None
        settings[key] = str(value) if isinstance(value, Path) else value
    return RunOptions(**options), settings


@dataclass
class _Session:
    """One session of a run: what it was given, its clock and its stages' wall seconds."""

    app: Application
    options: RunOptions
    input: str | Path | Asset
    outdir: Path
    started: float
    recorder: Profile | None
    timings: dict[str, float] = field(default_factory=dict)
    seconds_before: float = 0.0
    saved: dict | None = None

    @property
    def given(self) -> Asset | None:
        return self.input if isinstance(self.input, Asset) else None

    @property
    def input_name(self) -> str:
        return str(self.input) if self.given is None else str(self.given.source or self.given.name)

    def seconds_used(self) -> float:
        """Wall seconds of the run over all its sessions."""
        return self.seconds_before + time.monotonic() - self.started

    @contextlib.contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Record the wall seconds of the ``with`` block as ``timings[name]`` (and as a phase
        of the recording profile, ``lookalike.phases``)."""
        clock = time.monotonic()
        with phase(name):
            yield
        self.timings[name] = time.monotonic() - clock


def run(app: Application, input: str | Path | Asset, outdir: str | Path | None = None, *,
        config: Config | str | Path | None = None, **keywords) -> RunResult:
    """The run of ``app`` on ``input`` (any file ``lookalike.io.load`` reads, or an ``Asset``)
    into ``outdir`` (default: the input's name + ``app.outdir_suffix``, in the current folder;
    an existing non-empty folder is refused unless ``force`` or ``resume``). ``config``: a
    ``Config`` or a TOML file of settings, over ``app.defaults``; ``keywords``: settings by
    name, which override it, and the fields of ``RunOptions``.

    Outputs appear only when complete (``jobs.outputs``); a run that fails leaves ``outdir``
    as it found it (an interrupted run keeps its checkpoint, and one whose compressed model
    failed keeps its other outputs and its checkpoint: ``OutputsIncomplete``). Raises
    ``ConfigError`` or ``AssetError`` with a message naming the problem."""
    options, settings = split_keywords(keywords)
    name = input.name if isinstance(input, Asset) else Path(input).stem
    outdir = Path(outdir) if outdir is not None else Path.cwd() / f"{name}{app.outdir_suffix}"
    check_outdir(outdir, force=options.force, resume=options.resume)
    if options.threads is not None:
        if not 1 <= options.threads <= MAX_WORKERS:
            raise ConfigError(f"--threads must lie in [1, {MAX_WORKERS}], not {options.threads}")
        set_threads(options.threads)
    session = _Session(app, options, input, outdir, time.monotonic(), Profile() if options.profile else None)
    with left_as_found(outdir), (recording(session.recorder) if session.recorder else contextlib.nullcontext()):
        return _run(session, config, settings)


def run_device(app: Application, name: str, moving: bool, reference: RunReference):
    """The ``torch.device`` a run computes on, for its setting ``render.device`` (``name``):
    ``resolve_device``'s, where the run is of a kind that has run on a GPU (an application with
    ``runs_on_gpu``, a still input, drawn by our own pipeline); for any other, ``"auto"`` is the
    CPU and ``"cuda"`` a ``DeviceError`` that says so."""
    if app.runs_on_gpu and not moving and reference.draws_input:
        return resolve_device(name)
    if name == "cuda":
        kind = ("an animated input" if moving else f"lookalike {app.command}" if reference.draws_input
                else "a reference other than the input drawn by lookalike (a field, a path tracer)")
        raise DeviceError(f"{kind} runs on the CPU only so far (--device cpu, or auto)")
    return resolve_device("cpu")


def _run(s: _Session, config, settings: dict) -> RunResult:
    """``run`` once its output folder is checked: the phases in turn."""
    cfg, budget = settings_of_run(s, config, settings)
    if cfg.io.compress:
        check_compression_tools()
    with s.stage("load and initial guess"):
        asset, notes, moving = load_input(s, cfg)
        reference = s.app.reference(asset, cfg, moving)
        device = run_device(s.app, cfg.render.device, moving, reference)
        reference.renderer = reference_on(reference.renderer, device)
        guess, checkpointer = starting_point(s, cfg, asset, moving)
    with s.stage("reference views"):
        heldout, validation, source = reference_views(cfg, asset, reference.renderer, moving,
                                                       reference.drawn_triangles(asset), s.options.progress, device)
    draw = scoring_draw(cfg)
    with s.stage("scoring the input's coverage"):
        coverage = check_reference_coverage(reference, asset, [v for v in (heldout, validation) if v is not None],
                                            partial(draw, layers=MAX_LAYERS if uses_alpha(asset) else 1))
    written = WrittenModel(cfg.latent.alpha_mode, validation, draw,
                           forms=lambda model: [model] + [form for _, _, form in s.app.variants(model, cfg)],
                           flip_share=validation_flip_share(cfg), every_form_gains=s.app.every_variant_gains,
                           engine_draw=engine_draw(cfg) if s.app.engine_checked else None)

    def prepared(model: Asset) -> Asset:
        return reference.latent_start(training_start(model, cfg.latent.alpha_mode, cfg.latent.mask_anneal))

    with s.stage("the start"):
        take_best_start(guess, start_as_written(written, prepared), s.app.start_label)
        start = prepared(guess.start)
        latent = s.app.latent(asset, moved(start, device), cfg, moving)
        hold = reference.plane_hold(start) if cfg.latent.hold_planes and isinstance(latent, TexturedMesh) else None
        if hold is not None:
            latent.hold_on_planes(hold)
    written.annealed = annealed_alpha(start)
    with s.stage("alpha of the start"):
        start_written = written.start(start)
    methods = score_baselines(s, cfg, heldout, draw, guess, start_written, asset, reference)
    fitter = Fitter(latent, source, objective(cfg), loop_settings(cfg, outline=not uses_alpha(start)),
                    validate=None if validation is None else written.validate,
                    checkpointer=checkpointer, cores=CoreShare())
    if s.saved is not None and "latent" in s.saved:
        fitter.load_state_dict(s.saved)
    seconds = fit_seconds(s, cfg, budget, moving, uses_alpha(start) and validation is not None,
                          len(s.app.variants(start_written, cfg)), reference.alternatives_seconds(guess))
    fit, export = optimise(s, fitter, seconds, written, start_written, notes, reference.alternatives,
                           reference.written)
    if cfg.render.layers > 1 and latent.layers_used.renders:
        notes.append(peeling_note(latent.layers_used, cfg.render.layers))
    interrupted = fit.interrupted
    if moving and s.options.compare_static and not interrupted:
        interrupted = compare_bind_pose(s, cfg, asset, heldout, draw, methods, notes)
        if interrupted:  # our fit is done: a resume goes straight on to the bind-pose fit
            checkpointer.save(fitter.state_dict())
    with s.stage("scoring ours"):
        methods += [heldout.score(key, label, variant, draw, cfg.latent.texture_size)
                    for key, label, variant in s.app.variants(export, cfg)]
        methods.append(heldout.score("ours", "Ours", export, draw, cfg.latent.texture_size))
    motion = moving_picture(s, cfg, reference.renderer, export, heldout) if moving else None
    as_written = s.app.written_form(export)
    record = run_record(s, cfg, asset, heldout, methods, fit, as_written, notes + guess.notes, interrupted, moving)
    record.device = device_label(device)
    record.motion, record.written, record.written_alpha = motion, written.scores, written.alpha
    record.validation_metric, record.written_model = written.metric, written.kept_label
    record.reference_coverage, record.start_distance = coverage, guess.start_distance
    reference.annotate(record, getattr(source, "nbytes", 0))
    metrics = write_outputs(s, cfg, export, as_written, guess, record,
                            lambda model: heldout.score("compressed", "Ours, compressed", model, draw,
                                                        cfg.latent.texture_size))
    if not interrupted:
        (s.outdir / CHECKPOINT_NAME).unlink(missing_ok=True)
    baselines = {methods[0].key: guess.baseline, **({"baked": guess.baked} if guess.baked is not None else {})}
    if s.app.start_label is not None:
        baselines["start"] = start_written
    baselines.update({key: model for key, _, model in [*guess.comparisons, *reference.extra_baselines(asset, start_written)]})
    return RunResult(outdir=s.outdir, model=s.outdir / MODEL_NAME, report=s.outdir / REPORT_NAME, metrics=metrics,
                     interrupted=interrupted, baselines=baselines, command=s.app.command)


def peeling_note(used: LayerCount, layers: int) -> str:
    """The report's line on how deep the fit's renders peeled of ``render.layers`` ``layers``."""
    return (f"the fit's renders peeled {used.mean:.1f} depth layers on average (deepest {used.deepest}) of "
            f"render.layers = {layers}")


def run_settings(app: Application, config: Config | str | Path | None = None, settings: dict | None = None) -> Config:
    """The settings of a fresh run of ``app``: its defaults, then ``config`` (a ``Config`` or a
    TOML file), then ``settings`` by name; validated."""
    return with_overrides(config, defaults=app.defaults, **(settings or {}))


def settings_of_run(s: _Session, config, settings: dict) -> tuple[Config, float]:
    """The run's settings and this session's time budget: the checkpoint's settings where
    resumed (``s.saved`` read, its seconds so far in ``s.seconds_before``), else
    ``app.defaults`` < ``config`` < ``settings``, with the files named."""
    checkpoint = s.outdir / CHECKPOINT_NAME
    s.saved = read_checkpoint(checkpoint) if s.options.resume else None
    if s.saved is None:
        cfg = run_settings(s.app, config, settings)
        cfg.io = dataclasses.replace(cfg.io, input=s.input_name, outdir=str(s.outdir))
        return cfg, cfg.optim.time_budget
    check_same_command(s.saved, checkpoint, s.app.command)
    cfg = resumed_config(s.saved, checkpoint, {**settings, "config": config})
    cfg.io = dataclasses.replace(cfg.io, outdir=str(s.outdir))  # the folder as named now (a path-traced reference's cache)
    s.seconds_before = s.saved["seconds_used"]
    budget = settings.get("time_budget")
    return cfg, budget if budget is not None else cfg.optim.time_budget - s.seconds_before


def load_input(s: _Session, cfg: Config) -> tuple[Asset, list[str], bool]:
    """The input as the run sees it, the report's remarks on it, and whether it is fitted over
    its animations."""
    with phase("load"):
        loaded = s.given if s.given is not None else io.load(s.input)
    moving = animated.is_animated(loaded, cfg.latent.static)
    asset, notes = prepare_input(loaded, s.options.material_override, moving)
    for remark in s.app.remarks(asset):
        log.warning("%s: %s", cfg.io.input or asset.name, remark)
        notes.append(remark)
    if moving and cfg.views.relight:
        raise ConfigError("views.relight keeps one G-buffer per camera, and an animated input's geometry changes "
                          "with every view's pose: turn it off, or simplify the bind pose with --static")
    if moving and cfg.io.export_obj:
        notes.append(obj_note := "model.obj holds the bind pose: OBJ has no skeleton (model.glb has it)")
        log.warning(obj_note)
    return asset, notes, moving


def starting_point(s: _Session, cfg: Config, asset: Asset, moving: bool) -> tuple[InitialGuess, Checkpointer]:
    """The initial guess (the checkpoint's where resumed, after checking that the input is the
    same asset) and the checkpointer that stores it with the loop's state; a fresh run writes a
    first checkpoint at once."""
    checkpoint = s.outdir / CHECKPOINT_NAME
    fingerprint = asset.fingerprint()
    if s.saved is not None:
        check_same_input(s.saved, checkpoint, fingerprint, s.input_name)
        guess = s.saved["initial_guess"]
    else:
        count = None if cfg.io.init_mesh else target_triangle_count(cfg.latent.triangles, cfg.latent.ratio,
                                                                    asset.mesh.num_triangles)
        prepare_outdir(s.outdir, force=s.options.force, resume=s.options.resume)
        guess = s.app.initial_guess(asset, cfg, count)
        if moving:
            with phase("skinning weights"):
                guess = animated.animated_guess(asset, guess, cfg.latent.skin_candidates)
    checkpointer = Checkpointer(checkpoint, cfg.optim.checkpoint_seconds, extra=lambda: {
        "config": config_to_dict(cfg), "initial_guess": guess, "input_fingerprint": fingerprint,
        CHECKPOINT_APPLICATION: s.app.command, "seconds_used": s.seconds_used()})
    if s.saved is None:
        checkpointer.save({})
    return guess, checkpointer


def take_best_start(guess: InitialGuess, score: Callable[[Asset], float] | None, usual: str | None = None) -> None:
    """Start from whichever of ``guess.start`` and ``guess.alternatives`` has the highest
    ``score`` (the validation views, each start as written: the held-out ones stay unseen); the
    alternatives are then dropped (``InitialGuess.take_start``, which keeps the usual start,
    called ``usual``, scored beside them) and a note says which start was taken and why;
    without validation views (``score`` ``None``) the start stays."""
    if not guess.alternatives or score is None:
        guess.alternatives = []
        return
    scores = [(score(asset), label, asset) for label, asset in guess.alternatives]
    best = max(scores, key=lambda candidate: candidate[0])
    own = score(guess.start)
    if best[0] > own:
        guess.take_start(best[1], best[2], usual)
    else:
        others = ", ".join(f"{label} ({value:.2f} dB)" for value, label, _ in scores)
        guess.notes.append(f"started from {guess.own_start(usual)}: it scored higher on the validation views "
                           f"({own:.2f} dB) than {others}")
        guess.alternatives = []


def start_as_written(written: WrittenModel, prepared: Callable[[Asset], Asset]) -> Callable[[Asset], float] | None:
    """The validation score of a start as the fit would begin from it (``prepared``) and as it
    would be written at its own alpha cutoff (one scoring, not the full alpha choice); ``None``
    without validation views."""
    if written.validation is None:
        return None
    return lambda start: written.score(written_alpha(prepared(start), written.mode, AlphaChoice()))


def reference_views(cfg: Config, asset: Asset, reference: Reference, moving: bool, drawn_triangles: int,
                    progress: bool = False, device=CPU) -> tuple[HeldoutViews, HeldoutViews | None, ViewPool | FreshViews]:
    """The held-out views (the report's), the validation views (``None`` without) and the
    training views' source: a pool of reference images refreshed as the steps go (as often as a
    view of ``drawn_triangles`` (``RunReference.drawn_triangles``) allows: ``settings.refresh_interval``),
    or fresh renders at every step; with ``progress``, a bar counts the views rendered up front;
    the models scored on the held-out and validation views are drawn on ``device``."""
    centre, radius = reference.bounding_sphere()
    light = reference.fixed_light
    sampler = view_sampler(centre, radius, poses=animated.heldout_poses(asset) if moving else None, fixed_light=light)
    size, spp, views = cfg.render.resolution, cfg.render.target_spp, cfg.views
    pooled = views.pool_size if views.pool_size and not views.relight else 0
    counted = CountedReference(reference, views.heldout + views.validation + pooled, progress)
    try:
        heldout = HeldoutViews(counted, sampler, views.heldout, views.heldout_seed, size, spp, device)
        validation = (HeldoutViews(counted, sampler, views.validation, views.validation_seed, size, spp, device)
                      if views.validation else None)
        training = view_sampler(centre, radius, cfg.render.horizon_share,
                                poses=animated.training_poses(asset, cfg) if moving else None,
                                distance_spread=cfg.views.distance_spread, fixed_light=light)
        if not views.pool_size:
            return heldout, validation, FreshViews(reference, training, size, spp)
        relight = light_sampler(centre, cfg.render.horizon_share) if views.relight else None
        pool = ViewPool(counted, training, views.pool_size, (cfg.optim.seed, POOL_STREAM),
                        refresh_interval(cfg, drawn_triangles), size, spp, relight)
        return heldout, validation, pool
    finally:
        counted.close()


def score_baselines(s: _Session, cfg: Config, heldout: HeldoutViews, draw, guess: InitialGuess,
                    start: Asset, asset: Asset, reference: RunReference) -> list[MethodResult]:
    """The held-out scores of plain decimation (or the user's mesh), of the initial guess's
    comparisons, of the application's start (or, where it has no label of its own, the classic
    bake), each drawn as the reference says (``RunReference.baseline_draw``), and of what the
    reference adds (``RunReference.extra_baselines``, e.g. the input rasterized beside a path
    tracer's pictures of it)."""
    key, label = (("init_mesh", f"Your mesh ({Path(cfg.io.init_mesh).name})") if cfg.io.init_mesh
                  else ("decimated", "Plain decimation"))
    baseline_draw, drawn = reference.baseline_draw(draw)
    scoring = "drawing" if drawn else "scoring"  # only our own draw's stages estimate the outputs' time
    with s.stage(f"{scoring} plain decimation"):
        methods = [heldout.score(key, label + drawn, guess.baseline, baseline_draw, None)]
    for key, label, model in reference.extra_baselines(asset, start):
        with s.stage(f"scoring {label}"):
            methods.append(heldout.score(key, label, model, draw, None))
    for key, label, model in guess.comparisons:
        with s.stage(f"{scoring} {label}"):
            methods.append(heldout.score(key, label + drawn, model, baseline_draw, cfg.latent.texture_size))
    if s.app.start_label is not None:
        named = guess.start_label or s.app.start_label
        with s.stage(f"{scoring} the start"):
            methods.append(heldout.score("start", named + drawn, start, baseline_draw, cfg.latent.texture_size))
    elif guess.baked is not None:
        with s.stage(f"{scoring} the classic bake"):
            methods.append(heldout.score("baked", "Classic bake" + drawn, guess.baked, baseline_draw,
                                         cfg.latent.texture_size))
    return methods


def fit_seconds(s: _Session, cfg: Config, budget: float, moving: bool, choose_alpha: bool,
                variants: int = 0, alternatives: float = 0.0) -> float | None:
    """The loop's share of this session's ``budget``: what is left after the set-up, less the
    outputs' estimated time (``OUTPUT_TIME_FACTOR`` times the slowest scoring so far, plus the
    validation scorings that choose what is written, one for each of ``variants`` of the
    result, ``alternatives`` seconds of the models the reference offers instead of the fit,
    and the compressed model's, ``compress_seconds``); ``None`` where ``optim.iterations``
    fixes the steps."""
    if cfg.optim.iterations is not None:
        return None
    scorings = OUTPUT_TIME_FACTOR + moving + (moving and s.options.compare_static) + variants
    if choose_alpha:
        scorings += ALPHA_CANDIDATES * cfg.views.validation / cfg.views.heldout
    scorings += 3 * (1 + variants) * cfg.views.validation / cfg.views.heldout  # ours, with its edge texels taken, and the start
    scoring = max(seconds for stage, seconds in s.timings.items() if stage.startswith("scoring"))
    output_time = scorings * scoring + OUTPUT_TIME_MARGIN + compress_seconds(cfg) + alternatives
    return max(budget - (time.monotonic() - s.started) - output_time, 0.0)


def optimise(s: _Session, fitter: Fitter, seconds: float | None, written: WrittenModel, start: Asset,
             notes: list[str], alternatives: Callable[[Asset], dict[str, Asset]],
             form: Callable[[Asset], Asset]) -> tuple[FitResult, Asset]:
    """The loop, and what the run writes (``jobs.written_model``): its best model, one of the
    ``alternatives`` to it, either with its texels beside hard edges taken from further in
    (``with_edge_texels_taken``), or the start, whichever scores best on the validation views
    (said in ``notes``). Each is scored in the ``form`` the file will hold it in (the
    reference's ``written``), so that no candidate is judged in another drawing than the others."""
    with s.stage("optimisation"):
        fit = fitter.run(seconds_available=seconds, progress=s.options.progress)
    if fit.backoffs:
        notes.append(f"the position learning rate was halved {fit.backoffs} time(s), each time the validation "
                     f"fell {fitter.settings.position_backoff:g} dB below the best state, which the fit returned to")
    with s.stage("the written model"):
        best = written.finished(moved(fit.best.export(), CPU))
        if written.validation is None:  # nothing to choose: the fit is written
            offered, best = {}, form(best)
        else:
            offered = {label: form(model) for label, model in alternatives(best).items()}
            best, start = form(best), form(start)
            offered |= with_edge_texels_taken({"ours": best, **offered})
        export, is_start = written.kept(best, start, offered)
    if is_start:
        engine = ("" if written.engine_draw is None else f"; in an engine's draw {written.scores['ours, engine']:.2f} "
                  f"against {written.scores['start, engine']:.2f}")
        notes.append(remark := f"the fit did not improve on its start as written (validation {written.metric} "
                     f"{written.scores['ours']:.2f} against {written.scores['start']:.2f} dB{engine}): model.glb is "
                     f"the start")
        log.warning(remark)
    if (mix := written.kept_label) in MIXES:
        notes.append(f"model.glb: the fitted model with {MIXES[mix]}, which gained more on the start in the run's "
                     f"draw and an engine's (validation {written.scores[mix]:.2f} and {written.scores[mix + ', engine']:.2f} "
                     f"dB, the fit's {written.scores['ours']:.2f} and {written.scores['ours, engine']:.2f}, the "
                     f"start's {written.scores['start']:.2f} and {written.scores['start, engine']:.2f})")
    if (label := written.kept_label) in offered:
        notes.append(f"model.glb: {label}, which scored higher on the validation views ({written.metric} "
                     f"{written.scores[label]:.2f} dB; the fit's {written.scores['ours']:.2f}, the start's "
                     f"{written.scores['start']:.2f})")
    if written.alpha.get("written"):
        notes.append(f"model.glb's alpha: {written.alpha['written']} (chosen on the validation views)")
    return fit, export


def compare_bind_pose(s: _Session, cfg: Config, asset: Asset, heldout: HeldoutViews, draw,
                      methods: list[MethodResult], notes: list[str]) -> bool:
    """Run the bind-pose fit (``jobs.bind_pose``) and score it beside ours; whether it was
    interrupted."""
    with s.stage(BIND_POSE_STAGE):
        model, interrupted = bind_pose_fit(partial(run, s.app), s.input, s.outdir, cfg, s.options)
    if model is not None:
        with s.stage("scoring the bind-pose fit"):
            methods.append(heldout.score("bind_pose", "Bind-pose fit", transfer_skin(asset, model), draw,
                                         cfg.latent.texture_size))
        notes.append("bind-pose fit: the same run with --static (in bind-pose-fit/), its model given the "
                     "input's weights at the closest points of its surface")
    return interrupted


def moving_picture(s: _Session, cfg: Config, reference: Reference, export: Asset, heldout: HeldoutViews):
    """An animated run's moving picture of the reference and ours, at half the resolution."""
    with s.stage("moving picture"):
        small = cfg.render.resolution // 2
        return animated.motion(reference, {"Ours": export}, heldout,
                               partial(render_asset, resolution=small, msaa=cfg.render.latent_msaa), small,
                               cfg.render.target_spp)


def run_record(s: _Session, cfg: Config, asset: Asset, heldout: HeldoutViews, methods: list[MethodResult],
               fit: FitResult, as_written: Asset, notes: list[str], interrupted: bool, moving: bool) -> RunRecord:
    """What the report and the metrics say of the run (``as_written``: what ``model.glb`` holds)."""
    return RunRecord(
        asset_name=asset.name, input=cfg.io.input, reference=heldout.reference, silhouette=heldout.silhouette,
        methods=methods, input_triangles=asset.mesh.num_triangles,
        output_triangles=as_written.mesh.num_triangles,
        texture_size=cfg.latent.texture_size, resolution=cfg.render.resolution,
        loss_history=np.asarray(fit.losses, dtype=np.float64),
        validation_history=np.asarray(fit.validation, dtype=np.float64).reshape(-1, 2),
        validation_views=cfg.views.validation, iterations=fit.iterations, rollbacks=fit.rollbacks,
        position_backoffs=fit.backoffs,
        interrupted=interrupted, wall_time=s.seconds_used(),
        seconds_per_iteration=fit.seconds / max(fit.iterations, 1), timings=s.timings,
        config=config_to_dict(cfg), notes=notes,
        view_labels=animated.pose_labels(asset, heldout.pose) if moving else None)


def write_outputs(s: _Session, cfg: Config, export: Asset, as_written: Asset, guess: InitialGuess,
                  record: RunRecord, score: Callable[[Asset], MethodResult]) -> dict:
    """``model.glb`` (``as_written``, the application's ``written_form`` of ``export``; + ``model.obj``; with ``io.compress``, ``model.compressed.glb``, read back
    and scored by ``score`` among the record's methods), the application's own files,
    ``config.toml``, ``report.html`` and ``metrics.json``, all or none
    (``jobs.outputs.staged_outputs``); returns the metrics. A compressed model whose tool fails
    or hangs is left out (the report says so) and, the others in place, ``OutputsIncomplete``
    is raised (``left_as_found`` leaves them, and the checkpoint)."""
    optional = OptionalOutputs(s.outdir)
    with staged_outputs(s.outdir) as staging:
        with s.stage("export"):
            model = write_model(as_written, staging, cfg.io.export_obj)
            if cfg.io.compress:
                with optional.attempt(COMPRESSED_NAME, record.notes):
                    record.methods.append(score(io.load(write_compressed(model, staging / COMPRESSED_NAME))))
            record.levels = s.app.files(export, guess, cfg, staging, record.methods)
        write_text_atomic(staging / CONFIG_NAME, to_toml(cfg))
        if s.recorder is not None:
            record.profile = s.recorder.as_dict()
        with s.stage("report"):
            metrics = write_record(staging, record, s.started - s.seconds_before)
    optional.check()
    return metrics


KEYWORD_SETTINGS = ("triangles", "ratio", "texture_size", "resolution", "time_budget", "iterations", "seed",
                    "init", "init_mesh", "alpha_mode", "static", "export_obj", "compress")
"""The settings an application's docstring lists (any other setting is a keyword too)."""


def keywords_doc(app: Application, summary: str, settings: tuple[str, ...] = KEYWORD_SETTINGS) -> str:
    """A docstring for ``app``'s function: ``summary``, then each of ``settings`` with its help
    and its default in ``app.defaults`` (``lookalike.settings.setting_help``), then the
    ``RunOptions``; generated, so that what it says is what a run uses."""
    lines = [summary, "", "Args:",
             "    input: any file ``lookalike.io.load`` reads, or an ``Asset``.",
             f"    outdir: output folder (default: the input's name + ``{app.outdir_suffix}``).",
             "    config: a ``Config`` or a TOML file of settings (over this application's defaults).",
             "", "Settings (keywords; every field of ``lookalike.settings.Config`` is one):"]
    for key in settings:
        lines.append(f"    {key}: {setting_help(key)} (default {setting_value(app.defaults, key)!r}).")
    lines += ["", "Run options (keywords; ``RunOptions``): " + ", ".join(OPTION_NAMES) + ".", "",
              "Returns a ``RunResult``. Raises ``ConfigError`` or ``AssetError`` naming the problem."]
    return "\n".join(lines)
