"""Every CUDA kernel of the renderer against its plain-torch twin, forward and backward, on small
inputs: on the GPU where torch sees one, else in Numba's CUDA simulator, which runs each GPU
thread as a Python thread on CPU tensors (``lookalike.devices.cuda_kernels_for_cpu_tensors``
makes the ops take their CUDA forms for them).

How the simulator is chosen: ``numba.cuda``, when first imported, takes its target from
Numba's configuration (``NUMBA_ENABLE_CUDASIM``, read when Numba is imported and again on
``reload_config``), and that process keeps the target it got. So this module, when collected on
a machine without a GPU, imports ``numba.cuda`` with the variable set, and the configuration
reloaded, for that import alone (``_cuda_target``: Numba is imported already, by the conftest
and the modules collected before), and leaves both as it found them, so that no other test's
child process inherits the variable. The simulator staying loaded does not change the other tests: the library
imports ``numba.cuda`` only for tensors on a GPU (or under the tests' switch), and ``"auto"``
asks torch first, which sees no GPU either way. Where ``numba.cuda`` was already imported for a
real GPU that torch does not see, the module is skipped.

The simulator runs the kernels' Python, not their GPU compilation: the last test compiles every
kernel launched here to PTX for the argument types it was launched with (NVVM from the ``cuda``
extra's wheels; skipped without them), so a kernel that only Python accepts fails here too.
"""

from __future__ import annotations

import math
import os
import pickle
import subprocess
import sys
import textwrap

import pytest
import torch
from mesh_factory import bumpy_sphere_clip


def _simulated(cuda) -> bool:
    """Whether ``cuda`` (``numba.cuda``) is Numba's simulator."""
    return cuda.jit.__module__.startswith("numba.cuda.simulator")


def _cuda_target():
    """``numba.cuda``: the GPU where torch sees one, else the simulator (see the docstring)."""
    from numba.core import config

    before = os.environ.get("NUMBA_ENABLE_CUDASIM")
    if not torch.cuda.is_available():
        os.environ["NUMBA_ENABLE_CUDASIM"] = "1"
        config.reload_config()
    try:
        from numba import cuda
    except ImportError as e:
        pytest.skip(f"numba-cuda is not installed: {e}", allow_module_level=True)
    finally:
        if before is None:
            os.environ.pop("NUMBA_ENABLE_CUDASIM", None)
        else:
            os.environ["NUMBA_ENABLE_CUDASIM"] = before
        config.reload_config()
    if not torch.cuda.is_available() and not _simulated(cuda):
        pytest.skip("numba.cuda was imported for a GPU that torch does not see", allow_module_level=True)
    return cuda


cuda = _cuda_target()

import lookalike.render as dr  # noqa: E402
from lookalike.render.antialias import (neighbour_pairs_python, outline_walk_python,  # noqa: E402
                                        silhouette_edges_python)
from lookalike.devices import cuda_kernels_for_cpu_tensors  # noqa: E402
from lookalike.render.antialias_kernels import outline_crossings  # noqa: E402
from lookalike.render.barycentrics import barycentrics_python, pixel_ndc  # noqa: E402
from lookalike.render.interpolate import interpolate_python  # noqa: E402
from lookalike.render.mipmap import texture_construct_mip, texture_pyramid  # noqa: E402
from lookalike.render.msaa import (covered_sample_index, covered_sample_index_python, pick_samples,  # noqa: E402
                                   pick_samples_python, upsample_over, upsample_over_python)
from lookalike.render.rasterize import rasterize_layers  # noqa: E402
from lookalike.render.texture import texture_python  # noqa: E402
from lookalike.render.visibility_python import visibility_python, visible_layers_python  # noqa: E402
from lookalike.fit.slope_normals import slopes_to_normal, slopes_to_normal_python  # noqa: E402
from lookalike.fit.texture_pyramid import compose, compose_python, level_sizes  # noqa: E402
from lookalike.render.window import Window  # noqa: E402
from lookalike.shading.light import PointLight  # noqa: E402
from lookalike.shading.normal_map import shading_normal, shading_normal_python  # noqa: E402
from lookalike.shading.point_lighting import lit_radiance, lit_radiance_python  # noqa: E402

DEVICE = torch.device("cuda" if torch.cuda.is_available() else "cpu")
"""Where the CUDA kernels' inputs live: the GPU, or the CPU for the simulator."""

LAUNCHED: dict[tuple[str, str, tuple], None] = {}
"""``(module, kernel, argument types)`` of every simulated launch, for ``test_every_launched_kernel_compiles``."""


