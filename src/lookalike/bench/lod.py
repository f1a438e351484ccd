"""``lookalike bench lod``: the chain 8000@512, 2000@128, 500@32 of nefertiti and flight-helmet
(``lookalike lod`` with default settings, the chain's 15-minute budget), each level scored at
its own size beside the classic chain.

The classic chain: at each level's triangle count and texture size, quadric decimation, a UV
atlas and the projection bake (``jobs.bake``), drawn with box-filtered mipmaps, as every
shipping tool makes a level. Each level of both chains is drawn as an engine draws it (one
sample per pixel, trilinear mipmapped lookups) on the run's held-out views at the level's
resolution, and scored against the reference at ``REFERENCE_SPP`` x ``REFERENCE_SPP`` samples
per pixel (PSNR, FLIP); so is the input itself, drawn the same way, which shows how far one
sample per pixel lets any model come. Flicker: over a slow orbit (``ORBIT_FRAMES`` frames turning
``ORBIT_DEGREES``, ``shading.view_sampling.orbit_views``), the mean change between consecutive
frames (``report.metrics.temporal_change``) relative to the reference's own (``ORBIT_REFERENCE_SPP``).
Where gltfpack and ``basisu`` are found, each fitted level is also written compressed
(``jobs.compressed_model``) after the chain, outside its budget, and scored the same way.

Bar: the whole chain within 15 minutes per asset; ours at least the classic level + 1.5 dB at
the two smaller levels and + 1 dB at the largest, with a lower FLIP; ours' flicker at most 1.3
times the reference's at every level and below the classic chain's.
"""

from __future__ import annotations

import json
import logging
import tempfile
from pathlib import Path

from ..errors import ConfigError
from ._table import runs_table
from .quality import ASSETS as QUALITY_ASSETS
from .quality import SHARED_ASSETS, BenchAsset, check_assets_dir, check_judge, io_load, output_root, scan_material, \
    select_assets

log = logging.getLogger(__name__)

HELP = "fit a chain of prefiltered LODs to nefertiti and flight-helmet; compare each level with the classic chain"

ASSETS = select_assets(["nefertiti", "flight-helmet"], QUALITY_ASSETS)
LEVELS = "8000@512,2000@128,500@32"
REFERENCE_SPP = 16
ORBIT_REFERENCE_SPP = 8
"""The orbit's reference is supersampled 8 x 8 per pixel, which is converged (the LOD tests
compare it with 16 x 16): at 16 x 16 the 512-pixel level's 60 frames would take 12 minutes."""
ORBIT_FRAMES = 60
ORBIT_DEGREES = 30.0
"""The orbit turns half a degree per frame: slow enough that consecutive frames differ by what
aliasing adds more than by what the motion shows."""

BAR_CHAIN_MINUTES = 15.0
BAR_GAIN_DB = 1.5
BAR_GAIN_LARGEST_DB = 1.0
BAR_FLICKER_RATIO = 1.3


def run(repeats: int | None = None, out: str | Path | None = None, assets: tuple[BenchAsset, ...] = ASSETS,
        assets_dir: str | Path | None = None, levels: str = LEVELS, time_budget: float | None = None,
        reuse: bool = False, judge: str | None = None) -> dict:
    """Fit the chain ``levels`` of every asset, bake the classic chain, score both.

    Args:
        repeats: ignored (each asset runs once).
        out: keep the outputs in ``out/<asset>/{chain,classic}`` (default:
            ``$LOOKALIKE_BENCH_OUT`` or a temporary folder).
        assets, assets_dir: which cases, and where their files are (default ``../shared/assets``).
        levels: the chain, as ``lookalike lod --levels`` takes it.
        time_budget: seconds for the whole chain (default: ``lod``'s, 15 minutes).
        reuse: keep the levels already fitted in ``out/<asset>/chain`` (``lod``'s resume) and
            score them again.
        judge: ``"three"``: also draw each level of both chains, as written, in three.js
            (``lookalike.webgl``: one sample per pixel, its own mip levels) on the same views.

    Returns:
        ``{"levels", "bar", "runs": [row per asset and level], "all_meet_bar", "outputs"}``; a row
        holds the asset, level, triangles, pixels, the chain's minutes, file bytes, PSNR, FLIP
        and flicker (relative to the reference's) of the classic level and ours (and, judged,
        their PSNR and FLIP in three.js), and whether it meets the bar.
    """
    from ..jobs.lod import CHAIN_BUDGET, parse_levels

    if judge is not None:
        check_judge(judge, ("three",))
    assets_dir = check_assets_dir(SHARED_ASSETS if assets_dir is None else assets_dir)
    chain = parse_levels(levels)
    budget = CHAIN_BUDGET if time_budget is None else time_budget
    with tempfile.TemporaryDirectory(prefix="lookalike-bench-lod-") as scratch:
        root = output_root(out, scratch)
        rows = []
        for case in assets:
            rows += asset_rows(case, assets_dir, root / case.name, chain, budget, reuse, judge is not None)
        return {"levels": levels, "time_budget_s": budget,
                "bar": {"chain_minutes": BAR_CHAIN_MINUTES, "gain_db": BAR_GAIN_DB,
                        "gain_largest_db": BAR_GAIN_LARGEST_DB, "flicker_ratio": BAR_FLICKER_RATIO},
                "runs": rows, "all_meet_bar": all(r["meets_bar"] for r in rows),
                "outputs": None if root == Path(scratch) else str(root.resolve())}


