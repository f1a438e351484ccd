"""``lookalike bench cards``: foliage as cards on the generated foliage of
``lookalike.samples.foliage`` (the shrub of leaf meshes, and a broadleaf tree, a grass tuft and a
conifer drawn as real-time foliage is, alpha-textured cards on bark, and a game's tree of 5,604
triangles, leaf clusters on quads over low-poly bark), each at two budgets, 0.5 % and 2 % of its
triangles.

Per case, with default settings: ``cards`` as a user runs it (alpha-tested, or as the case
says blended); on the shrub also
``simplify`` at the same triangle count (its renders peeled as deep as ``cards``', so that both
see through the leaves' cut-outs alike). Beside them plain decimation (ours, and where judged
Blender's Decimate with the input's materials kept, ``blender.decimate_bake.blender_decimate_glb``:
what a Blender user makes, its leaf textures whole), stochastic simplification (Cook et al.
2007, ``lookalike.init.stochastic``: a random share of the leaves kept, enlarged and their
contrast pulled in) and the starts as the run wrote them (their alpha chosen on the validation
views, ``lookalike.jobs.written_model``): the billboard cloud, and where the input is already
cards of one leaf texture the start that keeps it (``lookalike.init.leaf_texture_cards``). Every model is scored on the ``cards``
run's held-out views (same sampler, seed and count), in our renderer with ``render.layers``
depth-peeled layers: PSNR, FLIP and the silhouette's intersection over union with the
reference's coverage; with ``judge="blender"`` also in Cycles and in three.js, each with its
shadows on and off (``lookalike.jobs.judge_scores``).

Bar, on every case and in every renderer scored: ``cards`` within 10 minutes on a 2-core
machine; ``cards`` as written at least its starts (never below) and at least every plain
decimation + 2 dB with a lower FLIP.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
import tempfile
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

from ._table import judged_table, runs_table
from .quality import TIME_BUDGET_S, check_judge, output_root

log = logging.getLogger(__name__)

HELP = "approximate generated foliage with cards; compare with decimation, stochastic simplification and simplify"

BAR_MINUTES = 10.0
BAR_GAIN_OVER_DECIMATED_DB = 2.0

STOCHASTIC_SEED = 0

NOT_RUN = float("nan")
"""The score of a method a case does not run (``simplify`` beside foliage other than the shrub)."""


@dataclass(frozen=True)
class CardsCase:
    """One benchmark case: the foliage ``kind`` (``samples.foliage.FOLIAGE``, generated with
    ``sizes``) kept at ``share`` of its triangles; ``simplify``: run ``simplify`` beside it;
    ``alpha``: the ``cards`` run's ``--alpha`` (``None``: its default, alpha-tested)."""

    name: str
    kind: str
    share: float
    simplify: bool = False
    sizes: dict = field(default_factory=dict, hash=False)
    alpha: str | None = None


BENCH_SIZES = {"shrub": {}, "broadleaf-tree": {}, "game-tree": {}, "grass-tuft": {"blades": 3000},
               "conifer": {"whorls": 480}}
"""Each kind's generator arguments: the tuft and the conifer denser than their defaults
(24,016 and 17,540 triangles), so that 0.5 % of them still makes some fifty cards."""

ASSETS = tuple(CardsCase(f"{kind}-{label}", kind, share, simplify=kind == "shrub", sizes=sizes)
               for kind, sizes in BENCH_SIZES.items() for share, label in ((0.005, "0.5pct"), (0.02, "2pct"))
               ) + (CardsCase("game-tree-9pct", "game-tree", 0.09),
                    CardsCase("grass-tuft-2pct-blend", "grass-tuft", 0.02, sizes=BENCH_SIZES["grass-tuft"],
                              alpha="blend"))
"""Every kind at 0.5 % and 2 % of its triangles; the game's tree also at 9 % (504 triangles),
the gentle budget of a game's far LOD, at which plain decimation still keeps leaves; the grass
tuft at 2 % also blended (``--alpha blend``), where the alpha test cannot draw the partial
coverage of blades a pixel thin."""

METHODS = (("decimated", "Plain decimation"), ("blender_decimated", "Blender's Decimate"),
           ("stochastic", "Stochastic simplification"), ("simplify", "simplify"), ("start", "Billboard cloud"),
           ("leaf_texture", "Leaf texture kept"), ("cards", "cards"))
"""(key, label) of the scored methods, in table order (``simplify`` where the case runs it,
Blender's Decimate where judged)."""

DECIMATIONS = ("decimated", "blender_decimated")
"""The methods ``cards`` is held to beat by ``BAR_GAIN_OVER_DECIMATED_DB``, where scored."""