@pytest.fixture(autouse=True)
def record_launches(monkeypatch):
    """In the simulator, note each kernel launch's module, name and Numba argument types."""
    if not _simulated(cuda):
        yield
        return
    import numba
    from numba.cuda.simulator.kernel import FakeCUDAKernel

    call = FakeCUDAKernel.__call__

    def recording(self, *args):
        if not self._device:
            LAUNCHED[(self.fn.__module__, self.fn.__name__, tuple(numba.typeof(a) for a in args))] = None
        return call(self, *args)

    monkeypatch.setattr(FakeCUDAKernel, "__call__", recording)
    yield


def on_cuda(op, *tensors, gradients_to=None, **keywords):
    """``op(*tensors, **keywords)`` through the CUDA kernels, its tensors on ``DEVICE``; outputs
    back on the CPU. With ``gradients_to`` (CPU tensors among ``tensors``), also the gradients
    of a random weighting of the outputs to them (``weighted_sum_gradients``), the backward
    kernels too run through the CUDA forms: ``(outputs, gradients)``."""
    moved = [t.to(DEVICE) if isinstance(t, torch.Tensor) else t for t in tensors]
    with cuda_kernels_for_cpu_tensors():
        out = op(*moved, **keywords)
        out = tuple(o.cpu() for o in out) if isinstance(out, tuple) else out.cpu()
        if gradients_to is None:
            return out
        return out, weighted_sum_gradients(out if isinstance(out, tuple) else [out], gradients_to)


def random_scene(n_views=2, n_verts=14, n_tris=12, seed=0):
    """Clip-space positions ``[B, V, 4]`` (some crossing the near plane) and triangles ``[T, 3]``."""
    generator = torch.Generator().manual_seed(seed)
    pos = torch.rand(n_views, n_verts, 4, generator=generator, dtype=torch.float64) * 2.4 - 1.2
    pos[..., 3] = 1.0 + 0.3 * torch.rand(n_views, n_verts, generator=generator, dtype=torch.float64)
    pos[..., 2] *= 0.8
    pos[0, 0, 3] = -0.2  # a vertex behind the eye: the clipped box path
    tri = torch.stack([torch.randperm(n_verts, generator=generator)[:3] for _ in range(n_tris)])
    tri[-1] = tri[1]  # a triangle drawn twice: its second copy has no depth of its own
    return pos.float(), tri


def weighted_sum_gradients(outputs, inputs, seed=1):
    """Gradients of a random weighting of ``outputs`` (so every output element matters)."""
    generator = torch.Generator().manual_seed(seed)
    loss = sum((o * torch.randn(o.shape, generator=generator, dtype=o.dtype).to(o.device)).sum() for o in outputs)
    return torch.autograd.grad(loss, inputs, allow_unused=True, materialize_grads=True)


def test_visible_layers_match_the_peeling_twin_across_tiles():
    pos, tri = random_scene()
    resolution = (34, 36)  # four 32-pixel tiles: binning is exercised
    ranges = torch.tensor([[0, 12], [3, 9]])
    ids, depth = on_cuda(lambda p, t: rasterize_layers(p, t, resolution, ranges, 3), pos[0], tri)
    twin_ids, twin_depth = visible_layers_python(pos[0].expand(2, -1, -1), tri, resolution, 3, ranges)
    assert (twin_ids > 0).sum() > 400
    assert torch.equal(ids, twin_ids)
    torch.testing.assert_close(depth, twin_depth)


def test_visibility_within_a_window_and_beyond_a_depth_matches_the_twin():
    pos, tri = random_scene(seed=3)
    floor = torch.full((2, 12, 16), -0.2)
    window = Window(2, 3, 8, 10, 12, 16)
    ids, depth = on_cuda(lambda p, t, f: rasterize_layers(p, t, (12, 16), None, 1, f, window), pos, tri, floor)
    twin_ids, twin_depth = visibility_python(pos, tri, (12, 16), None, floor, window)
    assert (twin_ids > 0).sum() > 20
    assert torch.equal(ids[0], twin_ids)
    torch.testing.assert_close(depth[0], twin_depth)


