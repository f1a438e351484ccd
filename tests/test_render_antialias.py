"""Antialiasing: coverage gradients against supersampled coverage, silence on interior
edges, the topology hash, and values on a straight edge."""

from __future__ import annotations

import math

import pytest
import torch
import torch.nn.functional as F

import lookalike.render as dr


def coverage_sum(pos: torch.Tensor, tri: torch.Tensor, size: int, supersample: int) -> float:
    """Sum over the image of the box-filtered coverage, from ``supersample^2`` samples per pixel."""
    rast, _ = dr.rasterize(None, pos, tri, (size * supersample, size * supersample))
    covered = (rast[..., 3] > 0).double()[:, None]
    return F.avg_pool2d(covered, supersample).sum().item()


def antialiased_sum(pos: torch.Tensor, tri: torch.Tensor, size: int) -> torch.Tensor:
    """Sum of the antialiased image of a white mesh on black."""
    rast, _ = dr.rasterize(None, pos, tri, (size, size))
    white = (rast[..., 3:] > 0).to(pos.dtype)
    return dr.antialias(white, rast, pos, tri).sum()


@pytest.mark.parametrize("vertex", [0, 1, 2])
@pytest.mark.parametrize("axis", [0, 1])
def test_position_gradient_matches_supersampled_coverage(vertex, axis):
    pos = torch.tensor(
        [[[-0.62, -0.71, 0.0, 1.0], [0.58, -0.43, 0.2, 1.3], [0.07, 0.69, 0.1, 0.9]]], dtype=torch.float64
    )
    tri = torch.tensor([[0, 1, 2]], dtype=torch.int32)
    pos.requires_grad_(True)
    antialiased_sum(pos, tri, 32).backward()
    h = 2.0 / 32 * 0.5  # half a pixel in NDC
    with torch.no_grad():
        plus, minus = pos.clone(), pos.clone()
        plus[0, vertex, axis] += h * pos[0, vertex, 3]
        minus[0, vertex, axis] -= h * pos[0, vertex, 3]
        expected = (coverage_sum(plus, tri, 32, 16) - coverage_sum(minus, tri, 32, 16)) / (2 * h * pos[0, vertex, 3].item())
    assert abs(expected) > 1.0
    assert pos.grad[0, vertex, axis].item() == pytest.approx(expected, rel=0.10)


def test_outline_owned_by_a_sliver_gets_its_gradient():
    # the right outline is the outer edges of a sliver (0.3 px wide) glued to a big triangle
    # along (1, 2): no pixel centre shows the sliver, the pairs across the outline show the
    # big triangle, whose own edge there is interior, and must walk on into the sliver
    eps = 0.3 * 2 / 32
    pos = torch.tensor(
        [[[-0.6, -0.7, 0.0, 1.0], [0.3, -0.6, 0.0, 1.0], [0.3, 0.7, 0.0, 1.0], [0.3 + eps, 0.05, 0.0, 1.0]]],
        dtype=torch.float64,
        requires_grad=True,
    )
    tri = torch.tensor([[0, 1, 2], [1, 3, 2]])
    rast, _ = dr.rasterize(None, pos, tri, (32, 32))
    assert rast[..., 3].unique().tolist() == [0.0, 1.0]
    antialiased_sum(pos, tri, 32).backward()
    h = 2.0 / 32 * 0.1
    with torch.no_grad():
        plus, minus = pos.clone(), pos.clone()
        plus[0, 3, 0] += h
        minus[0, 3, 0] -= h
        expected = (coverage_sum(plus, tri, 32, 32) - coverage_sum(minus, tri, 32, 32)) / (2 * h)
    assert expected > 3.0
    assert pos.grad[0, 3, 0].item() == pytest.approx(expected, rel=0.10)


def test_sub_pixel_surface_stays_within_its_neighbours_colours():
    # an equilateral triangle 0.2 px in circumradius around a pixel centre: each of its three
    # edges, 0.1 px from the centre, would blend 0.4 of the pixel with background, 1.2 in all
    centre = (8 + 0.5) / 16 * 2 - 1
    r = 0.2 * 2 / 16
    corners = [(r * math.cos(a), r * math.sin(a)) for a in (math.pi / 2, 7 * math.pi / 6, 11 * math.pi / 6)]
    pos = torch.tensor([[[centre + x, centre + y, 0.0, 1.0] for x, y in corners]])
    tri = torch.tensor([[0, 1, 2]])
    rast, _ = dr.rasterize(None, pos, tri, (16, 16))
    assert (rast[..., 3] > 0).sum() == 1
    out = dr.antialias((rast[..., 3:] > 0).float(), rast, pos, tri)
    assert out.min() == 0 and out.max() <= 1  # the pixel is all background, not less


