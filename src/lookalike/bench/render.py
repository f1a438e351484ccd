"""``lookalike bench render``: speed of the differentiable rasterizer.

Figures (medians over ``repeats``):

- ``visibility_100k_ms`` / ``visibility_500k_ms``: the compiled visibility query alone, 4
  views at 512x512 of a perturbed sphere with ~100k / ~500k triangles.
- ``frame_forward_ms`` / ``frame_backward_ms`` / ``frame_total_ms``: one optimisation
  frame, 4 views at 512x512 of a ~5k-triangle sphere: rasterize, interpolate uv (with
  derivatives) and normal + position (one call), trilinear lookup of a 1024^2 RGBA
  texture, Lambert shading, antialias, L1 loss; backward to vertex positions and texels.
- ``frame_cpu_ms``: mean process CPU time of a frame (all threads), and ``cpu_per_wall``:
  process CPU time over wall time during the frames (parallelism).
- ``compile_s``: in a fresh process with torch imported, ``import lookalike.render`` and a
  first small ``rasterize`` with an empty Numba cache (compiles the visibility kernels);
  ``startup_s``: the same with the cache filled.

Targets on the 2-core reference machine: visibility <= 70 ms (100k) and <= 150 ms (500k),
frame forward + backward <= 120 ms and CPU/wall >= 1.8, cached start-up <= 1 s.

On a GPU (``device`` ``"cuda"``, or ``"auto"`` where there is one) the sphere, the texture and
the targets live on it, the visibility figures time ``rasterize`` (the CUDA visibility kernels
take a GPU tensor, the CPU query NumPy), every time is read after ``torch.cuda.synchronize``, and
the start-up figures are left out (they time the CPU kernels' cache), and two more say where a
frame's time goes: ``launches_per_frame``, the CUDA kernels it launches, and ``launch_us``, the
wall time of launching an empty kernel with eight tensor arguments (the host's share of each
launch). Target there: the frame <= 5 ms.
"""

from __future__ import annotations

import math
import os
import statistics
import subprocess
import sys
import tempfile
import time

HELP = "speed of the differentiable rasterizer (visibility, engine frame, start-up)"

TARGETS = {
    "visibility_100k_ms": 70.0,
    "visibility_500k_ms": 150.0,
    "frame_total_ms": 120.0,
    "cpu_per_wall": 1.8,
    "startup_s": 1.0,
}
GPU_TARGETS = {"frame_total_ms": 5.0}

_STARTUP_SCRIPT = """
import time
import torch
start = time.perf_counter()
import lookalike.render as dr
pos = torch.tensor([[[-1.0, -1.0, 0.0, 1.0], [1.0, -1.0, 0.0, 1.0], [0.0, 1.0, 0.0, 1.0]]])
dr.rasterize(None, pos, torch.tensor([[0, 1, 2]], dtype=torch.int32), (8, 8))
print(time.perf_counter() - start)
"""


def sphere_mesh(rows: int, columns: int, bumpiness: float = 0.05):
    """A bumpy UV sphere: ``(v_pos [V,3], v_nrm [V,3], v_uv [V,2], tri [2 rows columns, 3]
    int32)`` (float32), with a seam column of duplicated vertices so uv runs 0..1."""
    import torch

    theta = torch.linspace(0, math.pi, rows + 1)[:, None]
    phi = torch.linspace(0, 2 * math.pi, columns + 1)[None, :]
    direction = torch.stack(
        [torch.sin(theta) * torch.cos(phi), torch.cos(theta).expand(-1, columns + 1), torch.sin(theta) * torch.sin(phi)],
        -1,
    ).reshape(-1, 3)
    radius = 1.0 + bumpiness * torch.sin(7 * theta) * torch.cos(5 * phi)
    v_pos = direction * radius.reshape(-1, 1)
    uv = torch.stack([(phi / (2 * math.pi)).expand(rows + 1, -1), (theta / math.pi).expand(-1, columns + 1)], -1)
    r, c = torch.meshgrid(torch.arange(rows), torch.arange(columns), indexing="ij")
    corner = (r * (columns + 1) + c).reshape(-1)
    quads = torch.stack([corner, corner + 1, corner + columns + 1, corner + columns + 2], -1)
    tri = torch.cat([quads[:, [0, 2, 1]], quads[:, [1, 2, 3]]]).int()
    return v_pos, direction.clone(), uv.reshape(-1, 2), tri