@pytest.mark.parametrize("differentiable", [True, False])
def test_rasterize_matches_the_barycentrics_twin(differentiable):
    pos, tri = random_scene(seed=2)
    pos = pos.double().requires_grad_(differentiable)
    with torch.no_grad():
        rast, _ = dr.rasterize(None, pos, tri, (12, 16))
    flat = torch.nonzero(rast[..., 3].reshape(-1)).squeeze(1)
    assert flat.numel() > 40

    def covered(p, t):
        rast, rast_db = dr.rasterize(None, p, t, (12, 16))
        return rast.reshape(-1, 4)[flat.to(p.device), :2], rast_db.reshape(-1, 4)[flat.to(p.device)]

    with torch.set_grad_enabled(differentiable):
        ours = on_cuda(covered, pos, tri, gradients_to=[pos] if differentiable else None)
    tri_idx = rast[..., 3].reshape(-1)[flat].long() - 1
    uv, db = barycentrics_python(pos, tri, flat // (12 * 16), tri_idx, pixel_ndc(flat, 12, 16, torch.float64), (12, 16))
    (values, gradients) = ours if differentiable else (ours, None)
    torch.testing.assert_close(values[0], uv)
    torch.testing.assert_close(values[1], db)
    if differentiable:
        torch.testing.assert_close(gradients, weighted_sum_gradients([uv, db], pos))


@pytest.mark.parametrize("per_view", [False, True])
def test_interpolate_matches_the_twin(per_view):
    pos, tri = random_scene(seed=4)
    rast, rast_db = dr.rasterize(None, pos.double(), tri, (10, 12))
    generator = torch.Generator().manual_seed(5)
    attr = torch.rand(2 if per_view else 1, pos.shape[1], 3, generator=generator, dtype=torch.float64)
    inputs = [attr.requires_grad_(True), rast.requires_grad_(True), rast_db.requires_grad_(True)]
    ours, gradients = on_cuda(lambda a, r, d, t: dr.interpolate(a, r, t, d, diff_attrs=[0, 2]), *inputs, tri,
                              gradients_to=inputs)
    twin = interpolate_python(attr, rast, tri, rast_db, diff_attrs=[0, 2])
    for a, b in zip(ours, twin):
        torch.testing.assert_close(a, b)
    torch.testing.assert_close(gradients, weighted_sum_gradients(twin, inputs))


def test_interpolate_at_listed_pixels_matches_the_twin():
    pos, tri = random_scene(seed=6)
    rast, _ = dr.rasterize(None, pos.double(), tri, (10, 12))
    attr = torch.rand(1, pos.shape[1], 2, dtype=torch.float64, requires_grad=True)
    pixels = torch.nonzero(rast[..., 3].reshape(-1)).squeeze(1)[::2]
    ours, gradients = on_cuda(lambda a, r, t, p: dr.interpolate_at(a, r, t, p)[0], attr, rast, tri, pixels,
                              gradients_to=[attr])
    twin = interpolate_python(attr, rast, tri)[0].reshape(-1, 2)[pixels]
    torch.testing.assert_close(ours, twin)
    torch.testing.assert_close(gradients, weighted_sum_gradients([twin], [attr]))


LOOKUPS = [("nearest", "wrap", False), ("nearest", "zero", True), ("linear", "clamp", False), ("linear", "zero", True),
           ("linear-mipmap-nearest", "wrap", False), ("linear-mipmap-linear", "wrap", False),
           ("linear-mipmap-linear", "zero", True)]


@pytest.mark.parametrize("filter_mode, boundary_mode, per_view", LOOKUPS)
def test_texture_matches_the_twin(filter_mode, boundary_mode, per_view):
    generator = torch.Generator().manual_seed(7)
    tex = torch.rand(2 if per_view else 1, 6, 5, 3, generator=generator, dtype=torch.float64)
    uv = torch.rand(2, 4, 5, 2, generator=generator, dtype=torch.float64) * 1.4 - 0.2
    uv_da = torch.randn(2, 4, 5, 4, generator=generator, dtype=torch.float64) * 0.3
    bias = torch.randn(2, 4, 5, generator=generator, dtype=torch.float64) * 0.5
    mipmapped = "mipmap" in filter_mode
    inputs = [tex.requires_grad_(True), uv.requires_grad_(True)] + (
        [uv_da.requires_grad_(True), bias.requires_grad_(True)] if mipmapped else [])
    keywords = {"filter_mode": filter_mode, "boundary_mode": boundary_mode}

    differentiable = inputs if filter_mode != "nearest" else inputs[:1]
    ours, gradients = on_cuda(lambda *a: dr.texture(a[0], a[1], *a[2:], **keywords), *inputs,
                              gradients_to=differentiable)
    twin = texture_python(*inputs, **keywords)
    torch.testing.assert_close(ours, twin)
    torch.testing.assert_close(gradients, weighted_sum_gradients([twin], differentiable))


def test_mip_pyramid_matches_the_twin():
    tex = torch.rand(2, 7, 5, 2, dtype=torch.float64, requires_grad=True)  # odd sides: the general spans
    table, gradients = on_cuda(lambda t: texture_pyramid(t).table, tex, gradients_to=[tex])
    twin = torch.cat([tex.reshape(-1, 2)] + [level.reshape(-1, 2) for level in texture_construct_mip(tex)])
    torch.testing.assert_close(table, twin)
    torch.testing.assert_close(gradients, weighted_sum_gradients([twin], [tex]))


@pytest.mark.parametrize("windowed", [False, True])
def test_outline_search_matches_the_twins_and_antialias_its_cpu_form(windowed):
    from lookalike.render import antialias_cuda

    pos, tri = bumpy_sphere_clip(seed=11)
    height, width = 20, 24
    rast, _ = dr.rasterize(None, pos, tri, (height, width))
    window = Window(3, 4, 14, 17, height, width) if windowed else None
    part = window.crop(rast).contiguous() if windowed else rast
    topology = dr.antialias_construct_topology_hash(tri)
    with cuda_kernels_for_cpu_tensors():
        ours = antialias_cuda.outline_crossings(part.to(DEVICE), pos[..., [0, 1, 3]].contiguous().to(DEVICE), tri,
                                                topology.neighbour, topology.opposite, window)
    front, other, start_tri, horizontal = neighbour_pairs_python(part[..., 3].long(), part[..., 2])
    silhouette = silhouette_edges_python(pos, tri, topology.opposite)
    edge_tri, edge = outline_walk_python(pos, tri, topology.neighbour, silhouette, front, other, start_tri,
                                         part.shape[1], part.shape[2], window)
    hit = edge >= 0
    assert hit.sum() > 20 and (edge_tri[hit] != start_tri[hit]).any()  # outlines, some beyond the first triangle
    twin = (front[hit], other[hit], horizontal[hit], edge_tri[hit], edge[hit])
    assert sorted(zip(*(a.tolist() for a in ours))) == sorted(zip(*(a.tolist() for a in twin)))
    cpu = outline_crossings(part.numpy(), pos[..., [0, 1, 3]].contiguous().numpy(), tri.numpy(),
                            topology.neighbour.numpy(), topology.opposite.numpy(), window)
    assert all(torch.equal(a.cpu(), torch.from_numpy(b)) for a, b in zip(ours, cpu))  # in the same order
    colour = torch.rand(*part.shape[:3], 3, dtype=torch.float64, generator=torch.Generator().manual_seed(12))
    leaves = [colour.requires_grad_(True), pos.requires_grad_(True)]
    blended, gradients = on_cuda(lambda c, p, r, t: dr.antialias(c, r, p, t, topology, window=window), *leaves, part,
                                 tri, gradients_to=leaves)
    cpu = dr.antialias(colour, part, pos, tri, topology, window=window)
    torch.testing.assert_close(blended, cpu)
    torch.testing.assert_close(gradients, weighted_sum_gradients([cpu], leaves))


def test_msaa_matches_the_twins():
    factor, generator = 2, torch.Generator().manual_seed(10)
    ids = torch.randint(1, 9, (2, 8, 10), generator=generator).float()
    ids *= torch.rand(ids.shape, generator=generator) < 0.5
    ids[:, -2:, -2:] = 0  # a block with no covered sample
    u = torch.rand(2, 4, 5, generator=generator)
    index = on_cuda(lambda i, r: covered_sample_index(i, r, factor), ids, u)
    assert torch.equal(index, covered_sample_index_python(ids, u, factor))
    accum = torch.rand(2, 8, 10, 4, generator=generator, dtype=torch.float64).requires_grad_(True)
    colour = torch.rand(2, 4, 5, 4, generator=generator, dtype=torch.float64).requires_grad_(True)

    def composite(over, pick, a, c, i, k):
        image = over(a, c, i, factor)
        return image, pick(image, k)

    ours, gradients = on_cuda(lambda *a: composite(upsample_over, pick_samples, *a), accum, colour, ids, index,
                              gradients_to=[accum, colour])
    twin = composite(upsample_over_python, pick_samples_python, accum, colour, ids, index)
    for a, b in zip(ours, twin):
        torch.testing.assert_close(a, b)
    torch.testing.assert_close(gradients, weighted_sum_gradients(twin, [accum, colour]))


@pytest.mark.parametrize("size", [(10, 7), (16, 12)])  # odd sides, and plain halvings
def test_texture_pyramid_sum_matches_the_twin(size):
    generator = torch.Generator().manual_seed(13)
    sizes = level_sizes(*size, 3)
    levels = [4 * torch.randn(h, w, 3, generator=generator) for h, w in sizes]
    low, high = torch.tensor([0.0, -0.5, -math.inf]), 0.8
    scales = (0.25, 0.5, 1.0)[: len(sizes)]
    # on DEVICE from the start: compose takes the excess off the levels in place
    ours_levels = [level.clone().to(DEVICE).requires_grad_(True) for level in levels]
    twin_levels = [level.clone().requires_grad_(True) for level in levels]
    ours, gradients = on_cuda(lambda *ls: compose(list(ls), scales, low, high), *ours_levels, gradients_to=ours_levels)
    twin = compose_python(twin_levels, scales, low, high)
    assert ours.max() == 0.8 and ours[..., 2].min() < -0.5  # the bounds were active
    torch.testing.assert_close(ours, twin)
    torch.testing.assert_close(ours_levels[0].detach().cpu(), twin_levels[0].detach())  # the same excess taken off
    torch.testing.assert_close([g.cpu() for g in gradients], list(weighted_sum_gradients([twin], twin_levels)))


def test_slope_normals_match_the_twin():
    slopes = (2 * torch.randn(5, 7, 2, generator=torch.Generator().manual_seed(14), dtype=torch.float64))
    slopes.requires_grad_(True)
    ours, gradients = on_cuda(slopes_to_normal, slopes, gradients_to=[slopes])
    twin = slopes_to_normal_python(slopes)
    torch.testing.assert_close(ours, twin)
    torch.testing.assert_close(gradients, weighted_sum_gradients([twin], [slopes]))


def unit_vectors(generator, count, around=None, spread=1.0):
    """``[count, 3]`` float64 unit vectors, random or (``around``) near the given ones."""
    x = torch.randn(count, 3, generator=generator, dtype=torch.float64) * spread
    x = x if around is None else around + x
    return x / x.norm(dim=-1, keepdim=True)


def test_shading_normals_match_the_twin():
    generator = torch.Generator().manual_seed(8)
    count = 96
    normal = unit_vectors(generator, count) * (0.5 + torch.rand(count, 1, generator=generator, dtype=torch.float64))
    tangent = torch.cat([torch.randn(count, 3, generator=generator, dtype=torch.float64),
                         torch.where(torch.rand(count, 1, generator=generator) < 0.5, -1.0, 1.0).double()], 1)
    tangent_space = unit_vectors(generator, count, torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64), 0.6)
    geometric = unit_vectors(generator, count, normal, 0.4)
    view_dir = unit_vectors(generator, count)
    mapped = torch.rand(count, generator=generator) < 0.5
    facing = torch.where((geometric * view_dir).sum(-1) >= 0, 1.0, -1.0).double()
    leaves = [t.requires_grad_(True) for t in (normal, tangent, tangent_space, geometric, view_dir)]
    ours, gradients = on_cuda(lambda n, t, s, g, v, m, f: shading_normal(n, t, s, m, g, v, f), *leaves, mapped, facing,
                              gradients_to=leaves)
    twin = shading_normal_python(normal, tangent, tangent_space, mapped, geometric, view_dir, facing)
    assert (facing < 0).any() and mapped.any() and (~mapped).any()
    torch.testing.assert_close(ours, twin)
    torch.testing.assert_close(gradients, weighted_sum_gradients([twin], leaves))


