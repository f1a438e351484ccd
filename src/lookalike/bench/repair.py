"""``lookalike bench repair``: the paper's automatic clean-up of an existing LOD
(``simplify --init-mesh``), on a decimation deliberately damaged the way bad LODs are.

For each asset (default: nefertiti and spot), our decimation to the benchmark's triangle count
is damaged (``damaged``): shrunk by ``SHRINK`` of the bounding radius along its normals, one
part (the ``PART`` of the triangles nearest a random vertex) detached and moved by ``OFFSET``
of the radius, and its UVs scrambled. ``simplify --init-mesh`` then starts from it, with the
default settings and budget, and is compared with the default run from our own decimation.

Bar: the repaired run's held-out PSNR within ``BAR_DB`` of the default run's. With
``--out`` pointing at the folder of a ``bench quality`` run, its finished default runs are
reused.
"""

from __future__ import annotations

import dataclasses
import json
import tempfile
from pathlib import Path

import numpy as np
import torch

from .. import io
from ..asset import Asset, Mesh
from ..asset.normals import vertex_normals
from ..init import decimate, unwrap
from ._table import aligned_table
from .quality import (SHARED_ASSETS, TIME_BUDGET_S, BenchAsset, check_assets_dir, output_root, scan_material,
                      select_assets, simplify_case)

HELP = "repair a deliberately damaged LOD with simplify --init-mesh and compare it with the default run"

SHRINK = 0.03
PART = 0.05
OFFSET = 0.05
BAR_DB = 0.5
REPAIR_ASSETS = ("nefertiti", "spot")


def scrambled_uvs(mesh: Mesh, rng: np.random.Generator) -> Mesh:
    """``mesh`` with the UV corners of UV set 0 shuffled among its triangles (overlapping,
    flipped charts; a fresh atlas first where it has no UVs)."""
    mesh = mesh if mesh.uv else unwrap(mesh, texture_size=1024)
    v_tex, t_tex_idx = mesh.uv[0]
    order = torch.from_numpy(rng.permutation(t_tex_idx.numel()))
    return dataclasses.replace(mesh, uv=[(v_tex, t_tex_idx.reshape(-1)[order].reshape(-1, 3))])


def damaged(mesh: Mesh, rng: np.random.Generator, shrink: float = SHRINK, part: float = PART,
            offset: float = OFFSET) -> Mesh:
    """``mesh`` [V, 3] / [T, 3] damaged three ways: every vertex moved by ``-shrink * r`` along
    its smooth normal (r the bounding radius); the ``part`` of the triangles whose centroids lie
    nearest a random vertex cut off as one piece (its vertices copied, so it keeps its own
    connectivity but shares none with the rest) and moved by ``offset * r`` along its mean
    normal; the UVs scrambled (``scrambled_uvs``)."""
    _, radius = mesh.bounding_sphere()
    normals = vertex_normals(mesh.v_pos.double(), mesh.t_pos_idx).float()
    v_pos = mesh.v_pos - shrink * radius * normals
    centroids = v_pos[mesh.t_pos_idx].mean(dim=1)
    seed = v_pos[int(rng.integers(mesh.num_vertices))]
    count = max(1, int(part * mesh.num_triangles))
    piece = torch.argsort((centroids - seed).norm(dim=-1))[:count]
    corners, local = torch.unique(mesh.t_pos_idx[piece], return_inverse=True)
    direction = torch.nn.functional.normalize(normals[corners].mean(dim=0), dim=0)
    t_pos_idx = mesh.t_pos_idx.clone()
    t_pos_idx[piece] = mesh.num_vertices + local
    v_pos = torch.cat([v_pos, v_pos[corners] + offset * radius * direction])
    broken = Mesh(v_pos=v_pos, t_pos_idx=t_pos_idx, uv=mesh.uv, t_mat_idx=mesh.t_mat_idx)
    return scrambled_uvs(broken, rng)


def damaged_lod(case: BenchAsset, assets_dir: Path, path: Path, seed: int = 0) -> Path:
    """Write ``damaged`` of our decimation of ``case`` to ``path`` (glTF, with the input's
    materials, or the scan material for untextured scans); returns ``path``."""
    asset = io.load(assets_dir / case.path)
    materials = [scan_material()] if case.scan else asset.materials
    mesh = damaged(decimate(asset.mesh, case.triangles), np.random.default_rng(seed))
    if case.scan:
        mesh = dataclasses.replace(mesh, t_mat_idx=torch.zeros_like(mesh.t_mat_idx))
    io.save(Asset(mesh=mesh, materials=materials), path)
    return path