def asset_rows(case: BenchAsset, assets_dir: Path, outdir: Path, chain: list, budget: float,
               reuse: bool = False, judged: bool = False) -> list[dict]:
    """Fit (``reuse``: resume) and score the chain of ``case`` in ``outdir``: a row per level
    (see ``run``; ``judged``: in three.js too); the chain's minutes are the sum of its levels'
    run times."""
    from ..fit.reference import MeshReference
    from ..jobs.bake import bake_asset
    from ..jobs.compressed_model import COMPRESSED_NAME, check_compression_tools, write_compressed
    from ..jobs.input_asset import prepare_input
    from ..jobs.lod import LEVEL, lod, screen_size_settings

    material = scan_material() if case.scan else None
    asset, _ = prepare_input(io_load(assets_dir / case.path), material)
    try:
        check_compression_tools()
        compress = True
    except ConfigError as e:
        log.warning("bench lod: the compressed chain is not scored: %s", e)
        compress = False
    levels = lod(asset, outdir / "chain", chain, time_budget=budget, force=True, resume=reuse, progress=False)
    minutes = sum(level["seconds"] for level in levels) / 60
    reference = MeshReference(asset)
    rows = []
    for row, level in zip(levels, chain):
        settings = screen_size_settings(level.pixels)
        classic = bake_asset(asset, outdir / "classic" / f"lod{row['level']}", triangles=level.triangles,
                             texture_size=settings["texture_size"], force=True)
        paths = {"classic": classic.model, "ours": outdir / "chain" / row["folder"] / "model.glb"}
        if compress:  # after the chain, outside its budget: the bar is the chain's, compression's cost is shown
            paths["compressed"] = write_compressed(paths["ours"], outdir / "chain" / row["folder"] / COMPRESSED_NAME)
        models = {"input": asset, "classic": classic.asset, **{name: io_load(path) for name, path in paths.items()
                                                              if name != "classic"}}
        count = settings.get("heldout", LEVEL.defaults.views.heldout)
        scores = level_scores(reference, models, settings["resolution"], count, paths if judged else None)
        rows.append(level_row(case.name, row, minutes, scores, {name: path.stat().st_size for name, path in paths.items()},
                              largest=row["level"] == 0))
    (outdir / "bench.json").write_text(json.dumps(rows, indent=2))
    return rows


def level_scores(reference, models: dict, resolution: int, count: int, files: dict | None = None) -> dict:
    """``{name: {"psnr", "flip", "flicker"}}`` of each model of ``models`` at ``resolution``
    (and ``"psnr_three"``, ``"flip_three"`` of those whose glb ``files`` names, drawn by three.js):
    drawn at one sample per pixel with trilinear mipmaps at the GPU's levels on ``count`` held-out views (the
    runs' sampler and seed; a level's run holds out as many) against ``reference`` at ``REFERENCE_SPP`` per axis, and its
    flicker over the orbit relative to the reference's at ``ORBIT_REFERENCE_SPP`` (``"flicker"``
    of ``"reference"`` is its own mean change)."""
    from functools import partial

    import numpy as np

    from ..fit.reference import render_in_chunks
    from ..fit.textured_mesh import render_asset
    from ..fit.training_views import view_sampler
    from ..report.heldout import HeldoutViews, over_background
    from ..report.metrics import temporal_change
    from ..settings import Config
    from ..shading.texturing import ENGINE_FOOTPRINT
    from ..shading.view_sampling import orbit_views
    from ..webgl import render_threejs

    centre, radius = reference.bounding_sphere()
    views = Config().views
    heldout = HeldoutViews(reference, view_sampler(centre, radius), count, views.heldout_seed, resolution,
                           REFERENCE_SPP)
    draw = partial(render_asset, resolution=resolution, msaa=1, footprint=ENGINE_FOOTPRINT)
    camera, light = orbit_views(centre, radius, ORBIT_FRAMES, ORBIT_DEGREES)
    own = temporal_change(over_background(render_in_chunks(reference, camera, light, resolution, ORBIT_REFERENCE_SPP)))
    scores = {"reference": {"flicker": own}}
    for name, model in models.items():
        result = heldout.score(name, name, model, draw, None)
        frames = over_background(draw(model, camera, light))
        scores[name] = {"psnr": float(np.mean(result.psnr_views)), "flip": float(np.mean(result.flip_views)),
                        "flicker": temporal_change(frames) / own}
    for name, path in (files or {}).items():
        result = heldout.score(name, name, models[name], lambda model, camera, light, pose, path=path: render_threejs(
            path, camera, resolution, light=light, samples=0), None)
        scores[name].update(psnr_three=float(np.mean(result.psnr_views)), flip_three=float(np.mean(result.flip_views)))
    return scores