def run(repeats: int | None = None, out: str | Path | None = None, time_budget: float = TIME_BUDGET_S,
        assets: tuple[CardsCase, ...] = ASSETS, reuse: bool = False, judge: str | None = None) -> dict:
    """Run every case (module docstring).

    Args:
        repeats: ignored (each run takes minutes).
        out: keep the runs in ``out/<case>/{cards,simplify}`` (default:
            ``$LOOKALIKE_BENCH_OUT`` or a temporary folder removed afterwards).
        time_budget: seconds per run (the default run's 600).
        assets: which cases.
        reuse: take the runs already in ``out`` (those with a ``metrics.json``) instead of
            running them again.
        judge: ``"blender"``: also decimate with Blender and render every method and the input
            in Blender Cycles and in three.js on the same views and score them there
            (``lookalike.jobs.judge_scores``; needs the ``judge`` extra, Chromium and three.js).

    Returns:
        ``{"time_budget_s", "bar", "runs": [row, ...], "all_meet_bar", "outputs"}``; a row holds
        the case, triangle counts, the minutes and seconds per step of the runs and, per method
        scored, ``psnr_<key>``, ``flip_<key>``, ``iou_<key>`` and ``kb_<key>`` (its glb's
        kilobytes: a run's ``model.glb``, the others as ``io.save`` writes them into
        ``out/<case>/models``), the gains of ``cards`` and
        whether it meets the bar; judged rows also hold ``"judge"``:
        ``{renderer: {method: {"psnr", "flip"}}}``.
    """
    from ..io import save
    from ..samples.foliage import FOLIAGE

    if judge is not None:
        from ..webgl import require_threejs

        check_judge(judge)
        require_threejs()
    with tempfile.TemporaryDirectory(prefix="lookalike-bench-") as scratch:
        root = output_root(out, scratch)
        root.mkdir(parents=True, exist_ok=True)
        rows = []
        for case in assets:
            source = root / f"{case.kind}.glb"
            if not (reuse and source.is_file()):
                save(FOLIAGE[case.kind](**case.sizes), source)
            rows.append(_case(case, source, root / case.name, time_budget, reuse, judge is not None))
        return {
            "time_budget_s": time_budget,
            "bar": {"minutes": BAR_MINUTES, "gain_over_decimated_db": BAR_GAIN_OVER_DECIMATED_DB},
            "runs": rows,
            "all_meet_bar": all(r["meets_bar"] for r in rows),
            "outputs": None if root == Path(scratch) else str(root.resolve()),
        }


def _case(case: CardsCase, source: Path, folder: Path, time_budget: float, reuse: bool, judged: bool) -> dict:
    """The runs of one case, every method scored on the ``cards`` run's held-out views (and
    judged in Cycles where ``judged``), and the table row."""
    from .. import io
    from ..settings import load_config
    from ..fit.reference import MeshReference
    from ..fit.textured_mesh import render_asset
    from ..fit.training_views import view_sampler
    from ..jobs.cards import cards
    from ..jobs.simplify import simplify
    from ..report.heldout import HeldoutViews

    asset = io.load(source)
    count = max(2, round(case.share * asset.mesh.num_triangles))
    runs = [("cards", cards, {} if case.alpha is None else {"alpha_mode": case.alpha})]
    if case.simplify:
        runs.append(("simplify", simplify, {"config": _peeled_like_cards()}))
    metrics = {}
    for name, job, options in runs:
        run_dir = folder / name
        if not (reuse and (run_dir / "metrics.json").is_file()):
            job(source, run_dir, triangles=count, time_budget=time_budget, force=True, progress=False, **options)
        metrics[name] = json.loads((run_dir / "metrics.json").read_text())
    cfg = load_config(folder / "cards" / "config.toml")
    reference = MeshReference(asset, cfg.render.reference_layers)
    centre, radius = reference.bounding_sphere()
    sampler = view_sampler(centre, radius)
    heldout = HeldoutViews(reference, sampler, cfg.views.heldout, cfg.views.heldout_seed, cfg.render.resolution,
                           cfg.render.target_spp)
    draw = partial(render_asset, resolution=cfg.render.resolution, msaa=cfg.render.latent_msaa,
                   layers=cfg.render.layers)
    validation = HeldoutViews(reference, sampler, cfg.views.validation, cfg.views.validation_seed,
                              cfg.render.resolution, cfg.render.target_spp)
    models = _methods(asset, count, cfg, folder, validation, draw, source if judged else None, reuse)
    files = _model_files(models, folder)
    row = {"asset": case.name, "input_triangles": asset.mesh.num_triangles, "triangles": count,
           **{f"minutes_{name}": m["seconds"]["total"] / 60 for name, m in metrics.items()},
           **{f"step_s_{name}": m["seconds"]["per_iteration"] for name, m in metrics.items()},
           "iterations": metrics["cards"]["iterations"]}
    for key, label in METHODS:
        row.update({f"psnr_{key}": NOT_RUN, f"flip_{key}": NOT_RUN, f"iou_{key}": NOT_RUN, f"kb_{key}": NOT_RUN})
        if key in models:
            scored = heldout.score(key, label, models[key], draw, None)
            row.update({f"psnr_{key}": scored.psnr, f"flip_{key}": scored.flip, f"iou_{key}": scored.silhouette_iou,
                        f"triangles_{key}": models[key].mesh.num_triangles, f"kb_{key}": files[key].stat().st_size / 1000})
    if judged:
        row["judge"] = _judge(reference, source, models, files, cfg, folder / "judge")
    return _with_bar(row)