def run(repeats: int | None = None, out: str | Path | None = None, time_budget: float = TIME_BUDGET_S,
        assets: tuple[BenchAsset, ...] = select_assets(list(REPAIR_ASSETS)),
        assets_dir: str | Path = SHARED_ASSETS) -> dict:
    """Per asset: the default ``simplify`` run and the ``--init-mesh`` run from the damaged
    decimation, each with ``time_budget``; ``repeats`` is ignored.

    Returns:
        ``{"time_budget_s", "bar_db", "runs": [row, ...], "all_meet_bar", "outputs"}``; a row
        holds the asset, the damaged mesh's held-out PSNR and FLIP, the default and repaired
        runs' PSNR and FLIP, their difference, and whether it meets the bar.
    """
    assets_dir = check_assets_dir(assets_dir)
    rows = []
    with tempfile.TemporaryDirectory(prefix="lookalike-bench-") as scratch:
        root = output_root(out, scratch)
        root.mkdir(parents=True, exist_ok=True)
        for case in assets:
            lod = damaged_lod(case, assets_dir, root / f"{case.name}-damaged.glb")
            default = _default_run(case, assets_dir, root / case.name, time_budget)
            repaired = simplify_case(case, assets_dir, root / f"{case.name}-repaired", time_budget, init_mesh=lod).metrics
            rows.append(_row(case, default, repaired))
        outputs = None if root == Path(scratch) else str(root.resolve())
    return {"time_budget_s": time_budget, "bar_db": BAR_DB, "runs": rows,
            "all_meet_bar": all(r["meets_bar"] for r in rows), "outputs": outputs}


def _default_run(case: BenchAsset, assets_dir: Path, outdir: Path, time_budget: float) -> dict:
    """The metrics of the default run of ``case`` in ``outdir``: read from a finished run of
    the same budget already there (``bench quality --out`` with the same folder), else run."""
    metrics = outdir / "metrics.json"
    if metrics.is_file():
        finished = json.loads(metrics.read_text(encoding="utf-8"))
        if not finished["interrupted"] and finished["input"] == str(assets_dir / case.path):
            return finished
    return simplify_case(case, assets_dir, outdir, time_budget).metrics


def _row(case: BenchAsset, default: dict, repaired: dict) -> dict:
    given, ours = repaired["heldout"]["init_mesh"], repaired["heldout"]["ours"]
    difference = ours["psnr"] - default["heldout"]["ours"]["psnr"]
    return {"asset": case.name, "psnr_damaged": given["psnr"], "flip_damaged": given["flip"],
            "psnr_default": default["heldout"]["ours"]["psnr"], "flip_default": default["heldout"]["ours"]["flip"],
            "psnr_repaired": ours["psnr"], "flip_repaired": ours["flip"], "iterations_default": default["iterations"],
            "iterations_repaired": repaired["iterations"], "difference_db": difference,
            "meets_bar": difference >= -BAR_DB}


def format_table(result: dict) -> str:
    header = ["asset", "damaged PSNR", "default PSNR", "repaired PSNR", "repaired - default", "FLIP damaged",
              "FLIP default", "FLIP repaired", "bar"]
    cells = [[r["asset"], f"{r['psnr_damaged']:.2f}", f"{r['psnr_default']:.2f}", f"{r['psnr_repaired']:.2f}",
              f"{r['difference_db']:+.2f}", f"{r['flip_damaged']:.4f}", f"{r['flip_default']:.4f}",
              f"{r['flip_repaired']:.4f}", "ok" if r["meets_bar"] else "MISSED"] for r in result["runs"]]
    lines = aligned_table(header, cells)
    lines.append(f"bar: the repaired run within {result['bar_db']:g} dB of the default run's held-out PSNR: "
                 f"{'met' if result['all_meet_bar'] else 'NOT met'} (time budget {result['time_budget_s']:g} s per run)")
    if result.get("outputs"):
        lines.append(f"outputs: {result['outputs']}")
    return "\n".join(lines)