def level_row(asset: str, level: dict, minutes: float, scores: dict, sizes: dict, largest: bool) -> dict:
    """One table row: the level of ``asset`` (a row of ``lods.json``), the chain's ``minutes``,
    the scores (``level_scores``) and file bytes of both chains, the gain of ours, and the bar
    (``+ BAR_GAIN_LARGEST_DB`` at the ``largest`` level, ``+ BAR_GAIN_DB`` below)."""
    classic, ours = scores["classic"], scores["ours"]
    gain = ours["psnr"] - classic["psnr"]
    meets = (minutes <= BAR_CHAIN_MINUTES and gain >= (BAR_GAIN_LARGEST_DB if largest else BAR_GAIN_DB)
             and ours["flip"] < classic["flip"] and ours["flicker"] <= BAR_FLICKER_RATIO
             and ours["flicker"] < classic["flicker"])
    return {"asset": asset, "level": level["level"], "triangles": level["triangles"], "pixels": level["pixels"],
            "texture_size": level["texture_size"], "fitted_mips": level.get("fitted_mips", False),
            "chain_minutes": minutes,
            **{f"{metric}_{name}": scores[name][metric] for name in ("input", "classic", "ours", "compressed")
               if name in scores
               for metric in ("psnr", "flip", "flicker", "psnr_three", "flip_three") if metric in scores[name]},
            **{f"bytes_{name}": size for name, size in sizes.items()},
            "gain_db": gain, "meets_bar": meets}


COLUMNS = (("asset", "asset", "{}"), ("level", "level", "{}"), ("triangles", "triangles", "{:,}"),
           ("px", "pixels", "{}"), ("texels", "texture_size", "{}"), ("chain min", "chain_minutes", "{:.1f}"),
           ("PSNR input", "psnr_input", "{:.2f}"), ("PSNR classic", "psnr_classic", "{:.2f}"),
           ("PSNR ours", "psnr_ours", "{:.2f}"),
           ("gain dB", "gain_db", "{:+.2f}"), ("FLIP classic", "flip_classic", "{:.4f}"),
           ("FLIP ours", "flip_ours", "{:.4f}"), ("flicker input", "flicker_input", "{:.2f}x"),
           ("flicker classic", "flicker_classic", "{:.2f}x"),
           ("flicker ours", "flicker_ours", "{:.2f}x"), ("three.js classic", "psnr_three_classic", "{:.2f}"),
           ("three.js ours", "psnr_three_ours", "{:.2f}"), ("PSNR compressed", "psnr_compressed", "{:.2f}"),
           ("three.js compressed", "psnr_three_compressed", "{:.2f}"), ("KB classic", "bytes_classic", "{:,.0f}"),
           ("KB ours", "bytes_ours", "{:,.0f}"), ("KB compressed", "bytes_compressed", "{:,.0f}"))


def format_table(result: dict) -> str:
    """The levels as an aligned table (file sizes in KB), with the bar underneath."""
    shown = dict(result, runs=[{**r, **{key: r[key] / 1024 for key in r if key.startswith("bytes_")}}
                               for r in result["runs"]])
    bar = (f"bar: chain <= {BAR_CHAIN_MINUTES:g} min; ours >= classic + {BAR_GAIN_DB:g} dB at the smaller levels, "
           f"+ {BAR_GAIN_LARGEST_DB:g} dB at the largest, lower FLIP; flicker (vs the reference's, "
           f"{REFERENCE_SPP}x{REFERENCE_SPP} spp) <= {BAR_FLICKER_RATIO:g}x and below classic")
    columns = tuple(c for c in COLUMNS if all(c[1] in r for r in shown["runs"]))  # three.js where judged
    return runs_table(shown, columns, bar, lambda rows: [])