@pytest.mark.parametrize("views", [1, 2])
def test_point_lighting_matches_the_twin(views):
    generator = torch.Generator().manual_seed(9)
    count = 96
    normal = unit_vectors(generator, count)
    view_dir = unit_vectors(generator, count, normal, 0.7)
    kd, ks = (torch.rand(count, 3, generator=generator, dtype=torch.float64) for _ in range(2))
    ks[:10, 1] = 0.01  # below the least roughness: the clamp
    position = torch.randn(count, 3, generator=generator, dtype=torch.float64)
    geometric = unit_vectors(generator, count, normal, 0.3)
    view = torch.randint(0, views, (count,), generator=generator)
    light_position = 3 * torch.randn(views, 3, generator=generator, dtype=torch.float64)
    intensity = 10 * torch.rand(views, 3, generator=generator, dtype=torch.float64)
    horizon = torch.arange(views) % 2 == 0
    leaves = [t.requires_grad_(True) for t in (kd, ks, normal, view_dir, position, light_position, intensity)]

    def lit(op, kd, ks, normal, view_dir, position, light_position, intensity, geometric, view, horizon):
        return op(kd, ks, normal, view_dir, position, geometric, view, PointLight(light_position, intensity, horizon))

    ours, gradients = on_cuda(lambda *a: lit(lit_radiance, *a), *leaves, geometric, view, horizon, gradients_to=leaves)
    twin = lit(lit_radiance_python, *leaves, geometric, view, horizon)
    assert (twin == 0).all(-1).any() and (twin > 0).any(-1).sum() > 30  # dark points and lit ones
    torch.testing.assert_close(ours, twin)
    torch.testing.assert_close(gradients, weighted_sum_gradients([twin], leaves))


