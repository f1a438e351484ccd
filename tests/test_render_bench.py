"""The render benchmark's scene and table (the timed run itself is `lookalike bench render`)."""

from __future__ import annotations

import torch

import lookalike.render as dr
from lookalike.bench import render as bench


def test_benchmark_scene_renders_and_table_lists_targets():
    v_pos, v_nrm, v_uv, tri = bench.sphere_mesh(8, 16)
    assert tri.shape == (256, 3) and tri.dtype == torch.int32
    assert v_pos.shape == v_nrm.shape == (9 * 17, 3) and v_uv.shape == (9 * 17, 2)
    pos = bench.to_clip(v_pos, bench.orbit_mvp(2))
    rast, _ = dr.rasterize(None, pos, tri, (32, 32))
    coverage = (rast[..., 3] > 0).float().mean()
    assert 0.1 < coverage < 0.9  # the sphere is in view, not filling it
    table = bench.format_table({"visibility_100k_ms": 12.5, "cpu_per_wall": 1.8, "threads": 2})
    assert "<= 70" in table and ">= 1.8" in table and "threads" in table


def test_table_holds_a_gpu_run_to_the_gpu_frame_target():
    table = bench.format_table({"device": "cuda:0 (NVIDIA H200)", "frame_total_ms": 4.0, "visibility_100k_ms": 3.0})
    assert "<= 5" in table and "<= 70" not in table and "<= 120" not in table


def test_cpu_timings_run_on_the_device_they_are_given():
    cpu = torch.device("cpu")
    assert bench.time_visibility(2_000, 1, cpu) > 0
    frame = bench.time_frame(1, cpu)
    assert frame["frame_total_ms"] >= frame["frame_forward_ms"] > 0
