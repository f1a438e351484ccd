"""Putting a user's LOD back on the input's surface (``lookalike.init.conform``)."""

from __future__ import annotations

import dataclasses

import numpy as np
import torch
from test_fit_simplify import bumpy_sphere

from lookalike.asset import Mesh
from lookalike.bench.repair import damaged
from lookalike.init import decimate
from lookalike.init.closest_point import SurfaceQuery
from lookalike.init.conform import (
    SurfaceFit,
    area_samples,
    barycentric_rows,
    boundary_loops,
    conform_to_surface,
    reattach_detached_parts,
)


def surface_distances(mesh: Mesh, surface: Mesh, count: int = 4000) -> tuple[float, float]:
    """Mean distance from points sampled on ``mesh`` to ``surface`` and back."""
    rng = np.random.default_rng(1)

    def points(m: Mesh) -> np.ndarray:
        pos, tri = m.v_pos.double().numpy(), m.t_pos_idx.numpy()
        return (barycentric_rows(tri, *area_samples(pos, tri, count, rng), m.num_vertices) @ pos)

    def distance(a: Mesh, b: Mesh) -> float:
        return float(SurfaceQuery(b.v_pos.numpy(), b.t_pos_idx.numpy()).closest(points(a)).distance.mean())

    return distance(mesh, surface), distance(surface, mesh)


def cut_off(mesh: Mesh, triangles: torch.Tensor, offset: torch.Tensor) -> Mesh:
    """``mesh`` with ``triangles`` given copies of their vertices (one piece) moved by ``offset``."""
    corners, local = torch.unique(mesh.t_pos_idx[triangles], return_inverse=True)
    t_pos_idx = mesh.t_pos_idx.clone()
    t_pos_idx[triangles] = mesh.num_vertices + local
    return dataclasses.replace(mesh, v_pos=torch.cat([mesh.v_pos, mesh.v_pos[corners] + offset]), t_pos_idx=t_pos_idx)


def test_area_samples_are_uniform_over_the_area():
    """Two triangles, one three times the other's area, get samples 3:1; weights sum to 1."""
    pos = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [3, 0, 1], [0, 1, 1]])
    triangle, barycentric = area_samples(pos, np.array([[0, 1, 2], [3, 4, 5]]), 40_000, np.random.default_rng(0))
    assert abs(np.mean(triangle == 1) - 0.75) < 0.01
    assert np.allclose(barycentric.sum(axis=1), 1.0) and (barycentric >= 0).all()
    assert abs(barycentric[:, 0].mean() - 1 / 3) < 0.01          # uniform in the triangle: centroid 1/3 each


def test_a_shrunk_decimation_is_fitted_back_and_a_good_one_stays():
    surface = bumpy_sphere().mesh
    good = decimate(surface, 300)
    shrunk = good.with_positions(good.v_pos * 0.93)
    fitted = conform_to_surface(shrunk, surface)
    before, after = surface_distances(shrunk, surface), surface_distances(fitted, surface)
    own = surface_distances(good, surface)
    assert min(before) > 5 * max(own)
    assert max(after) < 1.5 * max(own)                           # as close as the decimation itself
    assert torch.equal(fitted.t_pos_idx, shrunk.t_pos_idx)
    kept = conform_to_surface(good, surface)
    assert max(surface_distances(kept, surface)) < 1.2 * max(own)
    edge = (good.v_pos[good.t_pos_idx[:, 0]] - good.v_pos[good.t_pos_idx[:, 1]]).norm(dim=-1).mean()
    assert (kept.v_pos - good.v_pos).norm(dim=-1).max() < 0.5 * edge


def test_unfolding_passes_undo_the_folds_a_shrink_pushes_through_a_thin_shape():
    """A sphere squashed to 6 % of its width, decimated and shrunk by 5 % along its normals:
    the rim's two sides cross. Fitted with the start's differentials alone, 21 triangles stay
    folded onto the surface, facing the wrong way; the unfolding passes leave at most 3."""
    surface = bumpy_sphere().mesh
    surface = surface.with_positions(surface.v_pos * torch.tensor([1.0, 1.0, 0.06]))
    shrunk = damaged(decimate(surface, 300), np.random.default_rng(0), shrink=0.05, part=0.0, offset=0.0)
    check = SurfaceFit(shrunk, surface, 10, 0.03, np.random.default_rng(0))

    def folded(mesh: Mesh) -> int:
        return int(check.facing_against(mesh.v_pos.double().numpy()).sum())

    kept = conform_to_surface(shrunk, surface, unfold_passes=0, samples=5000)
    unfolded = conform_to_surface(shrunk, surface, samples=5000)
    assert folded(shrunk) > 100 and folded(kept) >= 15
    assert folded(unfolded) <= 3
    assert max(surface_distances(unfolded, surface)) <= max(surface_distances(kept, surface))


def test_a_piece_cut_off_and_moved_is_welded_back():
    mesh = decimate(bumpy_sphere().mesh, 300)
    centroids = mesh.v_pos[mesh.t_pos_idx].mean(dim=1)
    piece = torch.argsort((centroids - mesh.v_pos[0]).norm(dim=-1))[:15]
    broken = cut_off(mesh, piece, torch.tensor([0.05, -0.02, 0.1]))
    assert len(boundary_loops(broken.t_pos_idx.numpy())) == 2
    repaired, welded = reattach_detached_parts(broken)
    assert welded == 1 and repaired.num_vertices == mesh.num_vertices and repaired.num_triangles == mesh.num_triangles
    assert not boundary_loops(repaired.t_pos_idx.numpy())
    assert torch.allclose(repaired.v_pos[repaired.t_pos_idx], mesh.v_pos[mesh.t_pos_idx], atol=1e-6)


def test_loops_of_another_shape_are_not_welded():
    """Two separate spheres (no boundary) and an open sheet beside a sphere with a hole of a
    different shape are left alone."""
    mesh = decimate(bumpy_sphere().mesh, 300)
    assert reattach_detached_parts(mesh) == (mesh, 0)
    centroids = mesh.v_pos[mesh.t_pos_idx].mean(dim=1)
    piece = torch.argsort((centroids - mesh.v_pos[0]).norm(dim=-1))[:15]
    broken = cut_off(mesh, piece, torch.tensor([0.0, 0.0, 0.5]))
    corners = broken.t_pos_idx[piece].unique()
    stretched = broken.v_pos.clone()
    stretched[corners] = stretched[corners] * torch.tensor([2.0, 1.0, 1.0])  # the piece's outline no longer fits
    assert reattach_detached_parts(dataclasses.replace(broken, v_pos=stretched))[1] == 0


def test_the_bench_damage_is_repaired_close_to_the_decimation():
    surface = bumpy_sphere().mesh
    good = decimate(surface, 300)
    broken = damaged(good, np.random.default_rng(0))
    repaired, welded = reattach_detached_parts(broken)
    repaired = conform_to_surface(repaired, surface)
    assert welded == 1 and repaired.num_vertices == good.num_vertices
    assert max(surface_distances(repaired, surface)) < 1.5 * max(surface_distances(good, surface))
    assert max(surface_distances(broken, surface)) > 5 * max(surface_distances(good, surface))