def test_interior_edges_give_no_position_gradient():
    # a quad larger than the screen: its only on-screen edge is the shared diagonal
    pos = torch.tensor(
        [[[-3.0, -3.0, 0.0, 1.0], [3.0, -3.2, 0.1, 1.0], [-3.1, 3.0, 0.2, 1.0], [3.0, 3.0, 0.0, 1.0]]],
        dtype=torch.float64,
        requires_grad=True,
    )
    tri = torch.tensor([[0, 1, 2], [2, 1, 3]])
    rast, _ = dr.rasterize(None, pos, tri, (16, 16))
    assert rast[..., 3].unique().tolist() == [1.0, 2.0]
    color = torch.stack([rast[..., 3] == 1, rast[..., 3] == 2], -1).double().requires_grad_(True)
    out = dr.antialias(color, rast, pos, tri)
    (out * torch.randn_like(out)).sum().backward()
    assert torch.equal(out, color)
    assert torch.count_nonzero(pos.grad) == 0


def test_folded_edge_is_a_silhouette():
    # the second triangle folds back over the first along their shared edge (1, 2) and is
    # hidden behind it, so the edge is a silhouette of the front triangle
    pos = torch.tensor(
        [[[-0.8, -0.8, 0.0, 1.0], [0.6, -0.7, 0.0, 1.0], [-0.1, 0.7, 0.0, 1.0], [-0.5, -0.4, 0.5, 1.0]]],
        dtype=torch.float64,
        requires_grad=True,
    )
    tri = torch.tensor([[0, 1, 2], [1, 2, 3]])
    topology = dr.antialias_construct_topology_hash(tri)
    assert topology.opposite.tolist() == [[3, -1, -1], [-1, -1, 0]]
    assert topology.neighbour.tolist() == [[1, -1, -1], [-1, -1, 0]]
    assert antialiased_sum(pos, tri, 24).requires_grad
    antialiased_sum(pos, tri, 24).backward()
    assert pos.grad[0, 1, 0] > 1.0 and pos.grad[0, 2, 1] > 1.0


def test_vertical_edge_blends_by_exact_coverage():
    # a vertical edge 0.3 px right of the centre of column 7 (16 px image): coverage 0.8
    edge_x = (7 + 0.5 + 0.3) / 16 * 2 - 1
    pos = torch.tensor([[[-3.0, -3.0, 0.0, 1.0], [edge_x, -3.0, 0.0, 1.0], [edge_x, 3.0, 0.0, 1.0], [-3.0, 3.0, 0.0, 1.0]]])
    tri = torch.tensor([[0, 1, 2], [0, 2, 3]])
    rast, _ = dr.rasterize(None, pos, tri, (16, 16))
    out = dr.antialias((rast[..., 3:] > 0).float(), rast, pos, tri)
    row = out[0, 5, :, 0]
    torch.testing.assert_close(row[7:9], torch.tensor([0.8, 0.0]))
    assert row[:7].eq(1).all() and row[9:].eq(0).all()


def test_gradient_boost_scales_position_gradient_only():
    pos = torch.tensor([[[-0.6, -0.7, 0.0, 1.0], [0.6, -0.4, 0.0, 1.0], [0.1, 0.7, 0.0, 1.0]]], requires_grad=True)
    tri = torch.tensor([[0, 1, 2]], dtype=torch.int32)
    rast, _ = dr.rasterize(None, pos, tri, (16, 16))
    color = (rast[..., 3:] > 0).float().requires_grad_(True)
    grads = []
    for boost in (1.0, 3.0):
        out = dr.antialias(color, rast, pos, tri, pos_gradient_boost=boost)
        grads.append(torch.autograd.grad(out.sum(), (pos, color)))
    torch.testing.assert_close(grads[1][0], 3.0 * grads[0][0])
    torch.testing.assert_close(grads[1][1], grads[0][1])