def beats_bar(scores: dict) -> bool:
    """Whether ``cards`` meets the bar in one renderer's ``scores`` (``{key: {"psnr", "flip"}}``,
    NaN for a method not scored): ``cards`` scored, at least each start scored, and every
    decimation scored + 2 dB with a lower FLIP."""
    cards = scores["cards"]
    if math.isnan(cards["psnr"]):
        return False
    decimations = [scores[key] for key in DECIMATIONS if not math.isnan(scores[key]["psnr"])]
    starts = [scores[key]["psnr"] for key in ("start", "leaf_texture") if not math.isnan(scores[key]["psnr"])]
    return all(cards["psnr"] >= start for start in starts) and all(
        cards["psnr"] >= d["psnr"] + BAR_GAIN_OVER_DECIMATED_DB and cards["flip"] < d["flip"] for d in decimations)


def _with_bar(row: dict) -> dict:
    """``row`` with the gains of ``cards`` and ``meets_bar`` (module docstring)."""
    row["gain_over_start_db"] = row["psnr_cards"] - row["psnr_start"]
    row["gain_over_decimated_db"] = row["psnr_cards"] - row["psnr_decimated"]
    if not math.isnan(row["psnr_simplify"]):
        row["gain_over_simplify_db"] = row["psnr_cards"] - row["psnr_simplify"]
    scores = {"heldout": {key: {"psnr": row[f"psnr_{key}"], "flip": row[f"flip_{key}"]} for key, _ in METHODS}}
    scores.update(row.get("judge", {}))
    row["meets_bar"] = row["minutes_cards"] <= BAR_MINUTES and all(beats_bar(s) for s in scores.values())
    return row


def _methods(asset, count: int, cfg, folder: Path, validation, draw, source: Path | None, reuse: bool) -> dict:
    """``{key: Asset}`` of every method of ``METHODS`` the case has: the runs' models from
    ``folder``; the starts and plain decimation rebuilt as the ``cards`` run built them (same
    settings and seed), each start as the run writes it (``WrittenModel.start`` on the
    ``validation`` views drawn by ``draw``); stochastic simplification drawn with
    ``STOCHASTIC_SEED`` where the input's solid parts leave it a budget; Blender's Decimate of
    the input glb ``source`` where given (kept in ``folder``, taken from there where ``reuse``)."""
    import numpy as np

    from .. import io
    from ..errors import ConfigError
    from ..init.stochastic import stochastic_simplification
    from ..jobs.alpha_export import training_start
    from ..jobs.cards import cards_guess
    from ..jobs.written_model import WrittenModel

    guess = cards_guess(asset, cfg, count)
    starts = {"start": guess.start, **{"leaf_texture": start for _, start in guess.alternatives}}
    models = {"decimated": guess.baseline}
    for key, start in starts.items():
        trained = training_start(start, cfg.latent.alpha_mode, cfg.latent.mask_anneal)
        models[key] = WrittenModel(cfg.latent.alpha_mode, validation, draw).start(trained)
    try:
        models["stochastic"] = stochastic_simplification(asset, count, np.random.default_rng(STOCHASTIC_SEED))
    except ConfigError:
        pass                     # its solid parts alone exceed the budget (a tree's bark): not a method there
    for key in ("simplify", "cards"):
        if (folder / key / "model.glb").is_file():
            models[key] = io.load(folder / key / "model.glb")
    if source is not None:
        from ..blender.decimate_bake import blender_decimate_glb

        glb = folder / "blender_decimated.glb"
        if not (reuse and glb.is_file()):
            blender_decimate_glb(source, glb, count)
        models["blender_decimated"] = io.load(glb)
    return models


