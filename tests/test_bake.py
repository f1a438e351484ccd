"""The classic projection bake: ray casting (against its brute-force twin), the nearest-hit
rule, self-bakes, analytic bump normals, a rendered comparison, thin geometry and misses, and
the ``lookalike bake`` job."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import torch

from lookalike import io
from lookalike.asset import Asset, Material, Mesh, Texture
from lookalike.asset.uv_raster import sample_bilinear
from lookalike.cli import main
from lookalike.errors import ConfigError
from lookalike.init import unwrap
from lookalike.init.projection_bake import atlas_texels, bake, box_filter, locate_on_reference, project_along_normals
from lookalike.jobs.bake import bake_asset
from lookalike.init import raycast
from lookalike.init.raycast import RayCaster, intersect_python
from lookalike.shading import render
from lookalike.shading.view_sampling import random_lights, random_views
from mesh_factory import icosphere


def texel_values(texture: Texture, texels) -> np.ndarray:
    """``[K, C]`` values of a baked texture at the covered texels."""
    return texture.data.numpy()[texels.rows, texels.cols]


def world_normals(normal_map: Texture, texels) -> np.ndarray:
    """``[K, 3]`` shading normals a renderer gets from the baked map: ``x t + y b + z n``."""
    m = texel_values(normal_map, texels).astype(np.float64)
    return m[:, :1] * texels.tangent + m[:, 1:2] * texels.bitangent + m[:, 2:] * texels.normal


def bumpy_sphere(subdivisions: int, amplitude: float) -> Mesh:
    """Unit icosphere displaced radially: ``r(w) = 1 + amplitude * f(w)``, ``f = sin(3x) cos(2y)``."""
    mesh = icosphere(subdivisions)
    w = mesh.v_pos.double() / mesh.v_pos.double().norm(dim=-1, keepdim=True)
    radius = 1 + amplitude * torch.sin(3 * w[:, 0]) * torch.cos(2 * w[:, 1])
    return Mesh(v_pos=(w * radius[:, None]).float(), t_pos_idx=mesh.t_pos_idx)


def bump_normal(w: np.ndarray, amplitude: float) -> np.ndarray:
    """Analytic unit normal of ``bumpy_sphere`` at unit directions ``w [K, 3]``: the surface
    ``x = r(w) w`` has normal ``normalize(w - grad_S r / r)``, ``grad_S`` the gradient along
    the unit sphere (the 3D gradient of ``f`` minus its radial part)."""
    x, y = w[:, 0], w[:, 1]
    f = np.sin(3 * x) * np.cos(2 * y)
    grad = np.stack([3 * np.cos(3 * x) * np.cos(2 * y), -2 * np.sin(3 * x) * np.sin(2 * y), np.zeros_like(x)], -1)
    tangential = grad - (grad * w).sum(-1, keepdims=True) * w
    n = w - amplitude * tangential / (1 + amplitude * f)[:, None]
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def test_raycaster_matches_brute_force_twin(monkeypatch):
    monkeypatch.setattr(raycast, "THREAD_BLOCK", 1000)  # several threads share the 3000 rays
    g = np.random.default_rng(1)
    mesh = bumpy_sphere(2, 0.2)
    v_pos = mesh.v_pos.numpy() + g.normal(scale=0.02, size=mesh.v_pos.shape).astype(np.float32)
    t_pos_idx = mesh.t_pos_idx.numpy()
    origins = g.uniform(-1.5, 1.5, size=(3000, 3))
    directions = g.normal(size=(3000, 3))
    t_max = g.uniform(0.1, 3.0, size=3000)
    fast = RayCaster(v_pos, t_pos_idx).intersect(origins, directions, t_max)
    slow = intersect_python(v_pos, t_pos_idx, origins, directions, t_max)
    assert 0.2 < slow.hit.mean() < 0.9  # both hits and misses are exercised
    # rays that graze an edge or end right at a surface may go either way in float32
    inner = np.minimum(slow.barycentric.min(axis=1), fast.barycentric.min(axis=1))
    clear = (np.abs(slow.t - t_max) > 1e-4) & (inner > 1e-4)
    clear |= ~slow.hit & ~fast.hit
    assert clear.mean() > 0.95
    assert np.array_equal(fast.triangle[clear], slow.triangle[clear])
    both = clear & slow.hit
    assert np.allclose(fast.t[both], slow.t[both], rtol=1e-4, atol=1e-5)
    assert np.allclose(fast.barycentric[both], slow.barycentric[both], atol=1e-4)
    hit_points = np.einsum("kc,kcd->kd", fast.barycentric[both], v_pos[t_pos_idx][fast.triangle[both]])
    along_ray = origins[both] + fast.t[both, None] * directions[both]
    assert np.abs(hit_points - along_ray).max() < 1e-4


def two_sheets(z_top: float, z_bottom: float, half: float = 1.0, cells: int = 8) -> Mesh:
    """Two parallel square grids (unconnected): one at ``z_top`` facing +z, one at ``z_bottom``
    facing -z, each ``2 half`` wide."""
    u = np.linspace(-half, half, cells + 1)
    x, y = np.meshgrid(u, u, indexing="ij")
    grid = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], -1)
    i, j = np.meshgrid(np.arange(cells), np.arange(cells), indexing="ij")
    a = (i * (cells + 1) + j).ravel()
    up = np.concatenate([np.stack([a, a + cells + 1, a + 1], -1), np.stack([a + 1, a + cells + 1, a + cells + 2], -1)])
    top, bottom = grid + [0, 0, z_top], grid + [0, 0, z_bottom]
    v_pos = torch.tensor(np.concatenate([top, bottom]), dtype=torch.float32)
    t_pos_idx = torch.tensor(np.concatenate([up, up[:, ::-1] + len(grid)]), dtype=torch.int64)
    return Mesh(v_pos=v_pos, t_pos_idx=t_pos_idx)


def sheets_caster(sheets: Mesh):
    """``(caster, face_normal [T, 3], one_sided [T])`` of ``sheets``, every triangle one-sided."""
    v_pos, t_pos_idx = sheets.v_pos.numpy().astype(np.float64), sheets.t_pos_idx.numpy()
    corners = v_pos[t_pos_idx]
    face_normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    face_normal /= np.linalg.norm(face_normal, axis=-1, keepdims=True)
    return RayCaster(v_pos, t_pos_idx), face_normal, np.ones(len(t_pos_idx), bool)


def test_nearest_hit_of_either_direction_wins_and_ties_go_outward():
    upper = two_sheets(0.25, 10.0)             # one sheet facing +z at z = 0.25 (the other far away)
    lower = two_sheets(-0.25, 10.0)
    both = Mesh(v_pos=torch.cat([upper.v_pos, lower.v_pos]),
                t_pos_idx=torch.cat([upper.t_pos_idx, lower.t_pos_idx + upper.num_vertices]))
    caster, face_normal, one_sided = sheets_caster(both)
    points = np.array([[0.1, 0.2, -0.1], [0.1, 0.2, 0.1], [0.1, 0.2, 0.0]])
    normals = np.array([[0.0, 0.0, 1.0]] * 3)
    hits, offset = project_along_normals(caster, points, normals, 1.0, face_normal, one_sided)
    assert hits.hit.all()
    upper_hit = hits.triangle < upper.num_triangles
    # nearer sheet below; nearer sheet above; equidistant (tie -> outward, the upper sheet)
    assert upper_hit.tolist() == [False, True, True]
    assert np.allclose(offset, [-0.15, 0.15, 0.25], atol=1e-6)
    far, far_offset = project_along_normals(caster, points[:1], normals[:1], 0.1, face_normal, one_sided)
    assert not far.hit.any() and np.isinf(far_offset).all()


def test_rays_pass_through_back_faces_of_one_sided_surfaces_only():
    sheets = two_sheets(0.5, -0.25)           # facing +z above, facing -z (away from +z) below
    caster, face_normal, one_sided = sheets_caster(sheets)
    points, normals = np.array([[0.1, 0.2, 0.0]]), np.array([[0.0, 0.0, 1.0]])
    hits, offset = project_along_normals(caster, points, normals, 1.0, face_normal, one_sided)
    assert hits.triangle[0] < sheets.num_triangles // 2 and np.isclose(offset[0], 0.5, atol=1e-6)
    below, _ = project_along_normals(caster, points, -normals, 1.0, face_normal, one_sided)
    assert below.triangle[0] >= sheets.num_triangles // 2          # seen from below: the lower sheet
    hits, offset = project_along_normals(caster, points, normals, 1.0, face_normal, ~one_sided)
    assert hits.triangle[0] >= sheets.num_triangles // 2 and np.isclose(offset[0], -0.25, atol=1e-6)
    layers = [sheets.v_pos + torch.tensor([0.0, 0.0, dz]) for dz in (0.0, 0.01, 0.02)] + [two_sheets(-0.3, 10.0).v_pos]
    stacked = Mesh(v_pos=torch.cat(layers),
                   t_pos_idx=torch.cat([sheets.t_pos_idx + k * sheets.num_vertices for k in range(4)]))
    caster, face_normal, one_sided = sheets_caster(stacked)
    hits, offset = project_along_normals(caster, points, normals, 1.0, face_normal, one_sided)
    assert np.isclose(offset[0], -0.3, atol=1e-6)  # through three back faces to the sheet facing up below


def vertex_coloured_sphere() -> Asset:
    mesh = icosphere(3)
    colour = torch.cat([0.5 + 0.4 * mesh.v_pos, torch.ones(mesh.num_vertices, 1)], dim=1)
    mesh.v_color = colour
    return Asset(mesh=mesh, materials=[Material(kd=Texture.constant([1.0, 1.0, 1.0, 1.0]))])


def test_bake_onto_itself_gives_a_flat_normal_map_and_the_same_vertex_colours():
    reference = vertex_coloured_sphere()
    low = unwrap(icosphere(3), texture_size=128)
    result = bake(reference, low, texture_size=128, samples=1)
    texels = atlas_texels(low, 128)
    assert result.hit_fraction == 1.0 and result.mean_offset < 1e-5
    normal = result.material.normal.data
    assert normal[..., 2].min() > 0.9999          # every texel, covered or filled
    corners = reference.mesh.v_color.numpy()[low.t_pos_idx.numpy()[texels.triangle]]
    expected = np.einsum("kc,kcd->kd", texels.barycentric, corners)
    assert np.abs(texel_values(result.material.kd, texels) - expected).max() < 1e-4


def test_bake_onto_itself_keeps_a_textured_material():
    g = np.random.default_rng(2)
    high = unwrap(icosphere(3), texture_size=64)
    coarse = torch.from_numpy(g.uniform(0.1, 0.9, size=(8, 8, 4)).astype(np.float32))
    colour = torch.nn.functional.interpolate(coarse.permute(2, 0, 1)[None], size=(64, 64), mode="bilinear")[0]
    colour = colour.permute(1, 2, 0).contiguous()
    colour[..., 3] = 1.0
    specular = Texture.constant([0.1, 0.6, 0.3])
    reference = Asset(mesh=high, materials=[Material(kd=Texture(colour), ks=specular)])
    low = unwrap(Mesh(v_pos=high.v_pos, t_pos_idx=high.t_pos_idx), texture_size=128)
    result = bake(reference, low, texture_size=128, samples=1)
    texels = atlas_texels(low, 128)
    v_tex, t_tex_idx = high.uv[0]
    uv = np.einsum("kc,kcd->kd", texels.barycentric, v_tex.double()[t_tex_idx].numpy()[texels.triangle])
    expected = sample_bilinear(colour.numpy(), uv)
    error = np.abs(texel_values(result.material.kd, texels) - expected).max(axis=1)
    # texels on an edge may be hit through the neighbouring triangle, across a UV seam
    assert np.quantile(error, 0.97) < 1e-3
    assert np.allclose(texel_values(result.material.ks, texels), [0.1, 0.6, 0.3], atol=1e-6)
    assert result.material.normal.data[..., 2].min() > 0.9999


def test_bake_of_a_bumpy_sphere_gives_the_analytic_normals():
    amplitude = 0.08
    reference = Asset(mesh=bumpy_sphere(6, amplitude), materials=[Material()])
    low = unwrap(icosphere(4), texture_size=128)
    result = bake(reference, low, texture_size=128, cage=0.2)   # bumps reach 0.08 off the unit sphere
    texels = atlas_texels(low, 128)
    assert result.hit_fraction == 1.0
    got = world_normals(result.material.normal, texels)
    w = texels.position / np.linalg.norm(texels.position, axis=-1, keepdims=True)
    expected = bump_normal(w, amplitude)
    angle = np.degrees(np.arccos(np.clip((got * expected).sum(-1), -1, 1)))
    bumpiness = np.degrees(np.arccos(np.clip((expected * texels.normal).sum(-1), -1, 1)))
    assert bumpiness.max() > 10                   # the map has something to show
    assert angle.mean() < 0.1 and angle.max() < 1.0


def test_normal_map_of_the_reference_is_baked_in_world_space():
    sheet = two_sheets(0.0, 10.0)
    top = Mesh(v_pos=sheet.v_pos, t_pos_idx=sheet.t_pos_idx[: sheet.num_triangles // 2])
    xy = top.v_pos[:, :2]
    v_tex = torch.stack([(xy[:, 0] + 1) / 2, (1 - xy[:, 1]) / 2], dim=-1)   # u along +x, v down = -y
    top.uv = [(v_tex, top.t_pos_idx.clone())]
    tilt = np.array([0.3, -0.2, 1.0]) / np.linalg.norm([0.3, -0.2, 1.0])
    reference = Asset(mesh=top, materials=[Material(normal=Texture.constant(tilt.tolist()))])
    low = unwrap(Mesh(v_pos=top.v_pos, t_pos_idx=top.t_pos_idx), texture_size=64)
    result = bake(reference, low, texture_size=64)
    got = world_normals(result.material.normal, atlas_texels(low, 64))
    # our frame: x along increasing u (+x), y along decreasing v (+y), z along the normal (+z)
    assert np.abs(got - tilt).max() < 1e-4


def test_baked_normal_map_renders_closer_to_the_reference_than_none():
    reference = Asset(mesh=bumpy_sphere(5, 0.08), materials=[Material()])
    low = unwrap(icosphere(2), texture_size=128)
    result = bake(reference, low, texture_size=128)
    baked = Asset(mesh=low, materials=[result.material])
    flat = Asset(mesh=low, materials=[Material(kd=result.material.kd, ks=result.material.ks)])
    g = np.random.default_rng(4)
    camera = random_views(torch.zeros(3), 1.1, 4, g)
    light = random_lights(camera, torch.zeros(3), g)
    with torch.no_grad():
        target = render(reference, camera, light, 96)
        error_baked = (render(baked, camera, light, 96) - target)[..., :3].abs().mean()
        error_flat = (render(flat, camera, light, 96) - target)[..., :3].abs().mean()
    assert error_baked < 0.8 * error_flat


@pytest.mark.parametrize("double_sided", [False, True])
def test_rays_from_inside_thin_geometry_or_missing_everything_leave_no_holes(double_sided):
    colour = Texture.constant([0.2, 0.4, 0.6, 1.0])
    reference = Asset(mesh=two_sheets(0.0006, -0.0004), materials=[Material(kd=colour, double_sided=double_sided)])
    plane = two_sheets(0.0, 0.0, half=1.5, cells=6)
    low = unwrap(Mesh(v_pos=plane.v_pos, t_pos_idx=plane.t_pos_idx[: plane.num_triangles // 2]), texture_size=64)
    result = bake(reference, low, texture_size=64, cage=0.05)
    assert 0.2 < result.hit_fraction < 0.8        # inside the sheets: hits; outside: closest point
    material = result.material
    for texture in (material.kd, material.ks, material.normal):
        assert torch.isfinite(texture.data).all()
    assert torch.allclose(material.normal.data.norm(dim=-1), torch.ones(64, 64), atol=1e-5)
    assert torch.allclose(material.kd.data, torch.tensor([0.2, 0.4, 0.6, 1.0]))
    texels = atlas_texels(low, 64)
    z = texel_values(material.normal, texels)[:, 2]
    # the nearer sheet below faces away: one-sided, rays pass it for the upper one; double-sided,
    # it is seen from behind with its normal flipped
    assert (z > 0.999).all()


def test_bake_rejects_bad_arguments():
    reference = vertex_coloured_sphere()
    with pytest.raises(ConfigError, match="UV atlas"):
        bake(reference, icosphere(1))
    with pytest.raises(ConfigError, match="cage"):
        bake(reference, unwrap(icosphere(1), 64), texture_size=64, cage=0.0)


def test_bake_job_writes_a_model_and_refuses_to_overwrite(tmp_path):
    source = tmp_path / "ball.glb"
    io.save(vertex_coloured_sphere(), source)
    out = tmp_path / "out"
    assert main(["bake", str(source), "-o", str(out), "--triangles", "200", "--texture-size", "64"]) == 0
    baked = io.load(out / "model.glb")
    assert baked.mesh.num_triangles == 200 and len(baked.materials) == 1
    material = baked.materials[0]
    assert material.normal is not None and tuple(material.kd.data.shape) == (64, 64, 4)
    assert (out / "metrics.json").is_file()
    assert main(["bake", str(source), "-o", str(out), "--triangles", "200", "--texture-size", "64"]) == 2
    result = bake_asset(source, out, ratio=0.5, texture_size=32, force=True)
    assert result.metrics["triangles"] == {"input": 1280, "output": 640}
    assert math.isclose(result.metrics["hit_fraction"], 1.0, abs_tol=0.01)


def test_bake_benchmark_runs_and_prints_its_figures(monkeypatch):
    from lookalike.bench import bake as bench

    monkeypatch.setattr(bench, "REFERENCE_GRID", (40, 40))
    monkeypatch.setattr(bench, "LOW_GRID", (20, 20))
    monkeypatch.setattr(bench, "TEXTURE_SIZE", 64)
    monkeypatch.setattr(bench, "MILLION_TEXELS_SIZE", 96)
    result = bench.run(repeats=1)
    assert result["reference_triangles"] == 3200 and result["hit_fraction"] > 0.99
    assert result["million_texels"] > result["texels"] > 0
    table = bench.format_table(result)
    assert "bake_wall_s" in table and "<= 10" in table


def box_filter_python(rows, cols, factor, values):
    """One texel at a time: the mean of the samples whose sub-texel lies in it."""
    groups: dict[tuple[int, int], list[int]] = {}
    for k, (r, c) in enumerate(zip(rows, cols)):
        groups.setdefault((int(r) // factor, int(c) // factor), []).append(k)
    keys = sorted(groups)
    means = [np.array([array[groups[key]].mean(axis=0) for key in keys]) for array in values]
    return np.array([k[0] for k in keys]), np.array([k[1] for k in keys]), means


def test_box_filter_matches_its_python_twin():
    g = np.random.default_rng(7)
    flat = g.choice(40 * 40, size=900, replace=False)
    rows, cols = flat // 40, flat % 40
    values = [g.normal(size=(900, 3)), g.normal(size=(900, 1))]
    got = box_filter(rows, cols, 4, values)
    expected = box_filter_python(rows, cols, 4, values)
    order = np.lexsort((got[1], got[0]))
    assert np.array_equal(got[0][order], expected[0]) and np.array_equal(got[1][order], expected[1])
    for mine, theirs in zip(got[2], expected[2]):
        assert np.allclose(mine[order], theirs)


def test_supersampling_averages_detail_finer_than_a_texel_instead_of_aliasing_it():
    sphere = icosphere(5)
    jitter = torch.from_numpy(np.random.default_rng(3).uniform(-0.004, 0.004, size=(sphere.num_vertices, 1)))
    rough = Mesh(v_pos=(sphere.v_pos.double() * (1 + jitter)).float(), t_pos_idx=sphere.t_pos_idx)
    reference = Asset(mesh=rough, materials=[Material()])   # normals that change within every texel
    low = unwrap(icosphere(2), texture_size=32)
    covered = atlas_texels(low, 32)

    def grain(samples: int) -> float:
        normal = bake(reference, low, texture_size=32, cage=0.05, samples=samples).material.normal.data.numpy()
        return float(np.std(normal[covered.rows, covered.cols, :2]))

    assert grain(4) < 0.6 * grain(1)


@pytest.mark.parametrize("subdivisions", [0, 1])
def test_a_faceted_low_poly_bakes_a_smooth_reference_without_seams_at_its_hard_edges(subdivisions):
    """A flat-shaded icosahedron (its edges split its normals) baked from a smooth sphere: rays
    along the smooth normal reach the sphere point under each texel, so the decoded normals are
    the sphere's radial ones everywhere, edges included. Rays along each face's own normal would
    read points tilted towards that face's normal (by 3.3 degrees on the icosahedron), jumping
    across each edge."""
    low = unwrap(icosphere(subdivisions), texture_size=128)
    low = dataclasses.replace(low, t_nrm_idx=torch.arange(3 * low.num_triangles).reshape(-1, 3))  # flat-shaded
    reference = Asset(mesh=icosphere(6), materials=[Material()])
    result = bake(reference, low, texture_size=128, cage=0.5, samples=1)
    texels = atlas_texels(low, 128)
    got = world_normals(result.material.normal, texels)
    radial = texels.position / np.linalg.norm(texels.position, axis=-1, keepdims=True)
    angle = np.degrees(np.arccos(np.clip((got * radial).sum(-1), -1, 1)))
    facet = np.degrees(np.arccos(np.clip((texels.normal * radial).sum(-1), -1, 1)))
    assert facet.max() > 15                                     # the facets' own normals are far off
    assert angle.max() < 0.5


def test_a_texel_bakes_the_nearer_hit_of_its_smooth_and_its_own_normal_line():
    """A flat-shaded tent (two faces meeting at 90 degrees) over a reference plane ``d`` above
    its left face: the left face's own normal reaches the plane in ``d``, its smooth normal
    (tilted up to 45 degrees near the ridge) only in up to ``sqrt(2) d``; the nearer is taken."""
    d = 0.05
    v = torch.tensor([[-1.0, -1, 0], [0, -1, 1], [1, -1, 0], [-1, 1, 0], [0, 1, 1], [1, 1, 0]])
    tent = Mesh(v_pos=v, t_pos_idx=torch.tensor([[0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4]]))
    low = unwrap(tent, texture_size=64)
    low = dataclasses.replace(low, t_nrm_idx=torch.arange(3 * low.num_triangles).reshape(-1, 3))
    left = torch.tensor([-1.0, 0.0, 1.0]) / math.sqrt(2)
    along = torch.tensor([1.0, 0.0, 1.0]) / math.sqrt(2)
    corners = [d * left + s * 2.0 * along + torch.tensor([-0.5, t * 2.0, 0.5]) for s, t in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    plane = Asset(mesh=Mesh(v_pos=torch.stack(corners), t_pos_idx=torch.tensor([[0, 1, 2], [0, 2, 3]])),
                  materials=[Material(double_sided=True)])
    texels = atlas_texels(low, 64)
    points = locate_on_reference(plane, texels, cage=0.2)
    on_left = texels.position[:, 0] < -0.01
    assert points.hit[on_left].all()
    assert np.abs(points.offset[on_left] - d).max() < 1e-6
    smooth_reach = d / (texels.smooth[on_left] * texels.normal[on_left]).sum(-1)
    assert smooth_reach.max() > 1.3 * d                           # the smooth line alone would reach further
