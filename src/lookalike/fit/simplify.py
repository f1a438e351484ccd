"""``simplify``: the whole job, from an input file to ``OUTDIR/model.glb`` and its report.

Steps (paper Sec. 4 and 6): load -> decimate to the target count -> fresh UV atlas and initial
textures -> render the reference (supersampled) on a pool of random training views and on the
held-out views -> optimise -> write ``model.glb`` (+ ``model.obj``), ``metrics.json``,
``config.toml`` and ``report.html`` into OUTDIR, each atomically.

The time budget covers the whole run: the optimisation gets what is left after the set-up,
minus an estimate of the time the outputs take (measured on the decimation baseline).
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import shutil
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np
import torch

from .. import io
from ..asset import Asset, Material
from ..init import decimate
from ..report.data import MethodResult, ReportData
from ..report.html import write_report
from .config import Config, config_to_dict, to_toml, with_overrides
from .evaluate import HeldoutViews
from .initial import decimation_baseline, initial_latent, target_triangle_count
from .optimize import Fitter, FitResult, read_checkpoint
from .outdir import CHECKPOINT_NAME, atomic_path, check_outdir, prepare_outdir, write_text_atomic
from .targets import FreshViews, MeshTarget, ViewPool, latent_renderer
from .views import view_sampler

OUTDIR_SUFFIX = "-lookalike"
OUTPUT_TIME_FACTOR = 2.0
"""The outputs are estimated to take this many times the baseline's held-out scoring."""

