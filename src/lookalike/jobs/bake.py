"""``bake_asset``: the classic pipeline end to end (load -> decimate -> unwrap -> bake -> write
``OUTDIR/model.glb``), the baseline that ``simplify`` is compared with: ``simplify``'s own
initial guess (``lookalike.init.initial_guess``) written as a model.

The decimation target follows the same rule as ``simplify`` (``lookalike.init.initial_guess.
target_triangle_count``), so both start from the same low-poly mesh. Every step is
deterministic. The output folder follows ``simplify``'s rules (``lookalike.jobs.outdir``): an
existing non-empty folder is refused without ``force``; files are written atomically.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import io
from ..asset.asset import Asset
from ..asset.material import Material
from ..errors import ConfigError
from ..settings import Config
from ..init.decimate import decimate
from ..init.initial_guess import Ranges, initial_guess, target_triangle_count
from ..io.atomic import write_text_atomic
from ..limits import MAX_BAKE_TEXTURE_SIZE
from .outdir import check_outdir, left_as_found, prepare_outdir
from .outputs import METRICS_NAME, MODEL_NAME, staged_outputs, write_model
from .input_asset import prepare_input

OUTDIR_SUFFIX = "-baked"


@dataclass
class BakeJobResult:
    """What ``bake_asset`` wrote.

    Attributes:
        outdir: the output folder; model: ``OUTDIR/model.glb``.
        asset: the baked low-poly asset (one material).
        metrics: what ``OUTDIR/metrics.json`` holds (triangle counts, texture size, cage, hit
            fraction, seconds per step).
    """

    outdir: Path
    model: Path
    asset: Asset
    metrics: dict

    def summary(self) -> str:
        m = self.metrics
        return (f"baked {m['triangles']['output']:,} triangles (input {m['triangles']['input']:,}), "
                f"{m['texture_size']}^2 textures, {100 * m['hit_fraction']:.1f}% of texels hit within the cage, "
                f"in {m['seconds']['total']:.1f} s -> {self.model}")


def bake_asset(input: str | Path | Asset, outdir: str | Path | None = None, *, triangles: int | None = None,
               ratio: float | None = None, texture_size: int | None = None, cage: float | None = None,
               force: bool = False, material_override: Material | None = None) -> BakeJobResult:
    """Decimate, unwrap and bake ``input`` into ``outdir/model.glb``.

    Args:
        input: any file ``lookalike.io.load`` reads, or an ``Asset``.
        outdir: output folder (default ``<input name>-baked`` in the current folder).
        triangles, ratio: target triangle count, or fraction of the input's (default: the
            settings' ``latent.ratio``), as for ``simplify``.
        texture_size: side of the square baked textures (default: the settings'
            ``latent.texture_size``).
        cage: ray reach on each side of the low-poly surface (default: see ``lookalike.init.projection_bake``).
        force: overwrite an existing non-empty ``outdir``.
        material_override: bake the input as if every triangle had this material (e.g. a colour
            for untextured scans).
    Raises:
        ConfigError, AssetError: with a message naming the problem.
    """
    defaults = Config().latent
    texture_size = defaults.texture_size if texture_size is None else texture_size
    if not 4 <= texture_size <= MAX_BAKE_TEXTURE_SIZE:
        raise ConfigError(f"the texture size (--texture-size) must lie in [4, {MAX_BAKE_TEXTURE_SIZE}], not {texture_size}")
    started = time.monotonic()
    name = input.name if isinstance(input, Asset) else Path(input).stem
    outdir = Path(outdir) if outdir is not None else Path.cwd() / f"{name}{OUTDIR_SUFFIX}"
    check_outdir(outdir, force=force, resume=False)
    seconds = {}
    clock = time.monotonic()
    asset, _ = prepare_input(input if isinstance(input, Asset) else io.load(input), material_override)
    count = target_triangle_count(triangles, defaults.ratio if ratio is None else ratio,
                                  asset.mesh.num_triangles)
    seconds["load"] = time.monotonic() - clock
    clock = time.monotonic()
    decimated = decimate(asset.mesh, count)
    seconds["decimate"] = time.monotonic() - clock
    clock = time.monotonic()
    guess = initial_guess(asset, decimated, "bake", texture_size, Ranges(), np.random.default_rng(0), cage=cage)
    seconds["unwrap and bake"] = time.monotonic() - clock
    baked, result = guess.baked, guess.bake

    metrics = {"input": str(asset.source or name),
               "triangles": {"input": asset.mesh.num_triangles, "output": baked.mesh.num_triangles},
               "texture_size": texture_size, "cage": result.cage, "texels": result.texels,
               "hit_fraction": result.hit_fraction, "mean_offset": result.mean_offset, "seconds": seconds}
    with left_as_found(outdir):
        outdir = prepare_outdir(outdir, force=force, resume=False)
        write_bake(outdir, baked, metrics, started)
    model = outdir / MODEL_NAME
    return BakeJobResult(outdir=outdir, model=model, asset=baked, metrics=metrics)


def write_bake(outdir: Path, baked: Asset, metrics: dict, started: float) -> None:
    """``model.glb`` and ``metrics.json`` (its export and total seconds added) into ``outdir``,
    all or none (``jobs.outputs.staged_outputs``)."""
    clock = time.monotonic()
    with staged_outputs(outdir) as staging:
        write_model(baked, staging, obj=False)
        metrics["seconds"]["export"] = time.monotonic() - clock
        metrics["seconds"]["total"] = time.monotonic() - started
        write_text_atomic(staging / METRICS_NAME, json.dumps(metrics, indent=2))
