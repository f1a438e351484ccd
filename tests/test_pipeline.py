"""The deferred pipeline on scenes with known answers, and its camera and light helpers."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from lookalike.asset import Asset, Material, Mesh, Texture
from lookalike.shading import Camera, PointLight, look_at, perspective, render
from lookalike.shading.pipeline import box_downsample, render_coverage
from lookalike.shading.texturing import TextureSampler
from mesh_factory import icosphere

NO_SPECULAR = [1.0, 0.5, 0.0]  # gamma = 1 removes the specular lobe


def quad(z: float = 0.0, size: float = 1.0, material: int = 0) -> Mesh:
    """A square of half-size ``size`` in the plane ``z``, facing +z, UVs with (0, 0) top-left."""
    v_pos = torch.tensor([[-1.0, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]) * size + torch.tensor([0, 0, z])
    t_pos_idx = torch.tensor([[0, 1, 2], [0, 2, 3]])
    v_tex = torch.tensor([[0.0, 1], [1, 1], [1, 0], [0, 0]])
    return Mesh(v_pos=v_pos, t_pos_idx=t_pos_idx, uv=[(v_tex, t_pos_idx.clone())],
                t_mat_idx=torch.full((2,), material))


def merge(meshes: list[Mesh]) -> Mesh:
    offsets = torch.cumsum(torch.tensor([0] + [m.num_vertices for m in meshes[:-1]]), 0)
    return Mesh(
        v_pos=torch.cat([m.v_pos for m in meshes]),
        t_pos_idx=torch.cat([m.t_pos_idx + o for m, o in zip(meshes, offsets)]),
        uv=[(torch.cat([m.uv[0][0] for m in meshes]), torch.cat([m.uv[0][1] + o for m, o in zip(meshes, offsets)]))],
        t_mat_idx=torch.cat([m.t_mat_idx for m in meshes]),
    )


def uv_sphere(radius: float = 1.0, rings: int = 48, segments: int = 96) -> Mesh:
    """A UV sphere (poles on +-y), counter-clockwise seen from outside, u around, v down."""
    theta = torch.linspace(0, math.pi, rings + 1)
    phi = torch.linspace(0, 2 * math.pi, segments + 1)
    t, p = torch.meshgrid(theta, phi, indexing="ij")
    v_pos = radius * torch.stack([torch.sin(t) * torch.sin(p), torch.cos(t), torch.sin(t) * torch.cos(p)], -1)
    v_tex = torch.stack([p / (2 * math.pi), t / math.pi], -1)
    idx = torch.arange((rings + 1) * (segments + 1)).reshape(rings + 1, segments + 1)
    a, b = idx[:-1, :-1].reshape(-1), idx[:-1, 1:].reshape(-1)
    c, d = idx[1:, :-1].reshape(-1), idx[1:, 1:].reshape(-1)
    tris = torch.cat([torch.stack([a, c, d], 1), torch.stack([a, d, b], 1)])
    return Mesh(v_pos=v_pos.reshape(-1, 3), t_pos_idx=tris, uv=[(v_tex.reshape(-1, 2), tris.clone())])


def front_camera(distance: float = 3.0, fovy: float = math.radians(60), batch: int = 1) -> Camera:
    eye = torch.tensor([[0.0, 0.0, distance]]).expand(batch, 3)
    return Camera.looking_at(eye, torch.zeros(batch, 3), fovy=fovy, near=0.5, far=20.0)


def light_at(position, intensity: float = 1.0) -> PointLight:
    return PointLight(torch.tensor([position], dtype=torch.float32), torch.full((1, 3), intensity))


def emissive_material(rgb, alpha: float, mode: str) -> Material:
    """A material whose colour is its emission (black, no specular), with alpha."""
    return Material(kd=Texture.constant([0.0, 0.0, 0.0, alpha]), ks=Texture.constant(NO_SPECULAR),
                    emissive=Texture.constant(rgb), alpha_mode=mode, double_sided=True)


@pytest.mark.parametrize("factor", [1, 2, 3])
def test_box_downsample_averages_blocks(factor):
    image = torch.rand(2, 3 * factor, 2 * factor, 4, dtype=torch.float64, requires_grad=True)
    expected = torch.stack([torch.stack([image[:, r * factor:(r + 1) * factor, c * factor:(c + 1) * factor].mean(dim=(1, 2))
                                         for c in range(2)], 1) for r in range(3)], 1)
    torch.testing.assert_close(box_downsample(image, factor), expected)
    weights = torch.rand(2, 3, 2, 4, dtype=torch.float64)
    grad, = torch.autograd.grad((box_downsample(image, factor) * weights).sum(), image)
    torch.testing.assert_close(grad, weights.repeat_interleave(factor, 1).repeat_interleave(factor, 2) / factor**2)


def test_look_at_and_perspective():
    eye = torch.tensor([[1.0, 2.0, 3.0]])
    mv = look_at(eye, torch.zeros(1, 3), [0.0, 1.0, 0.0])
    assert torch.allclose(mv[0, :3, :3] @ mv[0, :3, :3].T, torch.eye(3), atol=1e-6)
    assert torch.allclose(mv[0] @ torch.tensor([1.0, 2, 3, 1]), torch.tensor([0.0, 0, 0, 1]), atol=1e-6)
    target_view = mv[0] @ torch.tensor([0.0, 0, 0, 1])
    assert torch.allclose(target_view[:3], torch.tensor([0.0, 0, -math.sqrt(14)]), atol=1e-5)
    up_view = mv[0, :3, :3] @ torch.tensor([0.0, 1.0, 0.0])
    assert up_view[1] > 0 and abs(up_view[0]) < 1e-6  # world up stays up in the picture
    # Looking straight down the up vector still gives a valid rotation.
    straight = look_at(torch.tensor([[0.0, 5.0, 0.0]]), torch.zeros(1, 3), [0.0, 1.0, 0.0])
    assert torch.isfinite(straight).all()
    assert torch.allclose(straight[0, :3, :3] @ straight[0, :3, :3].T, torch.eye(3), atol=1e-6)
    proj = perspective(math.radians(90), 2.0, 1.0, 10.0)
    for depth, ndc in ((1.0, -1.0), (10.0, 1.0)):
        clip = proj @ torch.tensor([0.0, 0.0, -depth, 1.0])
        assert math.isclose(clip[2] / clip[3], ndc, abs_tol=1e-6)
    clip = proj @ torch.tensor([2.0, 1.0, -1.0, 1.0])  # 45 degrees up, aspect 2: the corner
    assert torch.allclose(clip[:2] / clip[3], torch.tensor([1.0, 1.0]))


def test_point_light_falloff():
    light = PointLight(torch.tensor([[0.0, 0, 2], [0, 0, 4]]), torch.tensor([[4.0, 4, 4], [8, 8, 8]]))
    direction, irradiance = light.illuminate(torch.zeros(2, 3), torch.tensor([0, 1]))
    assert torch.allclose(direction, torch.tensor([[0.0, 0, 1], [0, 0, 1]]))
    assert torch.allclose(irradiance[:, 0], torch.tensor([1.0, 0.5]))


def test_lambertian_quad_centre_has_analytic_radiance():
    albedo, intensity, distance = 0.6, 9.0, 3.0
    grey = Material(kd=Texture.constant([albedo, albedo, albedo, 1.0]), ks=Texture.constant(NO_SPECULAR))
    asset = Asset(quad(), [grey])
    image = render(asset, front_camera(distance), light_at([0.0, 0.0, distance], intensity), 33)
    expected = albedo / math.pi * intensity / distance ** 2
    assert torch.allclose(image[0, 16, 16], torch.tensor([expected, expected, expected, 1.0]), rtol=1e-4)
    assert image[0, 0, 0, 3] == 0  # corner: background, alpha 0
    # A metal with roughness r has radiance F0 * D * Vis * E = kd / (4 pi r^4) * E head-on.
    rough = 0.5
    metal = Asset(quad(), [Material(kd=Texture.constant([0.9, 0.5, 0.2, 1.0]), ks=Texture.constant([0.0, rough, 1.0]))])
    image = render(metal, front_camera(distance), light_at([0.0, 0.0, distance], intensity), 33)
    expected = torch.tensor([0.9, 0.5, 0.2]) / (4 * math.pi * rough ** 4) * intensity / distance ** 2
    assert torch.allclose(image[0, 16, 16, :3], expected, rtol=1e-3)


def test_orientation_row_zero_is_top_and_u_runs_right():
    texels = torch.zeros(2, 2, 4)
    texels[..., 3] = 1.0
    texels[0, :, 0] = 1.0  # top row of the image: red
    texels[:, 0, 2] = 1.0  # left column: blue
    material = Material(kd=Texture(texels, wrap="clamp"), ks=Texture.constant(NO_SPECULAR))
    image = render(Asset(quad(), [material]), front_camera(), light_at([0.0, 0.0, 3.0], 30.0), 32)
    top_left, bottom_right = image[0, 7, 7], image[0, 24, 24]  # texel centres are at 1/4, 3/4
    assert top_left[0] > 0.1 and top_left[2] > 0.1
    assert bottom_right[0] < 1e-3 and bottom_right[2] < 1e-3
    # The world's +y is the top of the picture: a quad above the axis covers the upper rows.
    upper = quad(size=0.5)
    upper.v_pos = upper.v_pos + torch.tensor([0.0, 0.8, 0.0])
    alpha = render(Asset(upper, [material]), front_camera(), light_at([0.0, 0.0, 3.0]), 32)[0, ..., 3]
    assert alpha[:16].sum() > 0 and alpha[16:].sum() == 0


def test_sphere_coverage_matches_projected_area():
    radius, distance, fovy = 1.0, 4.0, math.radians(40)
    asset = Asset(uv_sphere(radius), [Material()])
    alpha = render(asset, front_camera(distance, fovy), light_at([0.0, 0.0, distance]), 96, spp=2)[0, ..., 3]
    # The silhouette is a circle of angular radius asin(r / d); in NDC its radius is
    # tan(asin(r / d)) / tan(fovy / 2), and the NDC square has area 4.
    ndc_radius = math.tan(math.asin(radius / distance)) / math.tan(fovy / 2)
    expected = math.pi * ndc_radius ** 2 / 4
    assert abs(alpha.mean().item() - expected) < 0.01 * expected


@pytest.mark.parametrize("spp", [1, 2])
def test_coverage_alone_is_the_rendered_alpha(spp):
    asset = Asset(uv_sphere(1.0, 16, 32), [Material()])
    eye = torch.tensor([[0.0, 0.0, 3.0], [2.0, 1.0, 2.0]])
    camera = Camera.looking_at(eye, torch.zeros(2, 3), fovy=math.radians(50))
    alpha = render(asset, camera, PointLight(eye, torch.full((2, 3), 9.0)), 32, spp=spp, msaa=spp > 1)[..., 3]
    coverage = render_coverage(asset.mesh, camera, 32, spp)
    assert coverage.shape == (2, 32, 32)
    assert ((coverage > 0) & (coverage < 1)).any()              # antialiased outline pixels
    assert torch.allclose(coverage, alpha, atol=1e-5)


def _coverage_slope(mesh: Mesh) -> tuple[float, float]:
    """d/ds of the mean coverage of ``mesh`` scaled by s at s = 1, by autograd and by a central
    difference (the coverage grows with the projected area)."""
    camera = front_camera(4.0, math.radians(40))

    def mean_coverage(scale):
        return render_coverage(Mesh(v_pos=mesh.v_pos * scale, t_pos_idx=mesh.t_pos_idx), camera, 64, 2).mean()

    scale = torch.tensor(1.0, requires_grad=True)
    mean_coverage(scale).backward()
    step = 0.01
    numeric = (mean_coverage(torch.tensor(1 + step)) - mean_coverage(torch.tensor(1 - step))).item() / (2 * step)
    return scale.grad.item(), numeric


@pytest.mark.parametrize("level", [0, 2, 4])
def test_coverage_gradient_matches_finite_differences(level):
    """From 20 to 5,120 triangles: on the finer spheres the outline's triangles are slivers
    that no pixel centre shows, and antialias must still find their edges."""
    analytic, numeric = _coverage_slope(icosphere(level))
    assert numeric > 0 and abs(analytic - numeric) < 0.05 * numeric


def test_supersampling_reduces_edge_aliasing():
    tilted = quad(size=0.8)
    angle = math.radians(17)
    cos, sin = math.cos(angle), math.sin(angle)
    rotation = torch.tensor([[cos, -sin, 0], [sin, cos, 0], [0, 0, 1.0]])
    tilted.v_pos = tilted.v_pos @ rotation.T
    asset = Asset(tilted, [Material()])
    camera, light = front_camera(), light_at([0.0, 0.0, 3.0], 9.0)
    reference = render(asset, camera, light, 24, spp=12)[..., 3]
    errors = [(render(asset, camera, light, 24, spp=s)[..., 3] - reference).abs().mean().item() for s in (1, 4)]
    assert errors[1] < 0.5 * errors[0]


def test_depth_peeled_blended_quads_composite_back_to_front():
    front, back, background = [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], torch.tensor([0.0, 1.0, 0.0])
    a_front, a_back = 0.5, 0.6
    materials = [emissive_material(front, a_front, "BLEND"), emissive_material(back, a_back, "BLEND")]
    camera, light = front_camera(), light_at([0.0, 0.0, 3.0])
    expected_two = (a_front * torch.tensor(front)
                    + (1 - a_front) * (a_back * torch.tensor(back) + (1 - a_back) * background))
    expected_one = a_front * torch.tensor(front) + (1 - a_front) * background
    for order in ((0, 1), (1, 0)):  # triangle order must not matter
        meshes = [quad(0.0, 0.5, material=0), quad(-1.0, 0.5, material=1)]
        asset = Asset(merge([meshes[i] for i in order]), materials)
        two = render(asset, camera, light, 16, layers=2, background=background)
        assert torch.allclose(two[0, 8, 8, :3], expected_two, atol=1e-5)
        assert two[0, 8, 8, 3] == 1.0
        one = render(asset, camera, light, 16, layers=1, background=background)
        assert torch.allclose(one[0, 8, 8, :3], expected_one, atol=1e-5)
    # Without a background the alpha accumulates: 1 - (1 - a_front)(1 - a_back).
    alpha = render(asset, camera, light, 16, layers=4)[0, 8, 8, 3]
    assert math.isclose(alpha.item(), 1 - (1 - a_front) * (1 - a_back), rel_tol=1e-5)


def test_mask_alpha_mode_and_background_image_orientation():
    mask_low, mask_high = (emissive_material([1.0, 1.0, 1.0], 0.4, "MASK") for _ in range(2))
    mask_low.alpha_cutoff, mask_high.alpha_cutoff = 0.3, 0.5
    background = torch.zeros(1, 16, 16, 3)
    background[:, :8, :, 0] = 1.0  # top half red
    camera, light = front_camera(), light_at([0.0, 0.0, 3.0])
    kept = render(Asset(quad(size=0.5), [mask_low]), camera, light, 16, background=background)
    dropped = render(Asset(quad(size=0.5), [mask_high]), camera, light, 16, background=background)
    assert torch.allclose(kept[0, 8, 8, :3], torch.ones(3))
    assert torch.allclose(dropped[0, 8, 8, :3], torch.zeros(3))  # bottom half of the background
    assert torch.allclose(dropped[0, 7, 8, :3], torch.tensor([1.0, 0, 0]))


def test_back_faces_single_sided_culled_double_sided_flipped():
    behind = Camera.looking_at(torch.tensor([[0.0, 0.0, -3.0]]), torch.zeros(1, 3), fovy=math.radians(60))
    light = light_at([0.0, 0.0, -3.0], 9.0)
    single = Material(ks=Texture.constant(NO_SPECULAR))
    double = Material(ks=Texture.constant(NO_SPECULAR), double_sided=True)
    culled = render(Asset(quad(), [single]), behind, light, 16)
    assert culled[..., 3].max() == 0
    shown = render(Asset(quad(), [double]), behind, light, 16)
    lit = render(Asset(quad(), [double]), front_camera(), light_at([0.0, 0.0, 3.0], 9.0), 16)
    assert torch.allclose(shown[0, 8, 8], lit[0, 8, 8], rtol=1e-5)


def normal_mapped_sphere(normal: Texture | None) -> Asset:
    texels = torch.rand(16, 16, 4, generator=torch.Generator().manual_seed(3))
    texels[..., 3] = 1.0
    material = Material(kd=Texture(texels), ks=Texture.constant([0.0, 0.4, 0.2]), normal=normal)
    return Asset(uv_sphere(1.0, 24, 48), [material])


def test_flat_normal_map_renders_like_no_normal_map():
    camera, light = front_camera(), light_at([1.0, 2.0, 3.0], 12.0)
    plain = render(normal_mapped_sphere(None), camera, light, 48)
    flat = torch.tensor([0.0, 0.0, 1.0]).expand(8, 8, 3).clone()
    mapped = render(normal_mapped_sphere(Texture(flat)), camera, light, 48)
    assert torch.allclose(mapped, plain, atol=1e-5)
    tilted = torch.nn.functional.normalize(torch.tensor([0.5, 0.0, 1.0]), dim=0).expand(8, 8, 3).clone()
    bumped = render(normal_mapped_sphere(Texture(tilted)), camera, light, 48)
    assert (bumped - plain).abs().max() > 0.05  # a tilted map does change the picture


@pytest.mark.parametrize("axis", [0, 1], ids=["x-right", "y-up"])
def test_normal_map_tilts_along_tangent_and_bitangent(axis):
    """Tangent-space x tilts the normal towards +u (right in the image), y towards -v (up in
    the image): a light on that side brightens the quad, a light on the other side darkens it."""
    tilt = torch.tensor([0.0, 0.0, 1.0])
    tilt[axis] = 0.6
    maps = {"flat": None, "tilted": Texture(torch.nn.functional.normalize(tilt, dim=0).expand(4, 4, 3).clone())}
    camera = front_camera()
    side = [0.0, 0.0, 1.0]
    side[axis] = 3.0
    brightness = {}
    for name, normal in maps.items():
        material = Material(kd=Texture.constant([0.5, 0.5, 0.5, 1.0]), ks=Texture.constant(NO_SPECULAR), normal=normal)
        for sign in (1, -1):
            position = [sign * c if i == axis else c for i, c in enumerate(side)]
            image = render(Asset(quad(), [material]), camera, light_at(position, 9.0), 16)
            brightness[name, sign] = image[0, 8, 8, 0].item()
    assert brightness["tilted", 1] > 1.2 * brightness["flat", 1]
    assert brightness["tilted", -1] < 0.8 * brightness["flat", -1]


def test_vertex_colours_multiply_base_colour():
    mesh = quad()
    mesh.v_color = torch.tensor([[1.0, 0.0, 0.0, 1.0]]).expand(4, 4).clone()
    material = Material(kd=Texture.constant([0.5, 0.5, 0.5, 1.0]), ks=Texture.constant(NO_SPECULAR))
    centre = render(Asset(mesh, [material]), front_camera(), light_at([0.0, 0.0, 3.0], 9.0), 16)[0, 8, 8]
    assert centre[0] > 0.1 and centre[1] == 0 and centre[2] == 0


def _lookup(texture: Texture, uv: torch.Tensor, uv_da: torch.Tensor | None = None, **sampler) -> torch.Tensor:
    """``[N, C]`` values of one texture alone at ``uv [N, 2]`` (trilinear with ``uv_da [N, 4]``)."""
    return TextureSampler(**sampler).sample([texture], lambda _: (uv, uv_da), uv.shape[0])[0]


def test_texture_transform_and_stacked_lookups_match_single_lookups():
    """Stacking same-size textures into one lookup (the fast path) gives what separate
    lookups give; a KHR_texture_transform equals sampling at the transformed coordinates."""
    generator = torch.Generator().manual_seed(1)
    uv = torch.rand(50, 2, generator=generator) * 1.5 - 0.25
    uv_da = torch.rand(50, 4, generator=generator) * 0.05
    transform = torch.tensor([[0.5, 0.2, 0.1], [-0.1, 2.0, 0.3], [0.0, 0.0, 1.0]])
    textures = [Texture(torch.rand(16, 16, c, generator=generator), transform=transform, wrap=w)
                for c, w in ((4, "wrap"), (3, "wrap"), (3, "clamp"))]
    textures.append(Texture.constant([0.1, 0.2]))
    stacked = TextureSampler().sample(textures, lambda _: (uv, uv_da), 50)
    moved = uv @ transform[:2, :2].T + transform[:2, 2]
    moved_da = (transform[:2, :2] @ uv_da.reshape(-1, 2, 2)).reshape(-1, 4)
    for texture, values in zip(textures, stacked):
        plain = Texture(texture.data, wrap=texture.wrap)
        assert torch.allclose(values, _lookup(plain, moved, moved_da), atol=1e-6)
    assert torch.equal(stacked[3], torch.tensor([[0.1, 0.2]]).expand(50, 2))


def test_own_mip_levels_are_used_and_get_gradients():
    """A texture with its own mip levels (prefiltering latents): a minified quad shows the
    levels' colour, not the base level's, and the levels receive the gradient."""
    base = torch.zeros(64, 64, 4)
    base[..., 0] = base[..., 3] = 1.0  # red base level
    levels = []
    for size in (32, 16, 8, 4, 2, 1):
        level = torch.zeros(size, size, 4)
        level[..., 1] = level[..., 3] = 1.0  # green coarser levels
        levels.append(level.requires_grad_(True))
    material = Material(kd=Texture(base, mips=levels), ks=Texture.constant(NO_SPECULAR))
    # The quad covers about 3 x 3 pixels: mip level ~4.
    far = Camera.looking_at(torch.tensor([[0.0, 0.0, 40.0]]), torch.zeros(1, 3), fovy=math.radians(60), far=100.0)
    image = render(Asset(quad(), [material]), far, light_at([0.0, 0.0, 40.0], 1600.0), 64)
    centre = image[0, 32, 32]
    assert centre[1] > 10 * centre[0]
    centre[1].backward()
    assert sum(level.grad.abs().sum() for level in levels) > 0


def test_msaa_shades_once_but_covers_like_supersampling():
    asset = Asset(uv_sphere(1.0, 16, 32), [Material()])
    camera, light = front_camera(), light_at([0.0, 0.0, 3.0], 9.0)
    ssaa = render(asset, camera, light, 24, spp=4)
    msaa = render(asset, camera, light, 24, spp=4, msaa=True)
    assert torch.allclose(msaa[..., 3], ssaa[..., 3], atol=1e-5)
    interior = ssaa[..., 3] == 1
    assert (msaa[interior] - ssaa[interior]).abs().mean() < 0.1 * ssaa[interior].mean()


def test_stochastic_msaa_is_per_sample_shading_in_expectation():
    """A checker of one texel per sample: shading once per pixel at its centre (what one
    sample per pixel gives) misses the sub-pixel texture; the mean of stochastic MSAA draws
    converges to shading every sample, and single draws differ (the sample is random)."""
    texels = torch.tensor([[0.1, 0.9], [0.9, 0.1]]).repeat(16, 16)[..., None].expand(32, 32, 3)
    material = Material(kd=Texture(torch.cat([texels, torch.ones(32, 32, 1)], dim=-1).contiguous()))
    asset = Asset(quad(size=2.0), [material])
    camera, light = front_camera(fovy=math.radians(37)), light_at([0.0, 0.0, 3.0], 9.0)
    every_sample = render(asset, camera, light, 16, spp=2)[..., :3]
    centre = render(asset, camera, light, 16, spp=1)[..., :3]
    torch.manual_seed(0)
    draws = torch.stack([render(asset, camera, light, 16, spp=2, msaa=True)[..., :3] for _ in range(64)])
    inside = slice(2, 14)
    def error(image):
        return (image - every_sample)[:, inside, inside].abs().mean().item()
    assert error(draws.mean(dim=0)) < 0.25 * error(centre)
    assert error(draws[0]) > 2 * error(draws.mean(dim=0))


def test_batch_of_views_and_gradients_reach_positions_and_textures():
    mesh = uv_sphere(1.0, 12, 24)
    mesh.v_pos.requires_grad_(True)
    texels = torch.full((8, 8, 4), 0.5, requires_grad=True)
    specular = torch.full((4, 4, 3), 0.4, requires_grad=True)
    asset = Asset(mesh, [Material(kd=Texture(texels), ks=Texture(specular))])
    eye = torch.tensor([[0.0, 0.0, 3.0], [3.0, 0.0, 0.0]])
    camera = Camera.looking_at(eye, torch.zeros(2, 3), fovy=math.radians(50))
    light = PointLight(eye.clone(), torch.full((2, 3), 9.0))
    image = render(asset, camera, light, 24, spp=2, layers=2, msaa=True)
    assert image.shape == (2, 24, 24, 4) and torch.isfinite(image).all()
    # A sphere looks the same from both views up to the texture.
    assert math.isclose(image[0, ..., 3].mean().item(), image[1, ..., 3].mean().item(), rel_tol=0.02)
    image[..., :3].sum().backward()
    for grad in (mesh.v_pos.grad, texels.grad, specular.grad):
        assert grad is not None and torch.isfinite(grad).all() and grad.abs().sum() > 0


def test_pipeline_gradients_match_finite_differences():
    """Float64 end to end: a bumpy textured sheet wider than the view (no silhouettes, no UV
    seams, so the image is smooth in every input) under a point light."""
    n = 4
    ys, xs = torch.meshgrid(torch.linspace(-3, 3, n, dtype=torch.float64),
                            torch.linspace(-3, 3, n, dtype=torch.float64), indexing="ij")
    v_pos = torch.stack([xs, ys, 0.3 * torch.sin(xs + 2 * ys)], -1).reshape(-1, 3)
    idx = torch.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].reshape(-1), idx[:-1, 1:].reshape(-1), idx[1:, :-1].reshape(-1), idx[1:, 1:].reshape(-1)
    t_pos_idx = torch.cat([torch.stack([a, b, d], 1), torch.stack([a, d, c], 1)])
    v_tex = v_pos[:, :2] / 6 + 0.5
    camera = front_camera()
    camera = Camera(camera.mv.double(), camera.proj.double(), camera.position.double())
    specular = Texture(torch.tensor([[[0.0, 0.5, 0.3]]], dtype=torch.float64))

    def image(light_position, texels, positions):
        mesh = Mesh(v_pos=positions, t_pos_idx=t_pos_idx, uv=[(v_tex, t_pos_idx)])
        light = PointLight(light_position, torch.full((1, 3), 9.0, dtype=torch.float64))
        return render(Asset(mesh, [Material(kd=Texture(texels), ks=specular)]), camera, light, 12)

    light_position = torch.tensor([[1.0, 2.0, 3.0]], dtype=torch.float64, requires_grad=True)
    texels = torch.rand(4, 4, 4, dtype=torch.float64, requires_grad=True)
    positions = v_pos.clone().requires_grad_(True)
    assert image(light_position, texels, positions)[..., 3].min() == 1  # the sheet fills the view
    assert torch.autograd.gradcheck(image, (light_position, texels, positions), fast_mode=True, atol=1e-5)


@pytest.mark.parametrize("spp", [1, 2])
def test_no_nans_at_grazing_views(spp):
    bumps = torch.nn.functional.normalize(torch.rand(8, 8, 3) - 0.5 + torch.tensor([0, 0, 1.0]), dim=-1)
    asset = normal_mapped_sphere(Texture(bumps))
    camera, light = front_camera(), light_at([3.0, 0.0, 0.1], 9.0)  # light grazing from the side
    image = render(asset, camera, light, 32, spp=spp)
    assert torch.isfinite(image).all() and (image >= 0).all()


SHARED_ASSETS = [
    "spot/spot.obj",
    "stanford-bunny/stanford-bunny.obj",
    "nefertiti/nefertiti.obj",
    "flight-helmet/FlightHelmet.gltf",
    "cesium-man/CesiumMan.glb",
    "fox/Fox.glb",
    "alpha-blend-mode-test/AlphaBlendModeTest.glb",
]


@pytest.mark.assets
@pytest.mark.parametrize("relative", SHARED_ASSETS, ids=lambda p: p.split("/")[0])
def test_renders_shared_asset(shared_assets, relative):
    from lookalike import io
    from lookalike.shading.view_sampling import random_lights, random_views

    asset = io.load(shared_assets / relative)
    centre, radius = asset.mesh.bounding_sphere()
    rng = np.random.default_rng(0)
    camera = random_views(centre, radius, 2, rng)
    with torch.no_grad():
        image = render(asset, camera, random_lights(camera, centre, rng), 64, layers=2)
    assert torch.isfinite(image).all() and (image >= 0).all()
    alpha = image[..., 3]
    assert ((alpha >= 0) & (alpha <= 1 + 1e-6)).all()
    coverage = alpha.mean(dim=(1, 2))
    assert ((coverage > 0.03) & (coverage < 0.8)).all(), coverage  # in the picture, framed
    covered = alpha > 0.99
    mean_colour = image[..., :3][covered].mean().item()
    assert 0.01 < mean_colour < 1.5  # lit, neither black nor blown out
    assert image[0, 0, 0, 3] == 0 and image[0, -1, -1, 3] == 0  # corners are background


def test_the_horizon_test_darkens_normal_mapped_points_whose_surface_faces_away_from_the_light():
    tilt = torch.nn.functional.normalize(torch.tensor([0.8, 0.0, 0.6]), dim=0)   # towards +x, 53 degrees
    grey = Material(kd=Texture.constant([0.6, 0.6, 0.6, 1.0]), ks=Texture.constant(NO_SPECULAR),
                    normal=Texture.constant(tilt.tolist()))
    asset = Asset(quad(), [grey])
    position = [[3.0, 0.0, -0.5]]   # slightly behind the quad's plane, on the side the normals lean to

    def centre(horizon) -> float:
        light = PointLight(torch.tensor(position), torch.full((1, 3), 9.0),
                           horizon=None if horizon is None else torch.tensor([horizon]))
        return float(render(asset, front_camera(), light, 33)[0, 16, 16, 0])

    assert centre(None) > 0.05 and centre(False) == centre(None)
    assert centre(True) == 0.0
    lit = [[3.0, 0.0, 0.5]]   # above the plane: both conventions light it alike
    position[:] = lit
    assert centre(True) == centre(None) > 0.05
    two = PointLight.cat([PointLight(torch.tensor(position), torch.ones(1, 3)),
                          PointLight(torch.tensor(position), torch.ones(1, 3), horizon=torch.tensor([True]))])
    assert two.horizon.tolist() == [False, True] and two[1:].horizon.tolist() == [True]


@pytest.mark.parametrize("footprint", [4.0, 8.0])
def test_a_lookup_filters_its_footprint_with_the_variance_of_the_pixels_box(footprint):
    """A vertical line of texels is blurred across ``u`` by the lookup's filter. Averaged over
    the line's place in the mip levels' blocks, the filter's second moment about the line with the footprint scaled
    by ``FOOTPRINT_SCALE`` is near the box's ``f^2 / 12``; trilinear at the plain footprint is
    three times wider (``f^2 / 4``): the engine's footprint, ``ENGINE_FOOTPRINT``."""
    from lookalike.shading.texturing import ENGINE_FOOTPRINT
    size = 128
    u = torch.linspace(0.25, 0.75, 2001)
    uv = torch.stack([u, torch.full_like(u, 0.5)], dim=1)
    uv_da = torch.tensor([[footprint / size, 0.0, 0.0, footprint / size]]).expand(len(u), 4)
    x = u.double() * size

    def variance(**sampler) -> float:
        variances = []
        for column in range(64, 72):
            data = torch.zeros(size, size, 1)
            data[:, column] = 1.0
            response = _lookup(Texture(data, wrap="clamp"), uv, uv_da, **sampler)[:, 0].double()
            variances.append(float((response * (x - column - 0.5) ** 2).sum() / response.sum()))
        return float(np.mean(variances))

    box = footprint ** 2 / 12
    assert 0.8 * box < variance() < 1.3 * box
    assert variance(footprint=ENGINE_FOOTPRINT) > 2.5 * box
