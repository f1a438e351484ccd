"""``simplify``: the whole job, from an input file to ``OUTDIR/model.glb`` and its report.

Steps (paper Sec. 4 and 6): load -> initial guess (our decimation to the target count, or the
user's own low-poly mesh, with a UV atlas and the classic bake) -> render the reference
(supersampled) on a pool of random training views and on the held-out views -> optimise a
``TexturedMesh`` -> write ``model.glb`` (+ ``model.obj``), ``report.html``, ``metrics.json`` and
``config.toml`` into OUTDIR, each atomically.

A skinned input with animations is fitted over its animations (paper Sec. 5.3,
``lookalike.jobs.animated``): the views show it posed at random clips and times, the latent is a
``SkinnedMesh`` whose skinning weights train too, and ``model.glb`` keeps the input's skeleton
and clips; ``static`` (``--static``) simplifies its bind pose into a still model instead.

The time budget covers the whole run: the optimisation gets what is left after the set-up,
minus an estimate of the time the outputs take (measured on the decimation baseline). A resumed
run takes its initial guess from the checkpoint instead of building it again.
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
import torch

from .. import io
from ..asset import Asset, Material
from ..asset.parts import aggregate_traits
from ..errors import ConfigError
from ..fit.checkpoint import Checkpointer, read_checkpoint
from ..fit.config import Config, LatentConfig, loop_settings, objective, refresh_interval
from ..fit.config_file import config_from_dict, config_to_dict, to_toml, with_overrides
from ..fit.loop import Fitter
from ..fit.reference import MeshReference, SkinnedReference
from ..fit.skinned_mesh import SkinnedMesh
from ..fit.textured_mesh import TexturedMesh, constant_channels, render_asset
from ..fit.training_views import FreshViews, ViewPool, light_sampler, view_sampler
from ..init import decimate
from ..init.initial_guess import (InitialGuess, Ranges, initial_guess, initial_guess_from_mesh, target_triangle_count,
                                  uses_alpha)
from ..init.skin_weights import transfer_skin
from ..io.atomic import write_text_atomic
from ..phases import SEPARATOR, Profile, phase, recording
from ..report.heldout import HeldoutViews
from ..report.record import RunRecord
from ..threads import CoreShare
from . import animated
from .alpha_export import ALPHA_CANDIDATES, finished_alpha, training_start
from .outdir import CHECKPOINT_NAME, check_outdir, left_as_found, prepare_outdir
from .outputs import METRICS_NAME, MODEL_NAME, REPORT_NAME, staged_outputs, write_model, write_record

log = logging.getLogger(__name__)

OUTDIR_SUFFIX = "-lookalike"
BIND_POSE_FOLDER = "bind-pose-fit"
"""Where ``compare_static`` runs the bind-pose fit, inside the output folder."""
BIND_POSE_STAGE = "bind-pose fit (a run of its own)"
"""The stage of the timings that holds it."""

OUTPUT_TIME_FACTOR = 2.0
"""The outputs are estimated to take this many times the slowest held-out scoring before the
fit (a baseline's, or the start's: scoring ours, and the report's pictures), once more for each
further scoring after the fit (an animated run's moving picture, the bind-pose fit's), and for a
model with trained alpha the validation renders of its candidate cutoffs
(``lookalike.jobs.alpha_export``)."""

OUTPUT_TIME_MARGIN = 5.0
"""Plus these seconds (writing the glTF and the report's pictures)."""

CHECKPOINT_APPLICATION = "application"
"""The checkpoint's entry naming the command that started the run (a run resumes by the same)."""

POOL_STREAM, TEXTURE_STREAM = 1, 2
"""Independent random streams derived from the seed: ``default_rng((seed, stream))`` (the
optimisation loop itself draws from ``default_rng(seed)``)."""


@dataclass
class SimplifyResult:
    """What ``simplify`` wrote.

    Attributes:
        outdir: the output folder.
        model: path of ``model.glb``.
        report: path of ``report.html``.
        metrics: the content of ``metrics.json``.
        interrupted: the run was stopped by Ctrl-C (the files hold the best result so far and
            ``checkpoint.pt`` lets ``resume=True`` continue).
        baselines: the models ours was compared with, in memory and not written:
            ``{"decimated" (or "init_mesh"): Asset, "baked": Asset}`` (no ``"baked"`` where the
            start was no bake); e.g. for judging them in another renderer.
    """

    outdir: Path
    model: Path
    report: Path
    metrics: dict
    interrupted: bool = False
    baselines: dict[str, Asset] = field(default_factory=dict)
    command: str = "simplify"

    def summary(self) -> str:
        """A few lines for the terminal: where to look, and how much we gained."""
        m = self.metrics
        heldout = m["heldout"]
        base, ours = heldout[m["methods"][0]], heldout["ours"]
        label = base["label"][0].lower() + base["label"][1:]
        lines = [
            f"{'interrupted; best result so far' if self.interrupted else 'done'}: "
            f"{m['triangles']['output']:,} triangles (input {m['triangles']['input']:,}), "
            f"{m['iterations']} iterations in {m['seconds']['total']:.0f} s",
            f"held-out PSNR: {label} {base['psnr']:.2f} dB, ours {ours['psnr']:.2f} dB "
            f"({ours['psnr'] - base['psnr']:+.2f} dB); FLIP {base['flip']:.4f} -> {ours['flip']:.4f}",
        ]
        for key in m["methods"][1:-1]:
            other = heldout[key]
            lines.append(f"{other['label'][0].lower() + other['label'][1:]}: PSNR {other['psnr']:.2f} dB "
                         f"(ours {ours['psnr'] - other['psnr']:+.2f} dB), FLIP {other['flip']:.4f}")
        if "profile" in m:
            lines.append("where the time went (wall s, CPU/wall; nested phases indented):")
            lines += [f"  {'  ' * path.count(SEPARATOR)}{path.split(SEPARATOR)[-1]:<{40 - 2 * path.count(SEPARATOR)}} "
                      f"{t['wall_s']:8.1f}  {t['cpu_per_wall']:4.2f}" for path, t in m["profile"].items()]
        lines += [f"model:  {self.model}", f"report: {self.report}"]
        if self.interrupted:
            lines.append(f"continue with: lookalike {self.command} {m['input']} -o {self.outdir} --resume")
        return "\n".join(lines)


def simplify(input: str | Path | Asset, outdir: str | Path | None = None, *, triangles: int | None = None,
             ratio: float | None = None, texture_size: int | None = None, resolution: int | None = None,
             time_budget: float | None = None, iterations: int | None = None, init: str | None = None,
             init_mesh: str | Path | None = None, seed: int | None = None, config: Config | str | Path | None = None,
             resume: bool = False, force: bool = False, material_override: Material | None = None,
             export_obj: bool | None = None, static: bool | None = None, compare_static: bool = False,
             progress: bool = True, profile: bool = False) -> SimplifyResult:
    """Simplify the asset in ``input`` into ``outdir``.

    Args:
        input: any file ``lookalike.io.load`` reads, or an ``Asset``.
        outdir: output folder (default: ``<input name>-lookalike`` in the current folder). An
            existing non-empty folder is refused unless ``force`` (or ``resume``).
        triangles, ratio: target triangle count, or fraction of the input's (default 0.02).
        texture_size: side of the square textures (default 1024).
        resolution: side of the training and report images (default 512).
        time_budget: wall seconds for the whole run (default 600); ignored when
            ``iterations`` is given.
        iterations: fixed number of optimisation steps.
        init: how the textures start (``"bake"``, the default, ``"source"``, ``"average"`` or
            ``"random"``; see ``LatentConfig.init``).
        init_mesh: start from this low-poly mesh (any readable file, in the input's frame)
            instead of our decimation: the paper's automatic clean-up of an existing LOD. Its
            UVs and textures are kept where it has a usable atlas and one textured material;
            otherwise the input is baked onto it (onto a fresh atlas where its UVs overlap).
        seed: random seed (default 0); same seed and thread count, same result (the thread
            count adapts to other busy programs unless pinned, ``lookalike.threads``).
        config: a ``Config`` or a TOML file with further settings; the arguments above override it.
        resume: continue the run whose ``checkpoint.pt`` is in ``outdir`` bit-exactly, with the
            settings and the initial guess stored in it (other options given are ignored, and
            a warning names them); ``input`` must be the same asset (the same content), else
            ``ConfigError``. The time budget is the run's total over all its sessions, unless
            ``time_budget`` is given again: then this session gets it.
        force: overwrite an existing ``outdir``.
        material_override: render the input with this material on every triangle (e.g. a
            colour for untextured scans).
        export_obj: also write ``model.obj`` with its ``.mtl`` and PNG textures (a skinned
            model's bind pose).
        static: for a skinned input with animations, simplify its bind pose into a still model
            instead of fitting it, weights included, over its animations (``latent.static``).
        compare_static: for an animated input, also run the bind-pose fit (``static``, the
            same settings and a budget of its own) into ``outdir/bind-pose-fit/``, give its
            model the input's weights (``transfer_skin``) and score it beside ours: what fitting
            the animations gained. Twice the time.
        progress: show a progress bar.
        profile: record where the time goes (``lookalike.phases``: wall and CPU seconds of
            each phase, nested) into ``metrics.json`` as ``"profile"``.

    Outputs appear only when complete (written into a temporary folder inside ``outdir`` and
    moved into place, ``metrics.json`` last). A run that fails leaves ``outdir`` as it found it
    (a folder it created is removed; an interrupted run keeps its checkpoint).

    Raises:
        ConfigError, AssetError: with a message naming the problem.
    """
    options = {"triangles": triangles, "ratio": ratio, "texture_size": texture_size, "resolution": resolution,
               "iterations": iterations, "init": init, "seed": seed, "export_obj": export_obj, "static": static}
    return run(SIMPLIFY, input, outdir, options, time_budget=time_budget, init_mesh=init_mesh, config=config,
               resume=resume, force=force, material_override=material_override, compare_static=compare_static,
               progress=progress, profile=profile)


@dataclass(frozen=True)
class Application:
    """What one application of the fit brings to the run every application shares (``run``):
    ``simplify`` here, ``cards`` (``lookalike.jobs.cards``).

    Attributes:
        command: its ``lookalike`` subcommand; a checkpoint resumes under the same one.
        outdir_suffix: the default output folder is the input's name + this.
        initial_guess: ``(input, cfg, count) -> InitialGuess``, ``count`` the target triangle
            count (``None`` where ``cfg.io.init_mesh`` gives the mesh).
        start_label: the label its start is scored under beside the baselines, or ``None``
            (then a start that is a classic bake is scored as "Classic bake").
        defaults: the settings a run starts from, before a settings file and the options.
        remarks: ``input -> [str]``, what to say about the input (logged, and in the report).
    """

    command: str
    outdir_suffix: str
    initial_guess: Callable[[Asset, Config, int | None], InitialGuess]
    start_label: str | None = None
    defaults: Config = field(default_factory=Config)
    remarks: Callable[[Asset], list[str]] = lambda asset: []


def run(app: Application, input: str | Path | Asset, outdir: str | Path | None, options: dict, *,
        time_budget: float | None = None, init_mesh: str | Path | None = None, config: Config | str | Path | None = None,
        resume: bool = False, force: bool = False, material_override: Material | None = None,
        compare_static: bool = False, progress: bool = True, profile: bool = False) -> SimplifyResult:
    """The run of ``app`` on ``input`` into ``outdir`` (``simplify`` documents the arguments;
    ``options`` holds the settings given as keyword arguments, ``None`` where not given)."""
    started = time.monotonic()
    given = input if isinstance(input, Asset) else None
    name = given.name if given is not None else Path(input).stem
    outdir = Path(outdir) if outdir is not None else Path.cwd() / f"{name}{app.outdir_suffix}"
    check_outdir(outdir, force=force, resume=resume)
    recorder = Profile() if profile else None
    with left_as_found(outdir), (recording(recorder) if recorder else contextlib.nullcontext()):
        return _run(app, input, given, outdir, options, time_budget, init_mesh, config, resume, force,
                    material_override, compare_static, progress, started, recorder)


def _run(app: Application, input, given: Asset | None, outdir: Path, options: dict, time_budget: float | None,
         init_mesh, config, resume: bool, force: bool, material_override: Material | None, compare_static: bool,
         progress: bool, started: float, recorder: Profile | None) -> SimplifyResult:
    """``run`` once its output folder is checked (see there)."""
    checkpoint = outdir / CHECKPOINT_NAME
    saved = read_checkpoint(checkpoint) if resume else None
    if saved is not None:
        check_same_command(saved, checkpoint, app.command)
        cfg = resumed_config(saved, checkpoint, {**options, "time_budget": time_budget, "config": config,
                                                 "init_mesh": init_mesh})
        seconds_before = saved["seconds_used"]
        budget = time_budget if time_budget is not None else cfg.optim.time_budget - seconds_before
    else:
        cfg = with_overrides(config, defaults=app.defaults, time_budget=time_budget, **options)
        input_name = str(input) if given is None else str(given.source or given.name)
        cfg.io = dataclasses.replace(cfg.io, input=input_name, init_mesh="" if init_mesh is None else str(init_mesh),
                                     outdir=str(outdir))
        seconds_before, budget = 0.0, cfg.optim.time_budget

    timings: dict[str, float] = {}
    with _stage(timings, "load and initial guess"):
        with phase("load"):
            loaded = given if given is not None else io.load(input)
        moving = animated.is_animated(loaded, cfg.latent.static)
        asset, notes = prepare_input(loaded, material_override, moving)
        for remark in app.remarks(asset):
            log.warning("%s: %s", cfg.io.input or asset.name, remark)
            notes.append(remark)
        if moving and cfg.views.relight:
            raise ConfigError("views.relight keeps one G-buffer per camera, and an animated input's geometry changes "
                              "with every view's pose: turn it off, or simplify the bind pose with --static")
        if moving and cfg.io.export_obj:
            notes.append(obj_note := "model.obj holds the bind pose: OBJ has no skeleton (model.glb has it)")
            log.warning(obj_note)
        fingerprint = asset.fingerprint()
        if saved is not None:
            check_same_input(saved, checkpoint, fingerprint, str(input) if given is None else given.name)
            guess = saved["initial_guess"]
        else:
            count = None if cfg.io.init_mesh else _triangle_target(cfg.latent, asset)
            prepare_outdir(outdir, force=force, resume=resume)
            guess = app.initial_guess(asset, cfg, count)
            if moving:
                with phase("skinning weights"):
                    guess = animated.animated_guess(asset, guess, cfg.latent.skin_candidates)
        checkpointer = Checkpointer(checkpoint, cfg.optim.checkpoint_seconds, extra=lambda: {
            "config": config_to_dict(cfg), "initial_guess": guess, "input_fingerprint": fingerprint,
            CHECKPOINT_APPLICATION: app.command,
            "seconds_used": seconds_before + time.monotonic() - started})
        if saved is None:
            checkpointer.save({})
        reference = SkinnedReference(asset) if moving else MeshReference(asset, cfg.render.layers)
        centre, radius = reference.bounding_sphere()
        bind_centre, bind_radius = asset.mesh.bounding_sphere()
        start = training_start(guess.start, cfg.latent.alpha_mode)
        train_alpha = uses_alpha(start)
        surface = {"centre": bind_centre, "radius": bind_radius, "limits": cfg.clamp, "msaa": cfg.render.latent_msaa,
                   "train_alpha": train_alpha, "layers": cfg.render.layers,
                   "constant": constant_channels(asset) if cfg.latent.constant_colour else frozenset(),
                   "texture_scales": cfg.latent.texture_scales}
        latent = SkinnedMesh.from_asset(start, **surface) if moving else TexturedMesh.from_asset(start, **surface)
    with _stage(timings, "reference views"):
        sampler = view_sampler(centre, radius, poses=animated.heldout_poses(asset) if moving else None)
        size, spp = cfg.render.resolution, cfg.render.target_spp
        heldout = HeldoutViews(reference, sampler, cfg.views.heldout, cfg.views.heldout_seed, size, spp)
        validation = (HeldoutViews(reference, sampler, cfg.views.validation, cfg.views.validation_seed, size, spp)
                      if cfg.views.validation else None)
        training = view_sampler(centre, radius, cfg.render.horizon_share,
                                poses=animated.training_poses(asset, cfg) if moving else None)
        relight = light_sampler(centre, cfg.render.horizon_share) if cfg.views.relight else None
        source = (ViewPool(reference, training, cfg.views.pool_size, (cfg.optim.seed, POOL_STREAM),
                           refresh_interval(cfg, asset.mesh.num_triangles), size, spp, relight)
                  if cfg.views.pool_size else FreshViews(reference, training, size, spp))
    draw = partial(render_asset, resolution=cfg.render.resolution, msaa=cfg.render.latent_msaa,
                   layers=cfg.render.layers)
    baseline_key, baseline_label = ("init_mesh", f"Your mesh ({Path(cfg.io.init_mesh).name})") if cfg.io.init_mesh \
        else ("decimated", "Plain decimation")
    with _stage(timings, "scoring plain decimation"):
        baseline = heldout.score(baseline_key, baseline_label, guess.baseline, draw, None)
    methods = [baseline]
    if app.start_label is not None:
        with _stage(timings, "scoring the start"):
            methods.append(heldout.score("start", app.start_label, start, draw, cfg.latent.texture_size))
    elif guess.baked is not None:
        with _stage(timings, "scoring the classic bake"):
            methods.append(heldout.score("baked", "Classic bake", guess.baked, draw, cfg.latent.texture_size))

    fitter = Fitter(latent, source, objective(cfg), loop_settings(cfg, outline=not train_alpha),
                    validate=None if validation is None else lambda model: validation.psnr(model.export(), draw),
                    checkpointer=checkpointer, cores=CoreShare())
    if saved is not None and "latent" in saved:
        fitter.load_state_dict(saved)
    scorings = OUTPUT_TIME_FACTOR + moving + (moving and compare_static)
    if train_alpha and validation is not None:
        scorings += ALPHA_CANDIDATES * cfg.views.validation / cfg.views.heldout
    scoring = max(seconds for stage, seconds in timings.items() if stage.startswith("scoring"))
    output_time = scorings * scoring + OUTPUT_TIME_MARGIN
    available = max(budget - (time.monotonic() - started) - output_time, 0.0)
    with _stage(timings, "optimisation"):
        fit = fitter.run(seconds_available=available if cfg.optim.iterations is None else None, progress=progress)
    with _stage(timings, "alpha cutoff"):
        export = finished_alpha(fit.best.export(), cfg.latent.alpha_mode,
                                None if validation is None else partial(validation.psnr, render=draw))
    interrupted = fit.interrupted
    if moving and compare_static and not interrupted:
        with _stage(timings, BIND_POSE_STAGE):
            bind_pose, interrupted = bind_pose_fit(given if given is not None else input, outdir, cfg,
                                                   resume=saved is not None, material_override=material_override,
                                                   progress=progress)
        if interrupted:  # our fit is done: a resume goes straight on to the bind-pose fit
            checkpointer.save(fitter.state_dict())
        if bind_pose is not None:
            with _stage(timings, "scoring the bind-pose fit"):
                methods.append(heldout.score("bind_pose", "Bind-pose fit", transfer_skin(asset, bind_pose), draw,
                                             cfg.latent.texture_size))
            notes.append(f"bind-pose fit: the same run with --static (in {BIND_POSE_FOLDER}/), its model given the "
                         "input's weights at the closest points of its surface")
    with _stage(timings, "scoring ours"):
        methods.append(heldout.score("ours", "Ours", export, draw, cfg.latent.texture_size))
    motion = None
    if moving:
        with _stage(timings, "moving picture"):
            small = cfg.render.resolution // 2
            motion = animated.motion(reference, {"Ours": export}, heldout,
                                     partial(render_asset, resolution=small, msaa=cfg.render.latent_msaa), small,
                                     cfg.render.target_spp)
    record = RunRecord(
        asset_name=asset.name, input=cfg.io.input, reference=heldout.reference, silhouette=heldout.silhouette,
        methods=methods, input_triangles=asset.mesh.num_triangles, output_triangles=export.mesh.num_triangles,
        texture_size=cfg.latent.texture_size, resolution=cfg.render.resolution,
        loss_history=np.asarray(fit.losses, dtype=np.float64),
        validation_history=np.asarray(fit.validation, dtype=np.float64).reshape(-1, 2),
        validation_views=cfg.views.validation, iterations=fit.iterations, rollbacks=fit.rollbacks,
        interrupted=interrupted, wall_time=seconds_before + time.monotonic() - started,
        seconds_per_iteration=fit.seconds / max(fit.iterations, 1), timings=timings,
        config=config_to_dict(cfg), notes=notes + guess.notes,
        view_labels=animated.pose_labels(asset, heldout.pose) if moving else None, motion=motion,
    )
    with staged_outputs(outdir) as staging:
        with _stage(timings, "export"):
            write_model(export, staging, cfg.io.export_obj)
        write_text_atomic(staging / "config.toml", to_toml(cfg))
        if recorder is not None:
            record.profile = recorder.as_dict()
        with _stage(timings, "report"):
            metrics = write_record(staging, record, started - seconds_before)
    if not interrupted:
        checkpoint.unlink(missing_ok=True)
    baselines = {baseline_key: guess.baseline, **({"baked": guess.baked} if guess.baked is not None else {})}
    if app.start_label is not None:
        baselines["start"] = start
    return SimplifyResult(outdir=outdir, model=outdir / MODEL_NAME, report=outdir / REPORT_NAME, metrics=metrics,
                          interrupted=interrupted, baselines=baselines, command=app.command)


def bind_pose_fit(input, outdir: Path, cfg: Config, resume: bool, material_override: Material | None,
                  progress: bool) -> tuple[Asset | None, bool]:
    """The bind-pose fit of an animated run (``compare_static``): ``simplify`` of ``input`` with
    ``cfg``'s settings and ``latent.static`` into ``outdir/BIND_POSE_FOLDER`` (its own time
    budget, checkpoint and report), and its model. When the animated run is resumed, a finished
    bind-pose fit is taken as it is and an interrupted one resumed; a fresh run makes it afresh.

    Returns:
        ``(model, interrupted)``: the still model (``None`` if it was interrupted) and whether
        it was.
    """
    folder = outdir / BIND_POSE_FOLDER
    if resume and (folder / METRICS_NAME).is_file() and not (folder / CHECKPOINT_NAME).exists():
        return io.load(folder / MODEL_NAME), False
    static = dataclasses.replace(cfg, latent=dataclasses.replace(cfg.latent, static=True))
    result = simplify(input, folder, config=static, resume=resume and (folder / CHECKPOINT_NAME).is_file(),
                      force=True, material_override=material_override, progress=progress)
    return (None, True) if result.interrupted else (io.load(result.model), False)


def resumed_config(saved: dict, checkpoint: Path, given: dict) -> Config:
    """The configuration stored in the checkpoint ``saved``; logs one line naming the given
    options (``given``, ``None`` where not given) that it overrides: every setting of a resumed
    run is the checkpoint's, except a new ``time_budget`` for this session."""
    cfg = config_from_dict(saved["config"], origin=str(checkpoint))
    ignored = []
    for key, value in given.items():
        if value is None or key == "time_budget":
            continue
        if key in ("config", "init_mesh"):
            ignored.append(f"--{key.replace('_', '-')} {value}")
            continue
        section = _SECTION_OF[key]
        current = getattr(getattr(cfg, section), key)
        if getattr(getattr(with_overrides(cfg, **{key: value}), section), key) != current:
            ignored.append(f"--{key.replace('_', '-')} {value} (the run has {current})")
    if ignored:
        log.warning("%s: resuming with the checkpoint's settings; ignored: %s", checkpoint, ", ".join(ignored))
    return cfg


_SECTION_OF = {"triangles": "latent", "ratio": "latent", "texture_size": "latent", "init": "latent",
               "resolution": "render", "iterations": "optim", "seed": "optim", "export_obj": "io",
               "static": "latent", "alpha_mode": "latent"}


def check_same_command(saved: dict, checkpoint: Path, command: str) -> None:
    """``ConfigError`` unless the checkpoint's run was started by ``command`` (runs from before
    the checkpoint named its command were ``simplify``'s)."""
    started_by = saved.get(CHECKPOINT_APPLICATION, "simplify")
    if started_by != command:
        raise ConfigError(f"{checkpoint}: this run was started by lookalike {started_by}; resume it with "
                          f"lookalike {started_by} ... --resume, or start afresh with --force")


def check_same_input(saved: dict, checkpoint: Path, fingerprint: str, input_name) -> None:
    """``ConfigError`` naming both inputs unless the asset being resumed has the content the
    checkpoint's run started from."""
    if saved.get("input_fingerprint") != fingerprint:
        raise ConfigError(f"{checkpoint}: this run was started from {saved['config']['io']['input']}, and "
                          f"{input_name} is a different asset (content {fingerprint[:12]}, not "
                          f"{str(saved.get('input_fingerprint'))[:12]}); resume with the same input, or start "
                          "afresh with --force")


def _triangle_target(latent: LatentConfig, asset: Asset) -> int:
    """The decimation target of ``latent`` (``triangles``, else ``ratio`` or the default ratio)."""
    ratio = latent.ratio if latent.ratio is not None else LatentConfig.DEFAULT_RATIO
    return target_triangle_count(latent.triangles, ratio, asset.mesh.num_triangles)


def build_initial_guess(asset: Asset, cfg: Config, count: int | None) -> InitialGuess:
    """The initial guess of a run: the user's mesh (``cfg.io.init_mesh``) with its own textures
    or a bake, else our decimation to ``count`` triangles with ``cfg.latent.init``'s textures."""
    size = cfg.latent.texture_size
    if cfg.io.init_mesh:
        lod = io.load(cfg.io.init_mesh)
        return initial_guess_from_mesh(asset, lod, Path(cfg.io.init_mesh).name, size)
    clamp = cfg.clamp
    ranges = Ranges(kd=clamp.kd, ks=(clamp.gamma, clamp.roughness, clamp.metalness))
    with phase("decimation"):
        decimated = decimate(asset.mesh, count)
    return initial_guess(asset, decimated, cfg.latent.init, size, ranges,
                         np.random.default_rng((cfg.optim.seed, TEXTURE_STREAM)))


@contextlib.contextmanager
def _stage(timings: dict[str, float], name: str) -> Iterator[None]:
    """Record the wall seconds of the ``with`` block as ``timings[name]`` (and as a phase of
    the recording profile, ``lookalike.phases``)."""
    clock = time.monotonic()
    with phase(name):
        yield
    timings[name] = time.monotonic() - clock


def prepare_input(asset: Asset, material_override: Material | None, moving: bool = False) -> tuple[Asset, list[str]]:
    """``asset`` with ``material_override`` applied (a copy; the input is not modified), and
    remarks about it for the report; ``moving``: it is fitted over its animations
    (``animated.is_animated``)."""
    notes = []
    if material_override is not None:
        mesh = dataclasses.replace(asset.mesh, t_mat_idx=torch.zeros_like(asset.mesh.t_mat_idx))
        asset = dataclasses.replace(asset, mesh=mesh, materials=[material_override])
        notes.append("every triangle of the input rendered with one given material")
    if not asset.mesh.uv:
        notes.append("the input has no UVs: plain decimation shows its constant materials")
    if moving:
        clips = ", ".join(a.name for a in asset.animations)
        notes.append(f"the input is skinned: it was simplified over its {len(asset.animations)} animation clip"
                     f"{'s' if len(asset.animations) > 1 else ''} ({clips}) with its skinning weights; the output "
                     f"keeps its skeleton ({len(asset.skin.joints)} joints) and clips, and held-out views show "
                     "every clip")
    elif asset.skin is not None:
        notes.append("the input is skinned: it was simplified in its bind pose, and the output is static")
    return asset, notes


def aggregate_remarks(asset: Asset) -> list[str]:
    """One line suggesting ``lookalike cards`` where ``asset`` looks like aggregate geometry
    (``lookalike.asset.parts.aggregate_traits``), else none."""
    traits = aggregate_traits(asset)
    if traits is None:
        return []
    return [f"the input looks like aggregate geometry ({traits}): decimation melts such parts into blobs; "
            "lookalike cards approximates them with alpha-textured cards"]


SIMPLIFY = Application(command="simplify", outdir_suffix=OUTDIR_SUFFIX,
                       initial_guess=lambda asset, cfg, count: build_initial_guess(asset, cfg, count),
                       remarks=aggregate_remarks)
"""``simplify``: decimation (or the user's mesh) and the classic bake, fitted."""