OUTPUT_TIME_MARGIN = 5.0
"""Plus these seconds (writing the glTF and the report's pictures)."""

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
    """

    outdir: Path
    model: Path
    report: Path
    metrics: dict
    interrupted: bool = False

    def summary(self) -> str:
        """A few lines for the terminal: where to look, and how much we gained."""
        m = self.metrics
        base, ours = m["heldout"]["decimated"], m["heldout"]["ours"]
        lines = [
            f"{'interrupted; best result so far' if self.interrupted else 'done'}: "
            f"{m['triangles']['output']:,} triangles (input {m['triangles']['input']:,}), "
            f"{m['iterations']} iterations in {m['seconds']['total']:.0f} s",
            f"held-out PSNR: plain decimation {base['psnr']:.2f} dB, ours {ours['psnr']:.2f} dB "
            f"({ours['psnr'] - base['psnr']:+.2f} dB); FLIP {base['flip']:.4f} -> {ours['flip']:.4f}",
        ]
        if "baked" in m["heldout"]:
            baked = m["heldout"]["baked"]
            lines.append(f"classic bake: PSNR {baked['psnr']:.2f} dB (ours {ours['psnr'] - baked['psnr']:+.2f} dB), "
                         f"FLIP {baked['flip']:.4f}")
        lines += [
            f"model:  {self.model}",
            f"report: {self.report}",
        ]
        if self.interrupted:
            lines.append(f"continue with: lookalike simplify {m['input']} -o {self.outdir} --resume")
        return "\n".join(lines)


def simplify(input: str | Path | Asset, outdir: str | Path | None = None, *, triangles: int | None = None,
             ratio: float | None = None, texture_size: int | None = None, resolution: int | None = None,
             time_budget: float | None = None, iterations: int | None = None, init: str | None = None,
             seed: int | None = None, config: Config | str | Path | None = None, resume: bool = False, force: bool = False,
             material_override: Material | None = None, export_obj: bool | None = None,
             progress: bool = True) -> SimplifyResult:
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
        seed: random seed (default 0); same seed, same result.
        config: a ``Config`` or a TOML file with further settings; the arguments above override it.
        resume: continue the run whose ``checkpoint.pt`` is in ``outdir`` (with the settings
            stored in it; ``input`` must be the same asset). A fixed ``iterations`` count is
            completed exactly; under a time budget the resumed session gets the budget afresh.
        force: overwrite an existing ``outdir``.
        material_override: render the input with this material on every triangle (e.g. a
            colour for untextured scans).
        export_obj: also write ``model.obj`` with its ``.mtl`` and PNG textures.
        progress: show a progress bar.

    Raises:
        ConfigError, AssetError: with a message naming the problem.
    """
    started = time.monotonic()
    given = input if isinstance(input, Asset) else None
    name = given.name if given is not None else Path(input).stem
    outdir = Path(outdir) if outdir is not None else Path.cwd() / f"{name}{OUTDIR_SUFFIX}"
    check_outdir(outdir, force=force, resume=resume)
    checkpoint = outdir / CHECKPOINT_NAME
    state = resumed_latent = None
    if resume:
        state, cfg, resumed_latent = read_checkpoint(checkpoint)
    else:
        cfg = with_overrides(config, triangles=triangles, ratio=ratio, texture_size=texture_size,
                             resolution=resolution, time_budget=time_budget, iterations=iterations, init=init, seed=seed,
                             export_obj=export_obj)
        input_name = str(input) if given is None else str(given.source or given.name)
        cfg.io = dataclasses.replace(cfg.io, input=input_name, outdir=str(outdir))

    timings: dict[str, float] = {}
    with _stage(timings, "load and initial guess"):
        asset, notes = _prepare_input(given if given is not None else io.load(input), material_override)
        count = target_triangle_count(cfg.latent, asset.mesh.num_triangles)
        prepare_outdir(outdir, force=force, resume=resume)
        write_text_atomic(outdir / "config.toml", to_toml(cfg))
        decimated = decimate(asset.mesh, count)
        latent, baked = initial_latent(asset, decimated, cfg.latent, cfg.clamp,
                                       np.random.default_rng((cfg.optim.seed, TEXTURE_STREAM)))
        latent = resumed_latent or latent
    with _stage(timings, "reference views"):
        sampler = view_sampler(asset.mesh)
        target = MeshTarget(asset, cfg.render.resolution, cfg.render.target_spp)
        heldout = HeldoutViews(target, sampler, cfg.views.heldout, cfg.views.heldout_seed)
        validation = (HeldoutViews(target, sampler, cfg.views.validation, cfg.views.validation_seed)
                      if cfg.views.validation else None)
        source = (ViewPool(target, sampler, cfg.views.pool_size, (cfg.optim.seed, POOL_STREAM), cfg.views.refresh_every)
                  if cfg.views.pool_size else FreshViews(target, sampler))
    draw = latent_renderer(cfg.render.resolution, cfg.render.latent_msaa)
    with _stage(timings, "scoring plain decimation"):
        baseline = heldout.score("decimated", "Plain decimation", decimation_baseline(asset, decimated), draw, None)
    methods = [baseline]
    if baked is not None:
        with _stage(timings, "scoring the classic bake"):
            methods.append(heldout.score("baked", "Classic bake", baked, draw, cfg.latent.texture_size))

    fitter = Fitter(latent, source, draw, cfg, checkpoint=checkpoint,
                    validate=None if validation is None else lambda model: validation.psnr(model, draw))
    if state is not None:
        fitter.load_state_dict(state)
    output_time = OUTPUT_TIME_FACTOR * timings["scoring plain decimation"] + OUTPUT_TIME_MARGIN
    available = max(cfg.optim.time_budget - (time.monotonic() - started) - output_time, 0.0)
    with _stage(timings, "optimisation"):
        fit = fitter.run(seconds_available=available if cfg.optim.iterations is None else None, progress=progress)
    with _stage(timings, "scoring ours"), torch.no_grad():
        ours = heldout.score("ours", "Ours", fit.best.as_asset(), draw, cfg.latent.texture_size)
    result = _write_outputs(outdir, cfg, asset, fit, heldout, [*methods, ours], timings, started, notes)
    if not fit.interrupted:
        checkpoint.unlink(missing_ok=True)
    return result


@contextlib.contextmanager
def _stage(timings: dict[str, float], name: str) -> Iterator[None]:
    """Record the wall seconds of the ``with`` block as ``timings[name]``."""
    clock = time.monotonic()
    yield
    timings[name] = time.monotonic() - clock


