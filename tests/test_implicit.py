"""Implicit surfaces: the sphere tracers (torch and GLSL), marching cubes, the field's own bake,
the readers' answers to bad fields, and a short run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from field_factory import box_field, sphere_field, sphere_volume, write_fields
from lookalike import io
from lookalike.asset.implicit import ImplicitSurface, axes_points, field_mesh, field_normals, grid_axes, narrow_band_values
from lookalike.asset.normals import crease_normal_index, split_at_both
from lookalike.bench.implicit import FIELDS
from lookalike.cli import main
from lookalike.errors import AssetError, UserCodeError
from lookalike.fit.reference import FieldReference
from lookalike.init import decimate
from lookalike.init.field_surface import FieldSurface
from lookalike.io.field_asset import PALETTE_LIMIT, finer_field_mesh
from lookalike.report.metrics import psnr
from lookalike.shading.sphere_tracing import HIT_FRACTION, cone_starts, primary_rays, sphere_trace
from lookalike.shading.view_sampling import random_lights, random_views


def gl_available() -> bool:
    try:
        import moderngl
        moderngl.create_standalone_context(backend="egl", require=330).release()
        return True
    except Exception:
        return False


needs_gl = pytest.mark.skipif(not gl_available(), reason="no headless OpenGL (Debian's libegl1, libegl-mesa0, "
                              "libgl1-mesa-dri; see the README)")


def traced(surface, views: int = 3, size: int = 64):
    """Rays of ``views`` random cameras at ``size`` pixels and where they hit ``surface``."""
    centre, radius = surface.bounding_sphere()
    camera = random_views(torch.zeros(3), 0.6, views, np.random.default_rng(5))
    origins, directions, footprint = (x.reshape(-1, *x.shape[2:]) for x in primary_rays(camera, size, size))
    t, hit = sphere_trace(surface.distance, origins, directions, footprint, surface.lo, surface.hi)
    return origins, directions, footprint, t, hit


def test_the_tracer_finds_a_sphere_within_a_fraction_of_a_pixel_with_its_normals():
    origins, directions, footprint, t, hit = traced(sphere_field(0.5))
    # the exact intersection of each ray with the sphere
    b = (origins * directions).sum(-1)
    disc = b * b - ((origins * origins).sum(-1) - 0.25)
    exact = disc > 0
    margin = (disc.clamp(min=0).sqrt() / 1.0) > 2 * footprint * (-b)  # rays clearly inside the silhouette
    assert bool(hit[exact & margin].all()) and not bool(hit[~exact & (disc < -(footprint * -b) ** 2 * 16)].any())
    points = origins[hit] + t[hit, None] * directions[hit]
    error = (points.norm(dim=-1) - 0.5).abs()
    assert float((error / (footprint[hit] * t[hit])).max()) <= HIT_FRACTION * 1.01
    normals = field_normals(sphere_field(0.5), points)
    cosine = (normals * points / points.norm(dim=-1, keepdim=True)).sum(-1)
    assert float(cosine.min()) > 0.9999


def test_a_ray_that_passes_the_sphere_close_by_misses_it():
    """Silhouettes are not dilated: a ray passing the sphere by more than twice the hit fraction
    of its footprint misses, so the field's outline is where the surface's is."""
    origins, directions, footprint, t, hit = traced(sphere_field(0.5), size=128)
    b = (origins * directions).sum(-1)
    closest = ((origins * origins).sum(-1) - b * b).clamp(min=0).sqrt()  # the ray's nearest distance to the centre
    passing = (closest - 0.5) / (footprint * -b)  # by how many footprints it misses the surface
    near = (passing > 2 * HIT_FRACTION) & (passing < 0.1)
    assert int(near.sum()) > 20  # rays the old tolerance of a tenth of a footprint called hits
    assert not bool(hit[passing > 2 * HIT_FRACTION].any())
    assert bool(hit[passing < -0.05].all())


def dust_field(count: int = 40, radius: float = 0.004) -> ImplicitSurface:
    """``count`` spheres of ``radius`` (a pixel or two at 128 pixels) scattered in a ball: thin
    parts a coarse tile's cone could step over."""
    centres = torch.from_numpy(np.random.default_rng(11).uniform(-0.35, 0.35, (count, 3))).float()
    return ImplicitSurface(sdf=lambda p: (p[:, None, :] - centres).norm(dim=-1).amin(dim=1) - radius, material=None,
                           lo=torch.full((3,), -0.5), hi=torch.full((3,), 0.5), text="dust")