def orbit_mvp(n_views: int):
    """``[B, 4, 4]`` OpenGL projection x view matrices of cameras circling the origin at
    distance 3 (fov 45 degrees)."""
    import torch

    near, far, f = 0.1, 10.0, 1.0 / math.tan(math.radians(22.5))
    proj = torch.tensor(
        [[f, 0, 0, 0], [0, f, 0, 0], [0, 0, (far + near) / (near - far), 2 * far * near / (near - far)], [0, 0, -1, 0]]
    )
    mats = []
    for k in range(n_views):
        angle = 2 * math.pi * k / n_views + 0.3
        rot = torch.tensor(
            [[math.cos(angle), 0, -math.sin(angle), 0], [0, 1, 0, 0], [math.sin(angle), 0, math.cos(angle), 0], [0, 0, 0, 1]]
        )
        view = torch.eye(4)
        view[2, 3] = -3.0
        mats.append(proj @ view @ rot)
    return torch.stack(mats)


def to_clip(v_pos, mvp):
    """``[B, V, 4]`` clip-space positions of ``v_pos [V, 3]`` under ``mvp [B, 4, 4]``."""
    import torch

    homogeneous = torch.cat([v_pos, torch.ones_like(v_pos[:, :1])], 1)
    return torch.einsum("vj,bij->bvi", homogeneous, mvp)


def _median_ms(samples):
    return 1000.0 * statistics.median(samples)


def _clock(device):
    """``time.perf_counter`` read once ``device``'s queued work is done."""
    import torch

    if device.type == "cuda":
        torch.cuda.synchronize(device)
    return time.perf_counter()


def time_visibility(n_triangles: int, repeats: int, device) -> float:
    """Median ms of the visibility query, 4 views at 512x512 (on a GPU: of ``rasterize``)."""
    import numpy as np

    import lookalike.render as dr
    from lookalike.render.visibility import visible_triangles

    rows = max(2, int(round(math.sqrt(n_triangles / 4))))
    v_pos, _, _, tri = sphere_mesh(rows, 2 * rows)
    pos = to_clip(v_pos, orbit_mvp(4))
    if device.type == "cuda":
        pos, tri = pos.to(device), tri.to(device)

        def query():
            dr.rasterize(None, pos, tri, (512, 512))
    else:
        pos, tri = pos.numpy(), tri.numpy()
        tri_range = np.array([[0, tri.shape[0]]] * 4)

        def query():
            visible_triangles(pos, tri, tri_range, 512, 512)
    query()
    samples = []
    for _ in range(repeats):
        start = _clock(device)
        query()
        samples.append(_clock(device) - start)
    return _median_ms(samples)