_COMPILE = textwrap.dedent("""
    import importlib, pickle, sys, types
    from numba import cuda
    import numba.cuda.dispatcher
    # device functions take the current GPU's compute capability; without a GPU, Hopper's
    numba.cuda.dispatcher.get_current_device = lambda: types.SimpleNamespace(compute_capability=(9, 0))
    try:
        from numba.cuda.cudadrv import nvvm
        nvvm.NVVM()
        cuda.compile_ptx(lambda a: None, "void(float32[:])", cc=(9, 0))  # NVRTC too, where the toolkit has it
    except Exception as e:
        print(f"no NVVM or NVRTC: {e}")
        sys.exit(77)
    failed = []
    scattering = set(sys.argv[2:])
    for module, name, signature in pickle.load(open(sys.argv[1], "rb")):
        kernel = getattr(importlib.import_module(module), name)
        try:
            ptx, _ = cuda.compile_ptx(kernel.py_func, signature, cc=(9, 0))
        except Exception as e:
            failed.append(f"{module}.{name}{signature}: {type(e).__name__}: {str(e)[-1500:]}")
            continue
        if f"{module}.{name}" in scattering and "atom.global.add" not in ptx:
            failed.append(f"{module}.{name}{signature}: scatters without an atomic add")
    print(chr(10).join(failed) or "compiled")
    sys.exit(1 if failed else 0)
""")


