"""Gradients of rasterize, interpolate and texture against central finite differences
(float64), and values of the barycentrics against an independent solve."""

from __future__ import annotations

import pytest
import torch
from torch.autograd import gradcheck

import lookalike.render as dr
from lookalike.render.barycentrics import barycentrics_python, pixel_ndc


def perspective_triangles(n_views: int = 2) -> tuple[torch.Tensor, torch.Tensor]:
    """``pos [B, 6, 4]`` float64 of two overlapping triangles with different w per vertex
    (so perspective correction matters), and ``tri [2, 3]``."""
    base = torch.tensor(
        [
            [-0.9, -0.8, 0.1, 1.0], [0.8, -0.9, 0.3, 2.0], [0.1, 0.9, 0.2, 1.5],
            [-0.7, 0.6, -0.2, 1.2], [0.9, 0.7, 0.4, 0.8], [0.0, -0.6, 0.0, 1.0],
        ],
        dtype=torch.float64,
    )
    pos = base.repeat(n_views, 1, 1) + 0.05 * torch.randn(n_views, 6, 4, dtype=torch.float64)
    pos[..., :2] *= pos[..., 3:]  # NDC layout above, scaled into clip space
    return pos, torch.tensor([[0, 1, 2], [3, 4, 5]], dtype=torch.int32)


def test_barycentrics_match_an_independent_solve():
    pos, tri = perspective_triangles()
    rast, _ = dr.rasterize(None, pos, tri, (20, 24))
    b, iy, ix = torch.nonzero(rast[..., 3] > 0).T
    t = rast[b, iy, ix, 3].long() - 1
    verts = pos[b[:, None], tri.long()[t]]  # [N, 3, 4]
    m = verts[..., [0, 1, 3]].transpose(1, 2)
    p = torch.stack([(2 * ix + 1) / 24 - 1, (2 * iy + 1) / 20 - 1, torch.ones_like(ix)], -1).double()
    solved = torch.linalg.solve(m, p)
    solved = solved / solved.sum(-1, keepdim=True)
    torch.testing.assert_close(rast[b, iy, ix, :2], solved[:, :2])
    assert (rast[..., :3][rast[..., 3] == 0] == 0).all()


def test_barycentric_and_derivative_gradients_match_finite_differences():
    pos, tri = perspective_triangles()
    rast, _ = dr.rasterize(None, pos, tri, (12, 10))
    flat = torch.nonzero(rast[..., 3].reshape(-1)).squeeze(1)
    tri_idx = rast[..., 3].reshape(-1)[flat].long() - 1
    view = flat // 120
    p = pixel_ndc(flat, 12, 10, torch.float64)
    pos.requires_grad_(True)
    assert gradcheck(lambda q: barycentrics_python(q, tri.long(), view, tri_idx, p, (12, 10)), (pos,))


def test_rast_db_is_the_pixel_derivative_of_the_barycentrics():
    pos, tri = perspective_triangles(1)
    rast, rast_db = dr.rasterize(None, pos, tri, (16, 16))
    flat = torch.nonzero(rast[..., 3].reshape(-1)).squeeze(1)
    tri_idx = rast[..., 3].reshape(-1)[flat].long() - 1
    view = torch.zeros_like(flat)
    p = pixel_ndc(flat, 16, 16, torch.float64)
    h = 1e-5  # pixels
    step_x = torch.tensor([2 * h / 16, 0.0, 0.0], dtype=torch.float64)
    step_y = torch.tensor([0.0, 2 * h / 16, 0.0], dtype=torch.float64)
    bary = lambda q: barycentrics_python(pos, tri.long(), view, tri_idx, q, (16, 16), with_db=False)[0]  # noqa: E731
    d_dx = (bary(p + step_x) - bary(p - step_x)) / (2 * h)
    d_dy = (bary(p + step_y) - bary(p - step_y)) / (2 * h)
    expected = torch.stack([d_dx[:, 0], d_dy[:, 0], d_dx[:, 1], d_dy[:, 1]], -1)
    torch.testing.assert_close(rast_db.reshape(-1, 4)[flat], expected, rtol=1e-6, atol=1e-8)


def test_rasterize_end_to_end_gradient():
    pos, tri = perspective_triangles(1)
    pos.requires_grad_(True)
    weights = torch.randn(1, 9, 11, 4, dtype=torch.float64)
    loss = lambda q: ((torch.cat(dr.rasterize(None, q, tri, (9, 11))[0:2], -1)[..., [0, 1, 4, 5, 6, 7]]) * torch.cat([weights[..., :2], weights], -1)).sum()  # noqa: E731
    assert gradcheck(loss, (pos,))
    grad_db_off = dr.rasterize(None, pos, tri, (9, 11), grad_db=False)[1]
    assert not grad_db_off.requires_grad


@pytest.mark.parametrize("batched_attr", [False, True])
def test_interpolate_gradients(batched_attr):
    pos, tri = perspective_triangles()
    rast, rast_db = dr.rasterize(None, pos, tri, (5, 6))
    attr = torch.randn(*((2,) if batched_attr else ()), 6, 3, dtype=torch.float64, requires_grad=True)
    uv = rast[..., :2].clone().requires_grad_(True)
    db = rast_db.clone().requires_grad_(True)

    def run(attr, uv, db):
        r = torch.cat([uv, rast[..., 2:]], -1)
        return dr.interpolate(attr, r, tri, db, diff_attrs=[0, 2])

    assert gradcheck(run, (attr, uv, db))
    out, out_da = run(attr, uv, db)
    assert out.shape == (2, 5, 6, 3) and out_da.shape == (2, 5, 6, 4)
    assert (out[rast[..., 3] == 0] == 0).all()


def test_interpolate_values_and_derivatives():
    pos, tri = perspective_triangles(1)
    rast, rast_db = dr.rasterize(None, pos, tri, (16, 16))
    # an attribute equal to clip-space (x, y, w): interpolated perspective-correctly, x/w and
    # y/w give back each pixel centre, and their pixel derivatives are 2/W and 2/H
    attr = pos[0, :, [0, 1, 3]]
    out, out_da = dr.interpolate(attr, rast, tri, rast_db, diff_attrs="all")
    covered = rast[0, ..., 3] > 0
    iy, ix = torch.nonzero(covered).T
    torch.testing.assert_close(out[0, iy, ix, 0] / out[0, iy, ix, 2], ((2 * ix + 1) / 16.0 - 1).double())
    torch.testing.assert_close(out[0, iy, ix, 1] / out[0, iy, ix, 2], ((2 * iy + 1) / 16.0 - 1).double())
    # d(x/w)/dX = (dx/dX w - x dw/dX) / w^2 = 2/16
    x, w = out[0, iy, ix, 0], out[0, iy, ix, 2]
    dxdX, dwdX = out_da[0, iy, ix, 0], out_da[0, iy, ix, 4]
    torch.testing.assert_close((dxdX * w - x * dwdX) / w**2, torch.full_like(w, 2 / 16))


def test_interpolate_rejects_mismatched_triangles():
    pos, tri = perspective_triangles(1)
    rast, _ = dr.rasterize(None, pos, tri, (8, 8))
    with pytest.raises(ValueError, match="beyond"):
        dr.interpolate(torch.zeros(6, 2), rast, tri[:1])
    with pytest.raises(ValueError, match="outside"):
        dr.interpolate(torch.zeros(4, 2), rast, tri)
