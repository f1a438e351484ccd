"""The generated default asset of ``lookalike demo``."""

from __future__ import annotations

import torch

from lookalike.cli import build_parser
from lookalike.jobs.demo import demo_asset, knot_mesh


def test_the_demo_asset_is_a_closed_outward_facing_textured_knot():
    asset = demo_asset()
    mesh = asset.mesh
    assert mesh.num_triangles == 100_000
    corners = mesh.v_pos.double()[mesh.t_pos_idx]
    volume = (corners[:, 0] * torch.linalg.cross(corners[:, 1], corners[:, 2], dim=-1)).sum() / 6
    assert volume > 0  # counter-clockwise faces point outwards
    edges = torch.sort(torch.cat([mesh.t_pos_idx[:, [0, 1]], mesh.t_pos_idx[:, [1, 2]], mesh.t_pos_idx[:, [2, 0]]]), dim=1).values
    _, uses = torch.unique(edges, dim=0, return_counts=True)
    assert (uses == 2).all()  # welded and closed: every edge joins exactly two triangles
    v_tex, t_tex_idx = mesh.uv[0]
    assert t_tex_idx.shape == mesh.t_pos_idx.shape and v_tex.min() >= 0 and v_tex.max() <= 1
    kd, ks = asset.materials[0].kd.data, asset.materials[0].ks.data
    assert kd.shape[-1] == 4 and ks.shape[-1] == 3
    assert kd[..., :3].std() > 0.05 and ks[..., 1].std() > 0.05 and ks[..., 2].max() == 1.0


def test_the_knot_resolution_is_adjustable():
    assert knot_mesh(segments=40, sides=8).num_triangles == 640


def test_the_demo_command_parses():
    args = build_parser(["demo"]).parse_args(["demo", "-o", "somewhere", "--time-budget", "3m"])
    assert args.output == "somewhere" and args.time_budget == "3m"