def _prepare_input(asset: Asset, material_override: Material | None) -> tuple[Asset, list[str]]:
    """``asset`` with ``material_override`` applied (a copy; the input is not modified), and
    remarks about it for the report."""
    notes = []
    if material_override is not None:
        mesh = dataclasses.replace(asset.mesh, t_mat_idx=torch.zeros_like(asset.mesh.t_mat_idx))
        asset = dataclasses.replace(asset, mesh=mesh, materials=[material_override])
        notes.append("every triangle of the input rendered with one given material")
    if not asset.mesh.uv:
        notes.append("the input has no UVs: plain decimation shows its constant materials")
    if asset.skin is not None:
        notes.append("the input is skinned: it was simplified in its bind pose, and the output is static")
    return asset, notes


def _write_outputs(outdir: Path, cfg: Config, asset: Asset, fit: FitResult, heldout: HeldoutViews,
                   methods: list[MethodResult], timings: dict, started: float,
                   notes: list[str]) -> SimplifyResult:
    """Write ``model.glb`` (+ OBJ), ``report.html`` and, last, ``metrics.json`` (whose total
    time includes the report), each atomically."""
    model = outdir / "model.glb"
    with _stage(timings, "export"):
        with torch.no_grad():
            export = fit.best.requires_grad_(False).as_asset()
        with atomic_path(model) as temp:
            io.save(export, temp)
        if cfg.io.export_obj:
            _save_obj(export, outdir)
    steps = max(fit.iterations, 1)
    with _stage(timings, "report"):
        report = write_report(outdir, ReportData(
            asset_name=asset.name, reference=heldout.reference, methods=methods,
            input_triangles=asset.mesh.num_triangles, loss_history=np.asarray(fit.losses, dtype=np.float64),
            validation_history=np.asarray(fit.validation, dtype=np.float64).reshape(-1, 2),
            wall_time=time.monotonic() - started, iterations=fit.iterations, seconds_per_iteration=fit.seconds / steps,
            config=config_to_dict(cfg), timings=dict(timings), notes=notes,
        ))
    metrics = {
        "input": cfg.io.input,
        "triangles": {"input": asset.mesh.num_triangles, "output": export.mesh.num_triangles},
        "texture_size": cfg.latent.texture_size,
        "resolution": cfg.render.resolution,
        "iterations": fit.iterations,
        "rollbacks": fit.rollbacks,
        "interrupted": fit.interrupted,
        "seconds": {"total": time.monotonic() - started, "per_iteration": fit.seconds / steps, **timings},
        "final_loss": _last_finite(fit.losses),
        "validation": {"views": cfg.views.validation, "iterations": [i for i, _ in fit.validation],
                       "psnr": [score for _, score in fit.validation]},
        "heldout": {
            "views": len(methods[0].psnr_views),
            "silhouette_pixels": float(heldout.silhouette.mean()),
            **{m.key: {"psnr": m.psnr, "flip": m.flip, "silhouette_error": m.silhouette_error,
                       "psnr_views": m.psnr_views.tolist(), "flip_views": m.flip_views.tolist()} for m in methods},
        },
    }
    write_text_atomic(outdir / "metrics.json", json.dumps(metrics, indent=2))
    return SimplifyResult(outdir=outdir, model=model, report=Path(report), metrics=metrics, interrupted=fit.interrupted)


def _save_obj(asset: Asset, outdir: Path) -> None:
    """Write ``model.obj`` and its companions into a temporary folder, then move each in place."""
    with tempfile.TemporaryDirectory(dir=outdir, prefix=".tmp-obj-") as staging:
        io.save(asset, Path(staging) / "model.obj")
        for written in sorted(Path(staging).iterdir()):
            shutil.move(str(written), str(outdir / written.name))


def _last_finite(values: list[float]) -> float | None:
    return next((v for v in reversed(values) if math.isfinite(v)), None)
