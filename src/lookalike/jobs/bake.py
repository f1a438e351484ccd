"""``bake_asset``: the classic pipeline end to end (load -> decimate -> unwrap -> bake -> write
``OUTDIR/model.glb``), the baseline that ``simplify`` is compared with.

The decimation target follows the same rule as ``simplify`` (``lookalike.init.initial_guess.
target_triangle_count``), so both start from the same low-poly mesh. Every step is
deterministic. The output folder follows ``simplify``'s rules (``lookalike.jobs.outdir``): an
existing non-empty folder is refused without ``force``; files are written atomically.
"""

from __future__ import annotations

import dataclasses
import json
import time
from dataclasses import dataclass
from pathlib import Path

import torch

from .. import io
from ..asset.asset import Asset
from ..asset.material import Material
from ..fit.config import LatentConfig
from ..init.bake import bake
from ..init.decimate import decimate
from ..init.initial_guess import target_triangle_count
from ..init.unwrap import unwrap
from ..io.atomic import write_text_atomic
from .outdir import check_outdir, prepare_outdir
from .outputs import write_model
from .simplify import prepare_input

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
               ratio: float | None = None, texture_size: int = 1024, cage: float | None = None,
               force: bool = False, material_override: Material | None = None) -> BakeJobResult:
    """Decimate, unwrap and bake ``input`` into ``outdir/model.glb``.

    Args:
        input: any file ``lookalike.io.load`` reads, or an ``Asset``.
        outdir: output folder (default ``<input name>-baked`` in the current folder).
        triangles, ratio: target triangle count, or fraction of the input's (default
            ``LatentConfig.DEFAULT_RATIO``), as for ``simplify``.
        texture_size: side of the square baked textures.
        cage: ray reach on each side of the low-poly surface (default: see ``lookalike.init.bake``).
        force: overwrite an existing non-empty ``outdir``.
        material_override: bake the input as if every triangle had this material (e.g. a colour
            for untextured scans).
    Raises:
        ConfigError, AssetError: with a message naming the problem.
    """
    started = time.monotonic()
    name = input.name if isinstance(input, Asset) else Path(input).stem
    outdir = Path(outdir) if outdir is not None else Path.cwd() / f"{name}{OUTDIR_SUFFIX}"
    check_outdir(outdir, force=force, resume=False)
    seconds = {}
    clock = time.monotonic()
    asset, _ = prepare_input(input if isinstance(input, Asset) else io.load(input), material_override)
    count = target_triangle_count(triangles, LatentConfig.DEFAULT_RATIO if ratio is None else ratio,
                                  asset.mesh.num_triangles)
    seconds["load"] = time.monotonic() - clock
    clock = time.monotonic()
    low = unwrap(decimate(asset.mesh, count), texture_size=texture_size)
    low = dataclasses.replace(low, t_mat_idx=torch.zeros_like(low.t_mat_idx), v_color=None,
                              v_joints=None, v_weights=None)
    seconds["decimate and unwrap"] = time.monotonic() - clock
    clock = time.monotonic()
    result = bake(asset, low, texture_size=texture_size, cage=cage)
    seconds["bake"] = time.monotonic() - clock
    baked = Asset(mesh=low, materials=[result.material], source=asset.source)

    outdir = prepare_outdir(outdir, force=force, resume=False)
    clock = time.monotonic()
    model = write_model(baked, outdir, obj=False)
    seconds["export"] = time.monotonic() - clock
    seconds["total"] = time.monotonic() - started
    metrics = {
        "input": str(asset.source or name),
        "triangles": {"input": asset.mesh.num_triangles, "output": low.num_triangles},
        "texture_size": texture_size,
        "cage": result.cage,
        "texels": result.texels,
        "hit_fraction": result.hit_fraction,
        "mean_offset": result.mean_offset,
        "seconds": seconds,
    }
    write_text_atomic(outdir / "metrics.json", json.dumps(metrics, indent=2))
    return BakeJobResult(outdir=outdir, model=model, asset=baked, metrics=metrics)