def _model_files(models: dict, folder: Path) -> dict[str, Path]:
    """``{key: glb}`` of every model: a run's ``model.glb`` as it wrote it, Blender's as Blender
    wrote it, the others written by ``io.save`` into ``folder/models``."""
    from .. import io

    files = {key: folder / key / "model.glb" for key in ("simplify", "cards") if key in models}
    if "blender_decimated" in models:
        files["blender_decimated"] = folder / "blender_decimated.glb"
    (folder / "models").mkdir(parents=True, exist_ok=True)
    for key in (key for key in models if key not in files):
        files[key] = folder / "models" / f"{key}.glb"
        io.save(models[key], files[key])
    return files


def _judge(reference, source: Path, models: dict, files: dict, cfg, folder: Path) -> dict:
    """Every method in ``models`` (its glb in ``files``) and the input rendered in Cycles and in
    three.js (shadows on and off each) and ours on the held-out views, the contact sheet and the
    scores written into ``folder``: ``{renderer: {key: {"psnr", "flip"}}}``. ``judge.json`` is
    written once Cycles is done, so a three.js that fails or gives no answer (a busy machine)
    costs only its own columns: they score ``NOT_RUN``, which fails the bar, and ``judge.json``
    says why (``"threejs_error"``)."""
    from ..errors import ExternalToolTimeout
    from ..jobs.judge_scores import JUDGE_RESOLUTION, THREEJS_RENDERERS, JudgedModel, heldout_views, judge_models, \
        threejs_scores
    from ..webgl.three_views import WebglError

    folder.mkdir(parents=True, exist_ok=True)
    judged = [JudgedModel(key, label, files[key], models[key]) for key, label in METHODS if key in models]
    views = heldout_views(reference, cfg.views.heldout, cfg.views.heldout_seed)
    result = judge_models(reference, source, judged, views, JUDGE_RESOLUTION, cfg.render.target_spp,
                          cfg.render.latent_msaa, contact_sheet_path=folder / "views.png", layers=cfg.render.layers)
    (folder / "judge.json").write_text(json.dumps(result, indent=2))
    try:
        result["scores"].update(threejs_scores(source, judged, views))
    except (WebglError, ExternalToolTimeout) as error:
        log.warning("bench cards: %s is not judged in three.js: %s", folder.parent.name, error)
        result["threejs_error"] = str(error)
        result["scores"].update({renderer: {} for renderer in THREEJS_RENDERERS})
    (folder / "judge.json").write_text(json.dumps(result, indent=2))
    return {renderer: {key: {"psnr": scores[key]["psnr"] if key in scores else NOT_RUN,
                             "flip": scores[key]["flip"] if key in scores else NOT_RUN} for key, _ in METHODS}
            for renderer, scores in result["scores"].items()}


def _peeled_like_cards():
    """``simplify``'s default settings with the depth-peeled layers of ``cards``."""
    from ..settings import Config
    from ..jobs.cards import CARDS_DEFAULTS

    config = Config()
    return dataclasses.replace(config, render=dataclasses.replace(config.render, layers=CARDS_DEFAULTS.render.layers))


COLUMNS = (
    ("case", "asset", "{}"), ("triangles", "triangles", "{:,}"), ("minutes cards", "minutes_cards", "{:.1f}"),
    ("s/step", "step_s_cards", "{:.2f}"),
    ("iters", "iterations", "{:,}"),
    *((f"PSNR {key}", f"psnr_{key}", "{:.2f}") for key, _ in METHODS),
    ("cards-start dB", "gain_over_start_db", "{:+.2f}"), ("cards-dec dB", "gain_over_decimated_db", "{:+.2f}"),
    *((f"FLIP {key}", f"flip_{key}", "{:.4f}") for key, _ in METHODS),
    *((f"IoU {key}", f"iou_{key}", "{:.3f}") for key, _ in METHODS),
    *((f"KB {key}", f"kb_{key}", "{:,.0f}") for key, _ in METHODS),
)


def format_table(result: dict) -> str:
    """The runs as an aligned text table, with the bar underneath."""
    bar = result["bar"]
    return runs_table(result, COLUMNS, f"bar: each run <= {bar['minutes']:g} min; cards >= its start and >= every plain "
                      f"decimation + {bar['gain_over_decimated_db']:g} dB with lower FLIP, in every renderer scored",
                      judge_table)


def judge_table(rows: list[dict]) -> list[str]:
    """Lines of the judge's table: per case, one row per renderer (Cycles and three.js with and
    without shadows, ours) with PSNR and FLIP of each method and the gains of ``cards``."""
    return judged_table(rows, "case", tuple((key, key) for key, _ in METHODS), "cards",
                        (("cards-start dB", "start"), ("cards-dec dB", "decimated"),
                         ("cards-Blender dB", "blender_decimated")),
                        "judge: Blender Cycles (32 samples, direct light), three.js (4 x MSAA) and our renderer on the "
                        "held-out views; PSNR over the pixels either picture covers, FLIP over the whole picture")