@pytest.mark.parametrize("field", [sphere_field(0.5), box_field(), dust_field()], ids=["sphere", "box", "dust"])
def test_the_cones_skip_empty_space_and_never_a_surface(field):
    """Rays started past their tiles' cones find the hits the plain march finds, at the same
    distances, and no cone carries a ray past its hit; the cones spare evaluations."""
    camera = random_views(torch.zeros(3), 0.6, 3, np.random.default_rng(5))
    size = 128
    grid = [x.reshape(3, size, size, *x.shape[2:]) for x in primary_rays(camera, size, size)]
    origins, directions, footprint = (x.reshape(-1, *x.shape[3:]) for x in grid)
    counted = []

    def distance(points):
        counted.append(points.shape[0])
        return field.distance(points)
    t, hit = sphere_trace(distance, origins, directions, footprint, field.lo, field.hi)
    plain = sum(counted)
    counted.clear()
    start, far = (x.flatten() for x in cone_starts(distance, *grid, field.lo, field.hi))
    cone_t, cone_hit = sphere_trace(distance, origins, directions, footprint, field.lo, field.hi, (start, far))
    assert int(hit.sum()) > 50
    assert bool((start[hit] <= t[hit]).all())
    assert int((hit != cone_hit).sum()) <= 2  # a ray grazing a surface at the hit fraction may go either way
    both = hit & cone_hit
    assert float(((cone_t - t)[both].abs() / (footprint * t)[both]).max()) <= 2 * HIT_FRACTION
    assert sum(counted) < 0.6 * plain


def test_the_tracer_finds_a_box_within_a_fraction_of_a_pixel_with_its_face_normals():
    half = torch.tensor([0.4, 0.25, 0.3])
    field = box_field(tuple(half.tolist()))
    origins, directions, footprint, t, hit = traced(field)
    assert int(hit.sum()) > 1000
    points = origins[hit] + t[hit, None] * directions[hit]
    error = field.distance(points).abs() / (footprint[hit] * t[hit])  # in pixels
    assert float(error.max()) <= HIT_FRACTION * 1.1  # every hit within the fraction (and float rounding)
    q = points.abs() / half
    axis = q.argmax(dim=-1)
    clear = (q.topk(2, dim=-1).values[:, 0] - q.topk(2, dim=-1).values[:, 1]) > 0.02  # away from edges
    expected = torch.nn.functional.one_hot(axis, 3).float() * points.sign()
    normals = field_normals(field, points)
    assert float((normals[clear] * expected[clear]).sum(-1).min()) > 0.9999


@needs_gl
def test_the_python_and_glsl_renderers_of_one_field_agree(tmp_path):
    python, glsl = write_fields(tmp_path)
    from_python, from_glsl = io.load(python), io.load(glsl)
    assert from_glsl.field.kind == "glsl" and from_python.field.kind == "python"
    centre, radius = from_python.mesh.bounding_sphere()
    camera = random_views(centre, radius, 4, np.random.default_rng(2))
    light = random_lights(camera, centre, np.random.default_rng(3))
    images = [FieldReference(a.field, (centre, radius)).render(camera, light, 128, 2) for a in (from_python, from_glsl)]
    assert float(images[0][..., 3].mean()) > 0.1
    assert psnr(images[0], images[1]) > 40.0


