"""Quadric edge collapse: the compiled kernel against its Python twin, the placement against a
direct solve, and the properties a start needs (count, watertight, borders, corners)."""

from __future__ import annotations

import numpy as np
import pytest
from mesh_factory import icosphere

from lookalike.init.quadric_collapse import (BORDER_WEIGHT, _placement, mesh_edges, quadric_collapse,
                                             quadric_collapse_python, vertex_quadrics)


def _bumpy_sphere(subdivisions: int = 3, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """An icosphere with a few smooth bumps and a little noise: no two edges cost the same."""
    mesh = icosphere(subdivisions)
    v = mesh.v_pos.double().numpy()
    rng = np.random.default_rng(seed)
    radius = 1.0 + 0.15 * np.sin(3.0 * v[:, 0]) * np.cos(2.0 * v[:, 1]) + 0.002 * rng.standard_normal(len(v))
    return v * radius[:, None], mesh.t_pos_idx.numpy()


def _cube(n: int) -> tuple[np.ndarray, np.ndarray]:
    """A closed unit cube, each face an ``n x n`` grid of quads split in two, welded."""
    vertices, faces = [], []
    s = np.linspace(0.0, 1.0, n + 1)
    a, b = np.meshgrid(s, s, indexing="ij")
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    q = (i * (n + 1) + j).ravel()
    grid = np.concatenate([np.stack([q, q + n + 1, q + 1], 1), np.stack([q + 1, q + n + 1, q + n + 2], 1)])
    for axis in range(3):
        for side in (0.0, 1.0):
            p = np.zeros((a.size, 3))
            p[:, axis] = side
            p[:, (axis + 1) % 3], p[:, (axis + 2) % 3] = a.ravel(), b.ravel()
            f = grid if side == 1.0 else grid[:, ::-1]
            faces.append(f + sum(len(x) for x in vertices))
            vertices.append(p)
    v, f = np.concatenate(vertices), np.concatenate(faces)
    key = np.round(v * 4 * n).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    return v[first], inverse.reshape(-1)[f]


def _cube_mesh(n: int):
    """``_cube(n)`` as a ``lookalike.asset.Mesh``."""
    import torch

    from lookalike.asset import Mesh

    v, f = _cube(n)
    return Mesh(v_pos=torch.from_numpy(v).float(), t_pos_idx=torch.from_numpy(f))


def _edge_uses(f: np.ndarray) -> np.ndarray:
    edges = np.sort(f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    return np.unique(edges, axis=0, return_counts=True)[1]


def _oriented_closed(f: np.ndarray) -> bool:
    directed = f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    return bool(np.all(_edge_uses(f) == 2) and len(np.unique(directed, axis=0)) == len(directed))


def _volume(v: np.ndarray, f: np.ndarray) -> float:
    c = v[f]
    return float(np.einsum("ij,ij->i", c[:, 0], np.cross(c[:, 1], c[:, 2])).sum() / 6.0)


@pytest.mark.parametrize("triangles", [600, 200, 40])
def test_the_kernel_matches_its_twin(triangles):
    v, f = _bumpy_sphere()
    fast, slow = quadric_collapse(v, f, triangles), quadric_collapse_python(v, f, triangles)
    assert np.array_equal(fast[1], slow[1])
    np.testing.assert_allclose(fast[0], slow[0], rtol=0, atol=1e-12)
    assert len(fast[1]) in (triangles, triangles - 1)


def test_the_kernel_matches_its_twin_on_an_open_sheet():
    v, f = _bumpy_sphere(seed=1)
    keep = v[f].mean(1)[:, 2] < 0.4                         # a sphere with a hole cut in its top
    used, f = np.unique(f[keep], return_inverse=True)
    v, f = v[used], f.reshape(-1, 3)
    fast, slow = quadric_collapse(v, f, 150), quadric_collapse_python(v, f, 150)
    assert np.array_equal(fast[1], slow[1])
    np.testing.assert_allclose(fast[0], slow[0], rtol=0, atol=1e-12)


def test_placement_is_the_least_error_point():
    rng = np.random.default_rng(3)
    planes = rng.standard_normal((6, 4))
    planes[:, :3] /= np.linalg.norm(planes[:, :3], axis=1, keepdims=True)
    q4 = planes.T @ planes
    q = q4[np.triu_indices(4)]
    solution = np.linalg.solve(q4[:3, :3], -q4[:3, 3])
    cost, *point = _placement(q, solution + 0.1, solution - 0.1)
    np.testing.assert_allclose(point, solution, atol=1e-9)
    homogeneous = np.append(solution, 1.0)
    assert cost == pytest.approx(homogeneous @ q4 @ homogeneous, abs=1e-9)


def test_placement_far_from_the_edge_falls_back_to_the_best_of_its_ends_and_midpoint():
    normal = np.array([0.0, 0.0, 1.0, 0.0])                  # the plane z = 0, and a near-parallel one
    other = np.array([0.0, 1e-3, 1.0, -1e-3])
    other[:3] /= np.linalg.norm(other[:3])
    q4 = np.outer(normal, normal) + np.outer(other, other) + 1e-6 * np.diag([1.0, 0.0, 0.0, 0.0])
    ends = np.array([0.0, 0.0, 0.0]), np.array([0.1, 0.0, 0.0])
    _, *point = _placement(q4[np.triu_indices(4)], *ends)
    assert any(np.allclose(point, p) for p in (ends[0], ends[1], (ends[0] + ends[1]) / 2))


def test_quadrics_vanish_on_their_own_surface_and_grow_off_it():
    v, f = _bumpy_sphere()
    q = vertex_quadrics(v, f)
    upper = np.triu_indices(4)
    full = np.zeros((len(v), 4, 4))
    full[:, upper[0], upper[1]] = q
    full = full + np.transpose(full, (0, 2, 1)) - full * np.eye(4)
    on = np.einsum("vi,vij,vj->v", np.c_[v, np.ones(len(v))], full, np.c_[v, np.ones(len(v))])
    off = np.einsum("vi,vij,vj->v", np.c_[1.05 * v, np.ones(len(v))], full, np.c_[1.05 * v, np.ones(len(v))])
    assert np.abs(on).max() < 1e-12 and off.min() > 0.0


def test_edges_are_each_listed_once():
    v, f = _bumpy_sphere(2)
    edges = mesh_edges(f)
    assert len(edges) == 3 * len(f) // 2 and np.all(edges[:, 0] < edges[:, 1])


def test_quadrics_and_edges_match_a_loop_over_the_faces():
    """The quadrics summed at once (``np.bincount``) and the edges found by key equal those of a
    plain loop over the faces of a sheet with a border: each face's plane at its corners, weighted
    by area, and each border edge's side plane at its ends, weighted by ``BORDER_WEIGHT`` times its
    length squared."""
    v, f = _bumpy_sphere(seed=1)
    keep = v[f].mean(1)[:, 2] < 0.4
    used, f = np.unique(f[keep], return_inverse=True)
    v, f = v[used], f.reshape(-1, 3)
    expected = np.zeros((len(v), 10))
    upper = np.triu_indices(4)
    faces_of = {}
    for k, (a, b, c) in enumerate(f):
        cross = np.cross(v[b] - v[a], v[c] - v[a])
        n = cross / np.linalg.norm(cross)
        plane = np.append(n, -n @ v[a])
        for w in (a, b, c):
            expected[w] += 0.5 * np.linalg.norm(cross) * np.outer(plane, plane)[upper]
        for e in ((a, b), (b, c), (c, a)):
            faces_of.setdefault(tuple(sorted(e)), []).append((k, e, n))
    for (k, (a, b), n) in (items[0] for items in faces_of.values() if len(items) == 1):
        side = np.cross(v[b] - v[a], n)
        side /= np.linalg.norm(side)
        plane = np.append(side, -side @ v[a])
        for w in (a, b):
            expected[w] += BORDER_WEIGHT * np.sum((v[b] - v[a]) ** 2) * np.outer(plane, plane)[upper]
    assert sum(len(items) == 1 for items in faces_of.values()) > 10
    np.testing.assert_allclose(vertex_quadrics(v, f), expected, rtol=1e-9, atol=1e-15)
    assert mesh_edges(f).tolist() == sorted(list(e) for e in faces_of)


def test_a_closed_surface_stays_closed_and_keeps_its_volume():
    v, f = _bumpy_sphere(4)
    out_v, out_f = quadric_collapse(v, f, 500)
    assert len(out_f) in (499, 500) and _oriented_closed(out_f)
    assert _volume(out_v, out_f) == pytest.approx(_volume(v, f), rel=0.01)


def test_a_finely_gridded_cube_collapses_to_its_corners():
    """The flat faces cost nothing and the corners are where three planes meet: a cube tessellated
    finely goes down to twelve triangles on its eight corners, as no library's collapse did."""
    v, f = _cube(12)
    out_v, out_f = quadric_collapse(v, f, 12)
    assert len(out_f) == 12 and _oriented_closed(out_f)
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    assert np.abs(np.sort(out_v, axis=0) - np.sort(corners, axis=0)).max() < 1e-9


def test_an_open_border_stays_where_it_was():
    x, y = np.meshgrid(np.linspace(0, 1, 21), np.linspace(0, 1, 21), indexing="ij")
    v = np.stack([x.ravel(), y.ravel(), 0.1 * np.sin(3 * x.ravel()) * np.cos(2 * y.ravel())], 1)
    i, j = np.meshgrid(np.arange(20), np.arange(20), indexing="ij")
    a = (i * 21 + j).ravel()
    f = np.concatenate([np.stack([a, a + 21, a + 1], 1), np.stack([a + 1, a + 21, a + 22], 1)])
    out_v, out_f = quadric_collapse(v, f, 100)
    uses = np.sort(out_f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    edges, counts = np.unique(uses, axis=0, return_counts=True)
    border = np.unique(edges[counts == 1])
    on_edge = np.minimum.reduce([out_v[border, 0], 1 - out_v[border, 0], out_v[border, 1], 1 - out_v[border, 1]])
    assert len(out_f) in (99, 100) and np.abs(on_edge).max() < 1e-3


def test_a_fields_decimation_offers_the_collapse_and_only_a_fields():
    """``FIELD_CANDIDATES`` runs the collapse beside the libraries (on a finely gridded cube it
    lands on the count, on the corners); ``CANDIDATES`` does not offer it."""
    from lookalike.init.decimate import CANDIDATES, FIELD_CANDIDATES, QUADRIC_COLLAPSE, decimate_reported

    mesh = _cube_mesh(12)
    _, report = decimate_reported(mesh, 12, settings=FIELD_CANDIDATES)
    assert any(c["setting"] == QUADRIC_COLLAPSE and c["triangles"] == 12 and c["mean"] < 1e-6
               for c in report.candidates)
    _, usual = decimate_reported(mesh, 12)
    assert all(c["setting"] != QUADRIC_COLLAPSE for c in usual.candidates)
    assert all(s.simplifier != QUADRIC_COLLAPSE for s in CANDIDATES)


def test_a_fields_large_input_is_coarsened_by_the_collapse_too(monkeypatch):
    """The coarse pass of a large input runs the collapse where it is a candidate (``coarse_setting``),
    fast-simplification's first setting elsewhere; the cube still lands on its corners."""
    import sys

    from lookalike.init.decimate import CANDIDATES, FIELD_CANDIDATES, QUADRIC_COLLAPSE, SCHEDULE, decimate_reported

    decimation = sys.modules["lookalike.init.decimate"]
    coarse_pass, passes = decimation._coarse_pass, []
    monkeypatch.setattr(decimation, "COARSE_ABOVE", 400)
    monkeypatch.setattr(decimation, "COARSE_TRIANGLES", 200)
    monkeypatch.setattr(decimation, "_coarse_pass", lambda *args: passes.append(args[3]) or coarse_pass(*args))
    mesh = _cube_mesh(12)                                               # 1,728 triangles
    out, report = decimate_reported(mesh, 12, settings=FIELD_CANDIDATES)
    assert [s.simplifier for s in passes] == [QUADRIC_COLLAPSE]
    assert out.num_triangles == 12 and report.mean < 1e-6
    passes.clear()
    decimate_reported(mesh, 12, settings=CANDIDATES)
    assert passes == [SCHEDULE[0]]
