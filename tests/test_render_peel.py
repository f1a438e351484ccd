"""Depth peeling returns layers nearest-first."""

from __future__ import annotations

import pytest
import torch

import lookalike.render as dr


def stacked_quads(n_quads: int) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Overlapping, slightly tilted quads at different depths, listed in random depth order.

    Returns ``pos [1, 4n, 4]``, ``tri [2n, 3]`` and the quads' corners in NDC ``[n, 4]``
    ``(x0, y0, x1, y1)`` with their depth planes ``[n, 3]`` ``(a, b, c)``: z/w = a x + b y + c.
    """
    corners = torch.rand(n_quads, 2) * 0.8 - 0.9
    corners = torch.cat([corners, corners + 0.7 + torch.rand(n_quads, 2) * 0.3], 1)
    planes = torch.cat([torch.randn(n_quads, 2) * 0.05, torch.randperm(n_quads)[:, None] * 0.15 - 0.5], 1)
    x0, y0, x1, y1 = corners.T
    xs = torch.stack([x0, x1, x0, x1], 1)
    ys = torch.stack([y0, y0, y1, y1], 1)
    zs = planes[:, 0:1] * xs + planes[:, 1:2] * ys + planes[:, 2:3]
    pos = torch.stack([xs, ys, zs, torch.ones_like(xs)], -1).reshape(1, -1, 4)
    base = torch.arange(n_quads)[:, None] * 4
    tri = torch.cat([base + torch.tensor([0, 1, 2]), base + torch.tensor([2, 1, 3])]).reshape(2, n_quads, 3)
    return pos, tri.transpose(0, 1).reshape(-1, 3).int(), torch.cat([corners, planes], 1)


@pytest.mark.parametrize("pass_ranges", [False, True])
def test_layers_come_nearest_first_and_match_sorted_depths(pass_ranges):
    n_quads, size = 5, 32
    pos, tri, quads = stacked_quads(n_quads)
    px = (2 * torch.arange(size) + 1) / size - 1
    x, y = px[None, :], px[:, None]
    inside = [(x >= q[0]) & (x <= q[2]) & (y >= q[1]) & (y <= q[3]) for q in quads]
    depth = torch.stack([torch.where(m, q[4] * x + q[5] * y + q[6], torch.inf) for q, m in zip(quads, inside)])
    expected_depth, expected_quad = depth.sort(0)
    if pass_ranges:
        args = (pos[0], tri, (size, size), torch.tensor([[0, tri.shape[0]]]))
    else:
        args = (pos, tri, (size, size))
    with dr.DepthPeeler(dr.RasterizeContext(), *args) as peeler:
        for layer in range(n_quads + 1):
            rast, _ = peeler.rasterize_next_layer()
            shown = rast[0, ..., 3] > 0
            if layer == n_quads:
                assert not shown.any()
                break
            expected_shown = expected_depth[layer].isfinite()
            assert (shown == expected_shown).float().mean() > 0.99
            both = shown & expected_shown
            quad = (rast[0, ..., 3][both].long() - 1) // 2
            assert (quad == expected_quad[layer][both]).float().mean() > 0.99
            torch.testing.assert_close(rast[0, ..., 2][both], expected_depth[layer][both], atol=1e-5, rtol=0)


def test_peeler_needs_its_with_block():
    pos, tri, _ = stacked_quads(2)
    peeler = dr.DepthPeeler(None, pos, tri, (8, 8))
    with pytest.raises(RuntimeError, match="with"):
        peeler.rasterize_next_layer()


@pytest.mark.parametrize("block", [1, 2])
def test_windowed_layers_are_the_windows_of_the_full_layers(block):
    """``rasterize_next_window`` gives, bit for bit, the window of ``rasterize_next_layer``'s
    images (values and gradients) that holds every covered pixel with a margin, each window
    inside the previous one, and ``None`` once no fragment is left."""
    pos, tri, _ = stacked_quads(4)
    pos = (pos * torch.tensor([0.6, 0.5, 1.0, 1.0]) + torch.tensor([0.1, -0.2, 0.0, 0.0])).requires_grad_()
    size = 36
    with dr.DepthPeeler(None, pos, tri, (size, size)) as full, dr.DepthPeeler(None, pos, tri, (size, size)) as part:
        outer = None
        for _ in range(6):
            rast, rast_db = full.rasterize_next_layer()
            window, part_rast, part_db = part.rasterize_next_window(block)
            if not (rast[..., 3] > 0).any():
                assert window is None and part_rast.numel() == 0
                break
            assert window.top % block == 0 and window.height % block == 0 and window.width < size
            assert torch.equal(window.crop(rast), part_rast) and torch.equal(window.crop(rast_db), part_db)
            outside = window.paste(torch.zeros_like(part_rast), rast)
            assert not (outside[..., 3] > 0).any()
            if outer is not None:
                assert outer.top <= window.top and window.top + window.height <= outer.top + outer.height
            weights = torch.randn(rast.shape)
            full_grad, = torch.autograd.grad((rast * weights).sum() + rast_db.sum(), pos)
            part_grad, = torch.autograd.grad((part_rast * window.crop(weights)).sum() + part_db.sum(), pos)
            torch.testing.assert_close(part_grad, full_grad, rtol=1e-6, atol=1e-6)
            outer = window
        else:
            pytest.fail("four quads ran out of layers")


@pytest.mark.parametrize("block", [None, 2])
def test_layers_found_in_one_pass_equal_layers_peeled_one_by_one(block):
    """A peeler told it will be asked for 3 layers finds them in one pass; its layers (and
    the ones it peels beyond the 3), windows and gradients equal those of a peeler that
    rasterizes every layer on its own."""
    pos, tri, _ = stacked_quads(6)
    pos = pos.requires_grad_()
    size = 30
    with dr.DepthPeeler(None, pos, tri, (size, size)) as alone, \
            dr.DepthPeeler(None, pos, tri, (size, size), layers=3) as together:
        for _ in range(5):
            if block is None:
                (rast, rast_db), (got, got_db) = alone.rasterize_next_layer(), together.rasterize_next_layer()
            else:
                window, rast, rast_db = alone.rasterize_next_window(block)
                got_window, got, got_db = together.rasterize_next_window(block)
                assert got_window == window
            assert torch.equal(got, rast) and torch.equal(got_db, rast_db)
            weights = torch.randn(rast.shape)
            expected, = torch.autograd.grad((rast * weights).sum() + rast_db.sum(), pos)
            grad, = torch.autograd.grad((got * weights).sum() + got_db.sum(), pos)
            assert torch.equal(grad, expected)
        assert (rast[..., 3] > 0).any()  # the fifth layer, peeled beyond the three, has fragments
