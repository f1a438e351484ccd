"""Depth peeling of stacked semi-transparent cards (the renders ``cards`` fits with): the
composite matches a per-pixel sorted one, and gradients reach alpha texels and card vertices."""

from __future__ import annotations

import math

import pytest
import torch

import lookalike.render as dr
from lookalike.asset import Asset, Material, Mesh, Texture
from lookalike.render.msaa import upsample_over
from lookalike.render.window import Window
from lookalike.shading import Camera, PointLight, peeled_layers, render
from lookalike.shading.peeled_layers import Frame, LayerCount, layer_gbuffer, points_image, shade_points
from lookalike.shading.pipeline import background_image, box_downsample, edge_topology, mesh_buffers, texture_sampler

NO_SPECULAR = [1.0, 0.5, 0.0]  # gamma = 1 removes the specular lobe


def card(centre, half: float, material: int = 0, dtype=torch.float32) -> Mesh:
    """A square card of half-size ``half`` facing +z at ``centre``, UVs (0, 0) top-left."""
    corners = torch.tensor([[-1.0, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], dtype=dtype) * half
    v_pos = corners + torch.as_tensor(centre, dtype=dtype)
    t_pos_idx = torch.tensor([[0, 1, 2], [0, 2, 3]])
    v_tex = torch.tensor([[0.0, 1], [1, 1], [1, 0], [0, 0]], dtype=dtype)
    return Mesh(v_pos=v_pos, t_pos_idx=t_pos_idx, uv=[(v_tex, t_pos_idx.clone())], t_mat_idx=torch.full((2,), material))


def joined(meshes: list[Mesh]) -> Mesh:
    offsets = [sum(m.num_vertices for m in meshes[:i]) for i in range(len(meshes))]
    return Mesh(v_pos=torch.cat([m.v_pos for m in meshes]),
                t_pos_idx=torch.cat([m.t_pos_idx + o for m, o in zip(meshes, offsets)]),
                uv=[(torch.cat([m.uv[0][0] for m in meshes]),
                     torch.cat([m.uv[0][1] + o for m, o in zip(meshes, offsets)]))],
                t_mat_idx=torch.cat([m.t_mat_idx for m in meshes]))


def glowing(rgb, alpha: float) -> Material:
    """Emission ``rgb`` and alpha, black base colour, blended, double-sided."""
    return Material(kd=Texture.constant([0.0, 0.0, 0.0, alpha]), ks=Texture.constant(NO_SPECULAR),
                    emissive=Texture.constant(rgb), alpha_mode="BLEND", double_sided=True)


def front_camera(dtype=torch.float32) -> Camera:
    camera = Camera.looking_at(torch.tensor([[0.0, 0.0, 4.0]]), torch.zeros(1, 3), fovy=math.radians(50),
                               near=0.5, far=20.0)
    return Camera(camera.mv.to(dtype), camera.proj.to(dtype), camera.position.to(dtype))


def test_stacked_cards_composite_like_a_per_pixel_sort():
    """Five overlapping cards at distinct depths, in shuffled triangle order: 8 peeled layers
    give what compositing each card's own render back to front, pixel by pixel, gives."""
    generator = torch.Generator().manual_seed(3)
    count = 5
    depths = torch.randperm(count, generator=generator).float() * 0.3 - 0.6
    centres = torch.cat([torch.rand(count, 2, generator=generator) - 0.5, depths[:, None]], dim=1)
    halves = 0.4 + 0.4 * torch.rand(count, generator=generator)
    colours = torch.rand(count, 3, generator=generator)
    alphas = 0.3 + 0.5 * torch.rand(count, generator=generator)
    materials = [glowing(colours[i].tolist(), float(alphas[i])) for i in range(count)]
    cards = [card(centres[i], float(halves[i]), material=i) for i in range(count)]
    camera, light = front_camera(), PointLight(torch.tensor([[0.0, 0.0, 4.0]]), torch.ones(1, 3))
    background = torch.tensor([0.1, 0.2, 0.3])
    order = torch.randperm(count, generator=generator).tolist()
    peeled = render(Asset(joined([cards[i] for i in order]), materials), camera, light, 48, spp=2, layers=8,
                    background=background)[0]

    alone = [render(Asset(cards[i], materials), camera, light, 48, spp=2)[0] for i in range(count)]
    expected = background.expand(48, 48, 3).clone()
    for i in sorted(range(count), key=lambda i: float(centres[i, 2])):   # farthest first
        expected = alone[i][..., :3] + (1 - alone[i][..., 3:]) * expected  # premultiplied "over"
    error = (peeled[..., :3] - expected).abs()
    assert float(error.mean()) < 2e-3
    assert float(error.quantile(0.98)) < 1e-4   # all but the pixels on card edges agree exactly


@pytest.mark.parametrize("wrt", ["alpha texels", "card vertices"])
def test_peeled_composite_gradients_match_finite_differences(wrt):
    """Float64: a textured blended card over a second one, both wider than the view (no
    outlines), lit by a point light; the image is smooth in the front card's alpha texels and
    in its vertices (which tilt its plane)."""
    dtype = torch.float64
    camera = front_camera(dtype)
    light = PointLight(torch.tensor([[1.0, 2.0, 4.0]], dtype=dtype), torch.full((1, 3), 9.0, dtype=dtype))
    back = card([0.0, 0.0, -1.0], 4.0, material=1, dtype=dtype)
    generator = torch.Generator().manual_seed(5)
    colour = torch.rand(4, 4, 3, generator=generator, dtype=dtype)
    alpha0 = (0.2 + 0.6 * torch.rand(4, 4, 1, generator=generator, dtype=dtype))
    front0 = card([0.0, 0.0, 0.0], 3.0, dtype=dtype).v_pos
    front0 = front0 + 0.2 * torch.rand(front0.shape, generator=generator, dtype=dtype) * torch.tensor([0, 0, 1.0],
                                                                                                        dtype=dtype)
    specular = Texture(torch.tensor([[[0.0, 0.6, 0.0]]], dtype=dtype))
    back_material = Material(kd=Texture(torch.tensor([[[0.3, 0.6, 0.2, 1.0]]], dtype=dtype)), ks=specular,
                             double_sided=True)

    def image(alpha, positions):
        front = card([0.0, 0.0, 0.0], 3.0, dtype=dtype)
        front.v_pos = positions
        material = Material(kd=Texture(torch.cat([colour, alpha], dim=-1)), ks=specular, alpha_mode="BLEND",
                            double_sided=True)
        return render(Asset(joined([front, back]), [material, back_material]), camera, light, 10, layers=8)

    alpha = alpha0.clone().requires_grad_(wrt == "alpha texels")
    positions = front0.clone().requires_grad_(wrt == "card vertices")
    assert image(alpha, positions)[..., 3].min() == 1   # the back card fills the view
    inputs = (alpha, positions)
    assert torch.autograd.gradcheck(image, inputs, fast_mode=True, atol=1e-5)


def full_frame_composite(asset, camera, light, size: int, spp: int, layers: int, background) -> torch.Tensor:
    """The oracle of the windowed peel: every one of ``layers`` layers rasterized, shaded (each
    on its own), composited and antialiased over the whole frame, empty ones included, with no
    early stop (``render``'s early stops, windows and shading all layers together must not
    change a value)."""
    full = (size * spp, size * spp)
    buffers = mesh_buffers(asset, camera)
    frame = Frame(asset, buffers, camera, light, texture_sampler(asset))
    whole = Window.whole(*full)
    shaded = []
    with dr.DepthPeeler(None, buffers.clip, buffers.tri, full) as peeler:
        for _ in range(layers):
            rast, rast_db = peeler.rasterize_next_layer()
            gb, shape = layer_gbuffer(frame, rast, rast_db, rast[..., 3] > 0, spp, whole)
            shaded.append((rast, points_image(gb, shade_points(frame, [gb])[0], shape)))
    accum = background_image(background, 1, size, size, spp, buffers.clip)
    for rast, colour in reversed(shaded):
        accum = dr.antialias(upsample_over(accum, colour, rast[..., 3], spp).contiguous(), rast, buffers.clip,
                             buffers.tri, topology_hash=edge_topology(asset, buffers))
    return box_downsample(accum, spp).flip(1)


def test_peeling_stops_at_the_deepest_covered_layer_and_equals_the_full_composite(monkeypatch):
    """Five blended cards (alpha < 1, so no sample is ever hidden) overlap at most four deep:
    ``render`` with 8 layers stops after the deepest covered layer and works in windows, and
    its image (stochastic MSAA, same draws) equals every layer composited over the whole frame,
    bit for bit, also where the k-buffer's memory holds only two layers (the rest peeled a pass
    each); ``LayerCount`` reports the layers used."""
    generator = torch.Generator().manual_seed(11)
    count, size, spp = 5, 40, 2
    centres = torch.cat([0.5 * torch.rand(count, 2, generator=generator) - 0.45,
                         torch.randperm(count, generator=generator).float()[:, None] * 0.3 - 0.6], dim=1)
    materials = [glowing(torch.rand(3, generator=generator).tolist(), 0.3 + 0.1 * i) for i in range(count)]
    asset = Asset(joined([card(centres[i], 0.35, material=i) for i in range(count)]), materials)
    camera, light = front_camera(), PointLight(torch.tensor([[0.0, 0.0, 4.0]]), torch.ones(1, 3))
    background = torch.tensor([0.1, 0.2, 0.3])
    used = LayerCount()
    torch.manual_seed(0)
    image = render(asset, camera, light, size, spp=spp, layers=8, background=background, msaa=True, layer_count=used)
    torch.manual_seed(0)
    expected = full_frame_composite(asset, camera, light, size, spp, 8, background)
    assert torch.equal(image, expected)
    torch.manual_seed(0)
    with torch.no_grad():  # each layer shaded as it is peeled, not all together
        assert torch.equal(render(asset, camera, light, size, spp=spp, layers=8, background=background, msaa=True),
                           expected)
    samples = (size * spp) ** 2
    monkeypatch.setattr(peeled_layers, "K_BUFFER_BYTES", 8 * 2 * samples)
    assert (peeled_layers.one_pass_layers(8, samples), peeled_layers.one_pass_layers(8, 4 * samples)) == (2, 1)
    torch.manual_seed(0)
    assert torch.equal(render(asset, camera, light, size, spp=spp, layers=8, background=background, msaa=True),
                       expected)
    with dr.DepthPeeler(None, camera.clip(asset.mesh.v_pos), asset.mesh.t_pos_idx.int(), (size * spp,) * 2) as peeler:
        covered = [bool((peeler.rasterize_next_layer()[0][..., 3] > 0).any()) for _ in range(8)]
    deepest = covered.index(False)
    assert 2 <= deepest < 8 and not any(covered[deepest:])
    assert (used.renders, used.layers, used.deepest, used.mean) == (1, deepest, deepest, deepest)


def test_a_sample_of_no_coverage_leaves_what_lies_behind_whatever_its_colour():
    """A back face's shading need not be finite; its coverage is 0, so it must not show."""
    accum = torch.tensor([[0.2, 0.3, 0.4, 1.0], [0.0, 0.0, 0.0, 0.0]])
    colour = torch.tensor([[math.nan, math.inf, 1.0, 0.0], [0.5, 0.5, 0.5, 0.5]])
    over = peeled_layers.composite_over(accum, colour)
    assert torch.equal(over[0], accum[0]) and torch.allclose(over[1], torch.tensor([0.25, 0.25, 0.25, 0.5]))
    alpha = torch.zeros(1, 1, requires_grad=True)  # a transparent texel's alpha learns what its colour would show
    peeled_layers.composite_over(accum[:1], torch.cat([torch.tensor([[0.9, 0.9, 0.9]]), alpha], -1)).sum().backward()
    assert float(alpha.grad) == pytest.approx((0.9 - 0.2) + (0.9 - 0.3) + (0.9 - 0.4))