def test_marching_cubes_and_decimation_of_a_sphere_is_watertight_with_its_volume():
    mesh = decimate(field_mesh(sphere_field(0.5), 48), 500)
    faces = mesh.t_pos_idx
    edges = torch.cat([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    # watertight and consistently oriented: every directed edge once, and its reverse once
    directed = set(map(tuple, edges.tolist()))
    assert len(directed) == edges.shape[0] and all((b, a) in directed for a, b in directed)
    v = mesh.v_pos[faces].double()
    volume = float((torch.linalg.cross(v[:, 0], v[:, 1]) * v[:, 2]).sum() / 6)
    assert volume == pytest.approx(sphere_volume(0.5), rel=0.02)


def corner_spread_degrees(mesh) -> torch.Tensor:
    """``[T]`` the largest angle between two corners' shading normals of each triangle."""
    v_nrm, t_nrm_idx = mesh.normals()
    corner = torch.nn.functional.normalize(v_nrm[t_nrm_idx], dim=-1)
    return torch.rad2deg(torch.arccos((corner * corner.roll(1, dims=1)).sum(-1).amin(dim=1).clamp(-1, 1)))


def test_marching_cubes_shades_a_crease_as_sharp_as_the_field_and_a_smooth_surface_smooth():
    """Across the box's edges, where marching cubes rounds the crease within a cube, no triangle
    interpolates between the faces' normals (its corners share one face's); the sphere keeps a
    normal per vertex."""
    box = field_mesh(box_field((0.41, 0.263, 0.307)), 24)
    v_nrm, t_nrm_idx = box.normals()
    assert corner_spread_degrees(box).max() < 1.0
    assert (v_nrm[t_nrm_idx].abs().amax(dim=-1) > np.cos(np.radians(1.0))).all()          # a face's normal
    assert t_nrm_idx.unique().numel() > box.num_vertices                                 # the creases' own slots
    sphere = field_mesh(sphere_field(0.5), 24)
    assert torch.equal(sphere.t_nrm_idx, sphere.t_pos_idx) and corner_spread_degrees(sphere).max() < 15.0


@pytest.mark.parametrize("field", [sphere_field(0.5), box_field()], ids=["sphere", "box"])
def test_a_field_evaluated_near_its_surface_only_gives_the_mesh_of_the_whole_grid(field):
    axes, h = grid_axes(field.lo, field.hi, 64, 4)
    banded = narrow_band_values(field, axes, h, 4)
    every = field.distance(axes_points(axes)).reshape(banded.shape).numpy()
    near = np.abs(every) < 2 * h
    assert np.array_equal(banded[near], every[near]) and np.array_equal(banded > 0, every > 0)
    assert (banded != every).mean() > 0.3  # most of the box was interpolated, not evaluated
    vertices = [np.unique(m.v_pos.numpy().round(6), axis=0) for m in (field_mesh(field, 64, 4), field_mesh(field, 64))]
    assert vertices[0].shape == vertices[1].shape and np.allclose(*vertices, atol=1e-6)


def test_the_field_bake_reads_the_field_on_its_surface_not_the_mesh(tmp_path):
    python, _ = write_fields(tmp_path)
    asset = io.load(python)
    triangle = torch.arange(0, asset.mesh.num_triangles, 97)
    bary = torch.full((triangle.shape[0], 3), 1.0 / 3.0)
    values = FieldSurface(asset).sample(triangle, bary, torch.zeros(triangle.shape[0]))
    corners = asset.mesh.v_pos[asset.mesh.t_pos_idx[triangle]].mean(dim=1)
    # the sampled points lie on the surface: the field's own normal and colour there
    assert float(asset.field.distance(corners).abs().max()) > 1e-4
    assert values.kd.shape == (triangle.shape[0], 4) and float(values.ks[:, 1].min()) >= 0.3 - 1e-6
    assert float(values.normal.norm(dim=-1).sub(1).abs().max()) < 1e-5


@pytest.mark.parametrize("source, words", [
    ("bounds = ((-1, -1, -1), (1, 1, 1))\ndef sdf(p):\n    return p.norm(dim=-1) + 1.0\n", "positive everywhere"),
    ("bounds = ((-1, -1, -1), (1, 1, 1))\ndef sdf(p):\n    return p.norm(dim=-1) - 3.0\n", "negative everywhere"),
    ("bounds = ((-1, -1, -1), (1, 1, 1))\ndef sdf(p):\n    return p.norm(dim=-1) - 1.5\n", "cut the surface"),
    ("bounds = ((-1, -1, -1), (1, 1, 1))\ndef sdf(p):\n    return (p.norm(dim=-1) - 0.5) / 0.0 * 0.0\n", "is nan at"),
    ("def sdf(p):\n    return p.norm(dim=-1) - 0.5\n", "defines no bounds"),
    ("bounds = ((1, -1, -1), (-1, 1, 1))\ndef sdf(p):\n    return p.norm(dim=-1) - 0.5\n", "minimum below"),
    ("bounds = ((-1, -1, -1), (1, 1, 1))\n", "defines no function sdf"),
    ("bounds = ((-1, -1, -1), (1, 1, 1))\ndef sdf(p):\n    return p.norm() - 0.5\n", "[N]"),
])
def test_a_bad_python_field_gets_one_line_naming_the_file(tmp_path, source, words):
    path = tmp_path / "bad.py"
    path.write_text(source)
    with pytest.raises(AssetError) as caught:
        io.load(path)
    assert str(path) in str(caught.value) and words in str(caught.value)


def test_an_error_in_the_users_python_is_reported_at_their_line(tmp_path, capsys):
    path = tmp_path / "field.py"
    path.write_text("import torch\nbounds = ((-1, -1, -1), (1, 1, 1))\n\ndef sdf(p):\n"
                    "    scale = {}['size']\n    return p.norm(dim=-1) - scale\n")
    with pytest.raises(UserCodeError) as caught:
        io.load(path)
    assert str(caught.value) == f"{path}, line 5, in sdf: KeyError: 'size'"
    path.write_text("import torch\nbounds = (\n")
    with pytest.raises(UserCodeError, match=r"line 2.*SyntaxError"):
        io.load(path)
    assert main(["simplify", str(path), "-o", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "error in your code" in err[0] and "field.py, line 2" in err[0]
    assert not (tmp_path / "out").exists()


@needs_gl
def test_a_glsl_field_that_does_not_compile_is_reported_at_its_line(tmp_path):
    path = tmp_path / "field.glsl"
    path.write_text("// bounds: -1 -1 -1 1 1 1\n\nfloat map(vec3 p) {\n    float r = length(p)\n"
                    "    return r - 0.5;\n}\n")
    with pytest.raises(UserCodeError) as caught:
        io.load(path)
    assert f"{path}, line 5: GLSL:" in str(caught.value)
    path.write_text("float map(vec3 p) { return length(p) - 0.5; }\n")
    with pytest.raises(AssetError, match="bounds"):
        io.load(path)


def test_the_fingerprint_follows_the_fields_source(tmp_path):
    python, _ = write_fields(tmp_path)
    first = io.load(python)
    python.write_text(python.read_text().replace("0.5\n", "0.5  # the same field\n"))
    second = io.load(python)
    assert torch.equal(first.mesh.v_pos, second.mesh.v_pos) and first.fingerprint() != second.fingerprint()


def test_the_settings_know_a_field_by_the_suffixes_its_readers_take(tmp_path):
    from lookalike.io.registry import readable_extensions
    from lookalike.settings import FIELD_SUFFIXES
    python, glsl = write_fields(tmp_path)
    assert {python.suffix, glsl.suffix} == set(FIELD_SUFFIXES) and set(FIELD_SUFFIXES) <= set(readable_extensions())
    assert io.load(python).field is not None


@pytest.mark.slow
def test_a_short_run_on_a_field_beats_marching_cubes_then_decimation(tmp_path):
    """It is offered the start on smooth normals beside the usual one, and whichever it takes,
    its model is written with normals split at every crease."""
    from lookalike.jobs.simplify import simplify
    from lookalike.settings import config_from_dict
    python, _ = write_fields(tmp_path)
    tiny = {"views": {"pool_size": 16, "heldout": 8, "batch_size": 2}, "render": {"resolution": 96},
            "latent": {"texture_size": 64}, "optim": {"checkpoint_seconds": 1e9}}
    result = simplify(python, tmp_path / "out", triangles=200, iterations=40, config=config_from_dict(tiny),
                      progress=False)
    heldout = result.metrics["heldout"]
    assert heldout["ours"]["psnr"] > heldout["decimated"]["psnr"] + 1.0
    assert "the classic bake on smooth normals" in result.report.read_text()
    written = io.load(result.model).mesh
    slots = written.normals()[1]
    split = split_at_both(slots, crease_normal_index(written.v_pos, written.t_pos_idx))
    assert len(split.unique()) == len(slots.unique())  # split at every crease already


def test_a_field_runs_candidates_are_scored_as_the_file_holds_them(tmp_path):
    """The fit, the field baked again onto it and the model without its normal map compete on
    the validation views each in the form the file holds (``FieldInput.written``: normals split
    at creases and where planes meet), so the score the run records for the model it kept is
    that of its ``model.glb``. Bound: within 0.05 dB (8-bit texels); a candidate scored on its
    smooth normals misses it by tenths of a dB."""
    from lookalike.fit.training_views import view_sampler
    from lookalike.jobs.reference_kinds import run_reference
    from lookalike.jobs.run import scoring_draw, validation_flip_share
    from lookalike.jobs.simplify import simplify
    from lookalike.report.heldout import HeldoutViews
    from lookalike.settings import config_from_dict, load_config

    python, _ = write_fields(tmp_path)
    tiny = {"views": {"pool_size": 8, "heldout": 2, "validation": 4, "batch_size": 2}, "render": {"resolution": 64},
            "latent": {"texture_size": 64}, "optim": {"checkpoint_seconds": 1e9}}
    result = simplify(python, tmp_path / "out", triangles=200, iterations=10, config=config_from_dict(tiny),
                      progress=False)
    cfg = load_config(tmp_path / "out" / "config.toml")
    field = run_reference(io.load(python), cfg, moving=False)
    views = HeldoutViews(field.renderer, view_sampler(*field.renderer.bounding_sphere()), cfg.views.validation,
                         cfg.views.validation_seed, cfg.render.resolution, cfg.render.target_spp)
    validation = result.metrics["validation"]
    recorded = validation["written"][validation["written_model"]]
    score = views.validation_score(io.load(result.model), scoring_draw(cfg), validation_flip_share(cfg))
    assert score == pytest.approx(recorded, abs=0.05), (validation["written_model"], validation["written"])


def test_the_sphere_start_is_a_sphere_of_the_count_and_its_laplacian_is_absolute():
    from lookalike.fit.textured_mesh import TexturedMesh
    from lookalike.init.sphere_start import tessellated_sphere
    from lookalike.init.unwrap import unwrap

    centre = torch.tensor([0.1, 0.2, 0.3])
    sphere = tessellated_sphere(centre, 2.0, 500)
    assert 450 <= sphere.num_triangles <= 500
    assert float((sphere.v_pos - centre).norm(dim=-1).sub(2.0).abs().max()) < 0.05
    mesh = unwrap(sphere, texture_size=32)
    textures = (torch.full((4, 4, 3), 0.5), torch.full((4, 4, 3), 0.5), torch.tensor([0.0, 0.0, 1.0]).expand(4, 4, 3))
    relative, absolute = (TexturedMesh(mesh, *textures, centre, 2.0, absolute_laplacian=a) for a in (False, True))
    assert float(relative.regularizers()["laplacian"].detach()) == 0.0
    assert float(absolute.regularizers()["laplacian"].detach()) > 0.0


@pytest.mark.slow
def test_a_run_from_a_sphere_moves_towards_the_field(tmp_path):
    from lookalike.jobs.simplify import simplify
    from lookalike.settings import config_from_dict
    python, _ = write_fields(tmp_path)
    tiny = {"views": {"pool_size": 16, "heldout": 8, "batch_size": 2, "validation": 0}, "render": {"resolution": 64},
            "latent": {"texture_size": 32}, "optim": {"checkpoint_seconds": 1e9}}
    result = simplify(python, tmp_path / "out", triangles=320, iterations=100, init="sphere",
                      config=config_from_dict(tiny), progress=False)
    model = io.load(result.model)
    field = io.load(python).field
    fitted_error = float(field.distance(model.mesh.v_pos).abs().mean())
    centre, radius = io.load(python).mesh.bounding_sphere()
    sphere_error = float(field.distance(centre + radius * torch.nn.functional.normalize(model.mesh.v_pos - centre, dim=-1))
                         .abs().mean())
    assert fitted_error < 0.6 * sphere_error


def test_a_lod_chain_takes_a_field(tmp_path):
    from lookalike.jobs.lod import LEVEL, Level, lod
    from lookalike.settings import config_from_dict
    python, glsl = write_fields(tmp_path)
    config = config_from_dict({"views": {"pool_size": 2, "heldout": 2, "batch_size": 1, "validation": 0},
                               "latent": {"texture_size": 32}, "optim": {"iterations": 2, "checkpoint_seconds": 1e9}},
                              base=LEVEL.defaults)
    rows = lod(glsl if gl_available() else python, tmp_path / "chain", [Level(200, 32)], config=config,
               progress=False)
    assert abs(rows[0]["triangles"] - 200) <= 2 and (tmp_path / "chain" / "lods.glb").is_file() and rows[0]["psnr"] > 10.0


def painted_sphere(folder, roughness: str, metallic: str):
    """A sphere field of grey base colour and the ``roughness`` and ``metallic`` expressions of
    ``p [N, 3]`` (``up``: its upper half), loaded."""
    path = folder / "painted.py"
    path.write_text("import torch\nbounds = ((-1, -1, -1), (1, 1, 1))\ndef sdf(p):\n    return p.norm(dim=-1) - 0.6\n"
                    "def material(p):\n    up = p[:, 1] > 0\n    return {'base_color': torch.ones(p.shape[0], 3) * 0.5,\n"
                    f"            'roughness': {roughness}, 'metallic': {metallic}}}\n")
    return io.load(path)


def test_the_fields_mesh_carries_its_roughness_and_metalness_as_a_palette(tmp_path):
    asset = painted_sphere(tmp_path, "torch.where(up, 0.3, 0.7)", "torch.where(up, 1.0, 0.0)")
    values = torch.tensor(sorted(m.ks.data.reshape(-1).tolist() for m in asset.materials))
    assert torch.equal(values, torch.tensor([[0.0, 0.3, 1.0], [0.0, 0.7, 0.0]]))  # the field's own: not 19/64
    metalness = torch.tensor([float(m.ks.data.reshape(-1)[2]) for m in asset.materials])
    for mesh in (asset.mesh, finer_field_mesh(asset, 200, 8)):          # the start's mesh shares the palette
        centroid_y = mesh.v_pos[mesh.t_pos_idx].mean(dim=1)[:, 1]
        metal = metalness[mesh.t_mat_idx]
        assert bool((metal[centroid_y > 0.05] == 1.0).all()) and bool((metal[centroid_y < -0.05] == 0.0).all())


def test_a_field_of_graded_roughness_gets_a_palette_of_at_most_its_limit(tmp_path):
    asset = painted_sphere(tmp_path, "0.5 + 0.4 * p[:, 0]", "0.5 + 0.5 * p[:, 1]")
    assert 4 < len(asset.materials) <= PALETTE_LIMIT
    _, ks = asset.field.channels(asset.mesh.v_pos[asset.mesh.t_pos_idx].mean(dim=1))
    palette = torch.stack([m.ks.data.reshape(-1)[1:] for m in asset.materials])
    assert (palette[asset.mesh.t_mat_idx] - ks[:, 1:]).abs().max() < 0.13  # rounded to 1/8 at the coarsest


CONSTANT_MATERIAL_FIELD = '''
import torch

bounds = ((-0.7, -0.7, -0.7), (0.7, 0.7, 0.7))


def sdf(p):
    """A box with rounded edges."""
    q = p.abs() - torch.tensor([0.4, 0.3, 0.25])
    return q.clamp(min=0).norm(dim=-1) + q.max(dim=-1).values.clamp(max=0) - 0.1


def material(p):
    n = p.shape[0]
    return {"base_color": torch.tensor([0.6, 0.3, 0.1]).expand(n, 3), "roughness": torch.full((n,), 0.35),
            "metallic": torch.ones(n)}
'''

FLAT_MAP_STD = 1e-4
"""Most standard deviation of a flat map over the texels its triangles cover: one texel in the
1,024 of a 32 x 32 map one 8-bit step (1/255) off has about 1.2e-4, so this allows no grain at
all, only float rounding."""


def map_grain(texture: torch.Tensor, mesh, size: int) -> float:
    """The largest standard deviation over channels of ``texture [h, w, C]`` (resampled, nearest,
    to ``size`` x ``size``: a constant may be one texel) over the texels ``mesh``'s triangles
    cover in UV set 0."""
    from io_factory import covered_texels

    resized = torch.nn.functional.interpolate(texture.float().permute(2, 0, 1)[None], size=(size, size),
                                              mode="nearest")[0].permute(1, 2, 0)
    return float(resized[covered_texels(mesh, 0, size, size)].std(dim=0).max())


@pytest.mark.slow
def test_a_field_whose_material_is_constant_gets_flat_maps(tmp_path):
    """The start bakes the field's one material, and the fit keeps it one value
    (``fit.textured_mesh.constant_channels``): grain the fit paints into base colour or
    specular shows as perceptual error on a plain material."""
    from lookalike.jobs.simplify import simplify
    from lookalike.settings import config_from_dict

    path = tmp_path / "plain.py"
    path.write_text(CONSTANT_MATERIAL_FIELD)
    size = 32
    tiny = {"views": {"pool_size": 2, "heldout": 1, "batch_size": 1, "validation": 0}, "render": {"resolution": 48},
            "latent": {"texture_size": size}, "optim": {"checkpoint_seconds": 1e9}}
    result = simplify(path, tmp_path / "out", triangles=300, iterations=10, config=config_from_dict(tiny),
                      progress=False)
    for model in (result.baselines["baked"], io.load(result.model)):
        material = model.materials[0]
        assert map_grain(material.kd.data[..., :3], model.mesh, size) < FLAT_MAP_STD
        assert map_grain(material.ks.data, model.mesh, size) < FLAT_MAP_STD
        kd, ks = material.kd.data.reshape(-1, 4)[0], material.ks.data.reshape(-1, 3)[0]
        assert kd[:3].tolist() == pytest.approx([0.6, 0.3, 0.1], abs=0.01)     # 8-bit sRGB steps
        assert ks[1:].tolist() == pytest.approx([0.35, 1.0], abs=0.005)


EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SHELL = 0.02
SLOPE_LIMIT = 1.05
"""Most slope accepted of an example field: 1 and the few percent that the bundled rook's smooth
unions reach near its surface."""


def bounds_faces(lo: torch.Tensor, hi: torch.Tensor, steps: int) -> torch.Tensor:
    """``[6 steps², 3]`` points on a grid of ``steps × steps`` on each face of the box ``lo``-``hi``."""
    grid = torch.cartesian_prod(*[torch.linspace(0.0, 1.0, steps)] * 2)
    side = [torch.full((grid.shape[0], 1), t) for t in (0.0, 1.0)]
    return torch.cat([lo + (hi - lo) * torch.cat([grid[:, :axis], s, grid[:, axis:]], dim=1)
                      for axis in range(3) for s in side])


@pytest.mark.parametrize("name, file", FIELDS)
def test_every_example_field_has_a_surface_that_traces_and_its_distances_are_a_bound(name, file):
    """Each field of ``examples/`` (the bench's, ``bench.implicit.FIELDS``) meshes, sphere-traces
    and is about 1-Lipschitz outside its solid and in a shell ``SHELL`` deep inside it (so it
    does not exceed the true distance there; deeper inside, a cut may jump), its material finite;
    its bounds hold the whole surface (positive on a fine grid over their faces: the judge's
    960-cube mesh finds a cut that 160 cubes miss)."""
    from lookalike.fit.reference import FieldReference
    from lookalike.fit.training_views import view_sampler
    from lookalike.io.field_glsl import load_glsl_field
    from lookalike.io.field_python import load_python_field

    path = EXAMPLES / file
    if path.suffix == ".glsl" and not gl_available():
        pytest.skip("no headless OpenGL")
    surface = (load_glsl_field if path.suffix == ".glsl" else load_python_field)(path)
    mesh = field_mesh(surface, 40)
    assert mesh.num_triangles > 1000
    centre, radius = mesh.bounding_sphere()
    views = view_sampler(centre, radius)(np.random.default_rng(1), 2)
    coverage = FieldReference(surface, (centre, radius)).render(views.camera, views.light, 32, 1)[..., 3]
    assert float(coverage.mean(dim=(1, 2)).min()) > 0.05
    generator = torch.Generator().manual_seed(0)
    a = surface.lo + (surface.hi - surface.lo) * torch.rand(8192, 3, generator=generator)
    b = a + 0.01 * torch.nn.functional.normalize(torch.randn(8192, 3, generator=generator), dim=-1)
    fa, fb = surface.distance(a), surface.distance(b)
    outside = (fa > -SHELL) & (fb > -SHELL)                # where tracing and the bake's projection step by it
    slope = (fa - fb).abs() / (a - b).norm(dim=-1)
    assert int(outside.sum()) > 1000 and float(slope[outside].max()) <= SLOPE_LIMIT
    on_bounds = bounds_faces(surface.lo, surface.hi, 256)
    assert float(surface.distance(on_bounds).min()) > 0.0, "the bounds cut the surface"
    kd, ks = surface.channels(mesh.v_pos)
    assert bool(torch.isfinite(kd).all() and torch.isfinite(ks).all())


def test_a_python_fields_pool_is_refreshed_as_its_tracing_costs(tmp_path):
    """Sphere tracing a Python field costs many times what drawing its marching-cubes mesh does:
    its pool is refreshed every 16 steps, the mesh's every 2 (the defaults)."""
    import dataclasses

    from lookalike.jobs.reference_kinds import run_reference
    from lookalike.settings import Config, refresh_interval
    python, _ = write_fields(tmp_path)
    field = io.load(python)
    mesh = dataclasses.replace(field, field=None)
    cfg = Config()
    assert [refresh_interval(cfg, run_reference(asset, cfg, False).drawn_triangles(asset))
            for asset in (field, mesh)] == [16, 2]


def test_the_fields_bake_onto_a_fitted_mesh_fits_its_frames_where_the_fitted_maps_do_not(tmp_path):
    """A fit's steps turn the vertices' shading frames under a normal map made for the old ones;
    the field baked again onto the moved mesh (``FieldInput.alternatives``) keeps the moved
    geometry and shades it as the field does. Bound: its PSNR above the old maps' by a quarter of
    the loss the step costs them (it recovers 42 %; the rest is the step's geometry), and its
    FLIP lower."""
    import dataclasses

    from lookalike.asset.material import Displacement, Texture
    from lookalike.fit.training_views import view_sampler
    from lookalike.init.initial_guess import Ranges, initial_guess
    from lookalike.jobs.reference_kinds import REBAKED, WITHOUT_NORMAL_MAP, run_reference
    from lookalike.jobs.run import scoring_draw
    from lookalike.report.heldout import HeldoutViews
    from lookalike.report.metrics import flip
    from lookalike.settings import config_from_dict

    python, _ = write_fields(tmp_path)
    asset = io.load(python)
    cfg = config_from_dict({"latent": {"texture_size": 128}, "render": {"resolution": 96}})
    field = run_reference(asset, cfg, moving=False)
    start = initial_guess(asset, decimate(asset.mesh, 400), "bake", 128, Ranges(),
                          np.random.default_rng(0)).start
    p = start.mesh.v_pos                        # a step of every vertex of 0.5 % of the size, its slope 9°
    step = torch.stack([torch.sin(40 * p[:, 1]), torch.sin(40 * p[:, 2]), torch.sin(40 * p[:, 0])], dim=1)
    moved = dataclasses.replace(start, mesh=dataclasses.replace(start.mesh, v_pos=p + 0.004 * step))
    offered = field.alternatives(moved)
    rebaked, bare = offered[REBAKED], offered[WITHOUT_NORMAL_MAP]
    assert all(m.normal is None for m in bare.materials) and torch.equal(bare.mesh.v_pos, moved.mesh.v_pos)
    assert torch.equal(rebaked.mesh.v_pos, moved.mesh.v_pos) and torch.equal(rebaked.mesh.t_pos_idx, moved.mesh.t_pos_idx)
    assert torch.equal(rebaked.mesh.uv[0][0], moved.mesh.uv[0][0])
    views = HeldoutViews(field.renderer, view_sampler(*field.renderer.bounding_sphere()), 6, 3, 96, 2)
    draw = scoring_draw(cfg)
    scores = {}
    for name, model in (("start", start), ("moved", moved), ("rebaked", rebaked)):
        images = views.images(model, draw)
        scores[name] = (psnr(views.reference, images), flip(views.reference, images))
    assert scores["moved"][0] < scores["start"][0] - 1.0, scores         # the step costs the old maps
    assert scores["rebaked"][0] > scores["moved"][0] + 0.25 * (scores["start"][0] - scores["moved"][0]), scores
    assert scores["rebaked"][1] < scores["moved"][1], scores
    displaced = dataclasses.replace(moved, materials=[dataclasses.replace(
        moved.materials[0], displacement=Displacement(Texture(torch.zeros(8, 8, 1)), 0.01))])
    assert REBAKED not in field.alternatives(displaced)                  # a bake makes no displacement