CUDA_MODULES = ["render.visibility", "render.barycentrics", "render.interpolate", "render.texture", "render.mip",
                "render.msaa", "render.antialias", "shading.normal_map", "shading.point_lighting", "fit.pyramid",
                "fit.slope_normals"]
"""The modules of CUDA kernels, each of which the tests above launch."""

SCATTERING = [f"lookalike.render.{name}_cuda.{name}_backward" for name in ("barycentrics", "interpolate", "texture")]
"""The kernels whose threads add into shared elements (``kernel_scatter.scatter_add``): their
PTX must add atomically."""


def test_the_render_bench_launches_an_empty_kernel_and_counts_the_launches():
    from lookalike.bench import render as bench
    from lookalike.devices import launches

    before = launches()
    assert bench.time_launch(DEVICE, repeats=3) > 0
    assert launches() - before == 4  # the compiling launch and three timed ones
    for key in [k for k in LAUNCHED if k[0] == bench.__name__]:  # a local kernel: nothing to compile by name
        del LAUNCHED[key]


def test_every_launched_kernel_compiles_for_the_gpu(tmp_path):
    """Every kernel the tests above launched in the simulator compiles to PTX for its argument
    types (on a GPU, the tests compiled them for real), those that scatter with atomic adds."""
    if not _simulated(cuda):
        pytest.skip("on a GPU the tests above compiled every kernel they ran")
    if not LAUNCHED:
        pytest.skip("no kernel was launched: run the whole module")
    modules = {module for module, _, _ in LAUNCHED}
    assert {f"lookalike.{name}_cuda" for name in CUDA_MODULES} <= modules
    (tmp_path / "launched.pkl").write_bytes(pickle.dumps(list(LAUNCHED)))
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_ENABLE_CUDASIM"}
    done = subprocess.run([sys.executable, "-c", _COMPILE, str(tmp_path / "launched.pkl"), *SCATTERING], env=env,
                          capture_output=True, text=True, timeout=600)
    if done.returncode == 77:
        pytest.skip(f"cannot compile for the GPU here ({done.stdout.strip()}): pip install -e \".[cuda]\"")
    assert done.returncode == 0, (done.stdout + done.stderr)[-6000:]