def time_frame(repeats: int, device) -> dict:
    """Median forward / backward ms of one optimisation frame and the CPU/wall ratio."""
    import torch

    import lookalike.render as dr
    from lookalike.devices import launches

    v_pos, v_nrm, v_uv, tri = (t.to(device) for t in sphere_mesh(50, 50))
    v_pos.requires_grad_(True)
    texels = torch.rand(1, 1024, 1024, 4, device=device, requires_grad=True)
    mvp = orbit_mvp(4).to(device)
    light = torch.tensor([0.3, 0.8, 0.5], device=device)
    target = torch.rand(4, 512, 512, 3, device=device)
    topology = dr.antialias_construct_topology_hash(tri)

    def one_frame() -> tuple[float, float]:
        start = _clock(device)
        pos = to_clip(v_pos, mvp)
        rast, rast_db = dr.rasterize(None, pos, tri, (512, 512))
        uv, uv_da = dr.interpolate(v_uv, rast, tri, rast_db, diff_attrs="all")
        gbuffer, _ = dr.interpolate(torch.cat([v_nrm, v_pos], 1), rast, tri)
        normal, position = gbuffer[..., :3], gbuffer[..., 3:]
        albedo = dr.texture(texels, uv, uv_da, filter_mode="linear-mipmap-linear")
        shade = (normal * light).sum(-1, keepdim=True).clamp_min(0.0) + 0.05 * position.norm(dim=-1, keepdim=True)
        color = dr.antialias(albedo[..., :3] * shade, rast, pos, tri, topology)
        loss = (color - target).abs().mean()
        middle = _clock(device)
        loss.backward()
        end = _clock(device)
        v_pos.grad, texels.grad = None, None
        return middle - start, end - middle

    one_frame()  # warm-up
    launched = launches()
    wall0, cpu0 = time.perf_counter(), time.process_time()
    forward, backward = zip(*(one_frame() for _ in range(repeats)))
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    figures = {
        "frame_forward_ms": _median_ms(forward),
        "frame_backward_ms": _median_ms(backward),
        "frame_total_ms": _median_ms([f + b for f, b in zip(forward, backward)]),
        "frame_cpu_ms": 1000.0 * cpu / repeats,
        "cpu_per_wall": cpu / wall,
    }
    if device.type == "cuda":
        figures["launches_per_frame"] = (launches() - launched) / repeats
    return figures


def time_launch(device, repeats: int = 200) -> float:
    """Mean wall microseconds of launching an empty CUDA kernel with eight tensor arguments."""
    import torch

    from lookalike.devices import launch, numba_cuda

    cuda = numba_cuda()

    @cuda.jit
    def nothing(a, b, c, d, e, f, g, h):
        pass

    tensors = [torch.zeros(16, device=device) for _ in range(8)]
    launch(nothing, 1, *tensors)  # compiles it
    start = _clock(device)
    for _ in range(repeats):
        launch(nothing, 1, *tensors)
    return 1e6 * (_clock(device) - start) / repeats


def time_startup() -> dict:
    """Seconds to import and run a first rasterize in a fresh process, with an empty and
    then with a filled Numba cache."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)

        def one_run() -> float:
            done = subprocess.run([sys.executable, "-c", _STARTUP_SCRIPT], env=env, capture_output=True, text=True, check=True)
            return float(done.stdout.strip().splitlines()[-1])

        compile_s = one_run()
        startup_s = min(one_run() for _ in range(3))
    return {"compile_s": compile_s, "startup_s": startup_s}


def run(repeats: int | None = None, device: str | None = None) -> dict:
    """The figures on ``device`` (``"auto"``, ``"cuda"`` or ``"cpu"``; default ``"auto"``)."""
    repeats = 5 if repeats is None else max(1, repeats)
    import torch

    from lookalike.devices import device_label, resolve_device

    on = resolve_device(device or "auto")
    result = {
        "device": device_label(on),
        "threads": torch.get_num_threads(),
        "visibility_100k_ms": time_visibility(100_000, repeats, on),
        "visibility_500k_ms": time_visibility(500_000, repeats, on),
    }
    result.update(time_frame(repeats, on))
    if on.type == "cuda":
        result["launch_us"] = time_launch(on)
    else:
        result.update(time_startup())
    return result


def format_table(result: dict) -> str:
    rows = [("figure", "value", "target")]
    targets = TARGETS if result.get("device", "cpu") == "cpu" else GPU_TARGETS
    for key, value in result.items():
        target = targets.get(key)
        bound = "" if target is None else (f">= {target:g}" if key == "cpu_per_wall" else f"<= {target:g}")
        rows.append((key, f"{value:.3g}" if isinstance(value, float) else str(value), bound))
    width = [max(len(r[i]) for r in rows) for i in range(3)]
    return "\n".join("  ".join(cell.ljust(w) for cell, w in zip(r, width)).rstrip() for r in rows)
