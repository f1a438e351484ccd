"""``simplify --init-mesh`` repairs a damaged LOD (``lookalike.bench.repair.damaged``), on a
small generated case."""

from __future__ import annotations

import numpy as np
import torch

from lookalike import io
from lookalike.asset import Asset
from lookalike.bench.repair import damaged
from lookalike.cli import main
from lookalike.settings import config_from_dict
from lookalike.init import decimate
from lookalike.init.conform import boundary_loops
from lookalike.init.initial_guess import UV_OVERLAP_LIMIT, uv_overlap
from lookalike.jobs.simplify import simplify
from test_fit_simplify import TINY, bumpy_sphere


def test_the_damage_shrinks_detaches_and_scrambles():
    mesh = decimate(bumpy_sphere().mesh, 300)
    broken = damaged(mesh, np.random.default_rng(0))
    assert torch.equal(broken.t_pos_idx[:0], mesh.t_pos_idx[:0]) and broken.num_triangles == 300
    assert mesh.num_vertices < broken.num_vertices < mesh.num_vertices + 3 * 15  # 5 % of the triangles
    assert len(boundary_loops(broken.t_pos_idx.numpy())) == 2                     # one piece, one hole
    untouched = broken.t_pos_idx.max(dim=1).values < mesh.num_vertices
    radius_before = mesh.v_pos.norm(dim=-1).mean()
    radius_after = broken.v_pos[broken.t_pos_idx[untouched].unique()].norm(dim=-1).mean()
    assert 0.95 < float(radius_after / radius_before) < 0.99          # shrunk by about 3 %
    assert uv_overlap(broken) > 5 * UV_OVERLAP_LIMIT


def test_init_mesh_repairs_a_damaged_decimation(tmp_path):
    asset = bumpy_sphere()
    cfg = config_from_dict(TINY)
    default = simplify(asset, tmp_path / "default", triangles=300, iterations=150, config=cfg, progress=False)
    lod = tmp_path / "lod.glb"
    io.save(Asset(mesh=damaged(decimate(asset.mesh, 300), np.random.default_rng(0)), materials=asset.materials), lod)
    source = tmp_path / "ball.glb"
    io.save(asset, source)
    assert main(["simplify", str(source), "-o", str(tmp_path / "repaired"), "--init-mesh", str(lod),
                 "--iterations", "150", "--config", str(tmp_path / "default" / "config.toml"), "--quiet"]) == 0
    repaired = __import__("json").loads((tmp_path / "repaired" / "metrics.json").read_text())
    given, ours = repaired["heldout"]["init_mesh"], repaired["heldout"]["ours"]
    assert repaired["methods"] == ["init_mesh", "baked", "ours"]
    assert ours["psnr"] > given["psnr"] + 3
    assert ours["psnr"] > default.metrics["heldout"]["ours"]["psnr"] - 1.0   # bench repair: 0.5 in full-length runs
    assert io.load(tmp_path / "repaired" / "model.glb").mesh.num_triangles == 300
