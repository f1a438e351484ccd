"""Mesh operations against naive per-vertex/per-triangle loop implementations, and their
gradients against finite differences (float64)."""

from __future__ import annotations

import math

import pytest
import torch

from lookalike.asset import Mesh
from lookalike.asset.laplacian import UniformLaplacian, unique_edges
from lookalike.asset.normals import vertex_normals
from lookalike.asset.subdivide import EdgeMidpointTopology, MeshSubdivision, subdivide


def grid_mesh(n: int = 4, dtype=torch.float64, noise: float = 0.1) -> Mesh:
    """An ``n x n`` quad grid (2 (n-1)^2 triangles) with jittered heights and one UV set
    whose index buffer differs from the positions' (a seam down the middle column)."""
    ys, xs = torch.meshgrid(torch.linspace(0, 1, n, dtype=dtype), torch.linspace(0, 1, n, dtype=dtype), indexing="ij")
    z = noise * torch.sin(7 * xs + 3 * ys)
    v_pos = torch.stack([xs, ys, z], dim=-1).reshape(-1, 3)
    idx = torch.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].reshape(-1), idx[:-1, 1:].reshape(-1), idx[1:, :-1].reshape(-1), idx[1:, 1:].reshape(-1)
    t_pos_idx = torch.cat([torch.stack([a, b, d], 1), torch.stack([a, d, c], 1)])
    # UVs: duplicate every vertex, the triangles of the first half use the duplicates (a seam).
    v_tex = torch.cat([v_pos[:, :2], v_pos[:, :2] + 0.5]).to(torch.float64)
    t_tex_idx = t_pos_idx.clone()
    t_tex_idx[: t_pos_idx.shape[0] // 2] += n * n
    return Mesh(v_pos=v_pos, t_pos_idx=t_pos_idx, uv=[(v_tex, t_tex_idx)])


def tetrahedron(dtype=torch.float64) -> Mesh:
    v_pos = torch.tensor([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=dtype)
    t_pos_idx = torch.tensor([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    return Mesh(v_pos=v_pos, t_pos_idx=t_pos_idx)


def naive_normals(v_pos, t_pos_idx):
    out = [[0.0, 0.0, 0.0] for _ in range(len(v_pos))]
    for tri in t_pos_idx.tolist():
        p = [v_pos[i].tolist() for i in tri]
        e1 = [p[1][k] - p[0][k] for k in range(3)]
        e2 = [p[2][k] - p[0][k] for k in range(3)]
        n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]]
        for i in tri:
            out[i] = [out[i][k] + n[k] for k in range(3)]
    result = []
    for n in out:
        length = math.sqrt(sum(c * c for c in n))
        result.append([c / length for c in n] if length > 0 else [0.0, 0.0, 1.0])
    return torch.tensor(result, dtype=torch.float64)


def naive_laplacian(v_pos, t_pos_idx):
    neighbours = [set() for _ in range(len(v_pos))]
    for a, b, c in t_pos_idx.tolist():
        for i, j in ((a, b), (b, c), (c, a)):
            if i != j:
                neighbours[i].add(j)
                neighbours[j].add(i)
    rows = []
    for i, ring in enumerate(neighbours):
        if not ring:
            rows.append([0.0, 0.0, 0.0])
            continue
        mean = [sum(v_pos[j][k].item() for j in ring) / len(ring) for k in range(3)]
        rows.append([v_pos[i][k].item() - mean[k] for k in range(3)])
    return torch.tensor(rows, dtype=torch.float64)


def naive_subdivide(v_pos, t_idx):
    """Returns (positions, set of triangles as frozensets of position tuples)."""
    points = [tuple(p) for p in v_pos.tolist()]
    triangles = []
    for a, b, c in t_idx.tolist():
        pa, pb, pc = points[a], points[b], points[c]
        mid = lambda p, q: tuple((x + y) / 2 for x, y in zip(p, q))  # noqa: E731
        mab, mbc, mca = mid(pa, pb), mid(pb, pc), mid(pc, pa)
        triangles += [(pa, mab, mca), (mab, pb, mbc), (mca, mbc, pc), (mab, mbc, mca)]
    return triangles


def rotate_to_canonical(tri):
    """A triangle of position tuples, rotated so the smallest corner comes first (keeps winding)."""
    k = min(range(3), key=lambda i: tri[i])
    return tuple(tri[k:] + tri[:k])


def rounded(t):
    return tuple(tuple(round(x, 9) for x in p) for p in t)


@pytest.mark.parametrize("mesh", [grid_mesh(), tetrahedron()], ids=["grid", "tetrahedron"])
def test_vertex_normals_match_loop(mesh):
    expected = naive_normals(mesh.v_pos, mesh.t_pos_idx)
    assert torch.allclose(vertex_normals(mesh.v_pos, mesh.t_pos_idx), expected, atol=1e-12)


def test_vertex_normals_degenerate_and_unreferenced_vertices():
    v_pos = torch.tensor([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0], [5, 5, 5]], requires_grad=True)
    t_pos_idx = torch.tensor([[0, 1, 2], [0, 1, 3]])  # a zero-area triangle; vertex 4 unused
    n = vertex_normals(v_pos, t_pos_idx)
    assert torch.isfinite(n).all()
    assert torch.allclose(n[2], torch.tensor([0.0, 0, 1])) and torch.allclose(n[4], torch.tensor([0.0, 0, 1]))
    assert torch.allclose(n[0], torch.tensor([0.0, 0, 1]))
    n.sum().backward()
    assert torch.isfinite(v_pos.grad).all()


def test_vertex_normals_gradient():
    mesh = grid_mesh(3)
    pos = mesh.v_pos.clone().requires_grad_(True)
    assert torch.autograd.gradcheck(lambda p: vertex_normals(p, mesh.t_pos_idx), (pos,))


@pytest.mark.parametrize("mesh", [grid_mesh(), tetrahedron()], ids=["grid", "tetrahedron"])
def test_laplacian_matches_loop(mesh):
    expected = naive_laplacian(mesh.v_pos, mesh.t_pos_idx)
    assert torch.allclose(UniformLaplacian(mesh.t_pos_idx, mesh.num_vertices).differentials(mesh.v_pos), expected,
                          atol=1e-12)


def test_laplacian_isolated_vertex_and_duplicate_edges():
    v_pos = torch.tensor([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [9, 9, 9]], dtype=torch.float64)
    t_pos_idx = torch.tensor([[0, 1, 2], [0, 2, 1]])  # both orientations: edges counted once
    delta = UniformLaplacian(t_pos_idx, len(v_pos)).differentials(v_pos)
    assert torch.allclose(delta, naive_laplacian(v_pos, t_pos_idx))
    assert torch.equal(delta[3], torch.zeros(3, dtype=torch.float64))
    assert unique_edges(t_pos_idx).tolist() == [[0, 1], [0, 2], [1, 2]]


def test_laplacian_loss_absolute_and_relative():
    mesh = grid_mesh()
    lap = UniformLaplacian(mesh.t_pos_idx, mesh.num_vertices)
    delta = naive_laplacian(mesh.v_pos, mesh.t_pos_idx)
    assert torch.allclose(lap.loss(mesh.v_pos), (delta ** 2).sum(-1).mean())
    assert lap.loss(mesh.v_pos, reference_delta=lap.differentials(mesh.v_pos)).item() == 0.0
    moved = mesh.v_pos + 0.01 * torch.randn_like(mesh.v_pos)
    expected = ((naive_laplacian(moved, mesh.t_pos_idx) - delta) ** 2).sum(-1).mean()
    assert torch.allclose(lap.loss(moved, reference_delta=delta), expected)
    # A translated mesh has the same differentials; float32 input works with the same operator.
    assert torch.allclose(lap.differentials((mesh.v_pos + 3.0).float()), delta.float(), atol=1e-5)


def test_laplacian_gradient():
    mesh = grid_mesh(3)
    lap = UniformLaplacian(mesh.t_pos_idx, mesh.num_vertices)
    ref = torch.randn(mesh.num_vertices, 3, dtype=torch.float64)
    pos = mesh.v_pos.clone().requires_grad_(True)
    assert torch.autograd.gradcheck(lambda p: lap.loss(p, ref), (pos,))


def test_subdivision_matches_loop():
    mesh = grid_mesh(3)
    fine = subdivide(mesh)
    assert fine.num_triangles == 4 * mesh.num_triangles
    # Each undirected edge gives exactly one new vertex (welded, no cracks).
    assert fine.num_vertices == mesh.num_vertices + unique_edges(mesh.t_pos_idx).shape[0]
    got = [rounded(rotate_to_canonical([tuple(p) for p in fine.v_pos[t].tolist()])) for t in fine.t_pos_idx]
    expected = [rounded(rotate_to_canonical(list(t))) for t in naive_subdivide(mesh.v_pos, mesh.t_pos_idx)]
    assert got == expected
    # UVs follow their own index buffer, the seam stays a seam.
    v_tex, t_tex_idx = mesh.uv[0]
    got_uv = [rounded(rotate_to_canonical([tuple(p) for p in fine.uv[0][0][t].tolist()])) for t in fine.uv[0][1]]
    expected_uv = [rounded(rotate_to_canonical(list(t))) for t in naive_subdivide(v_tex, t_tex_idx)]
    assert got_uv == expected_uv
    assert torch.equal(fine.t_mat_idx, torch.zeros(4 * mesh.num_triangles, dtype=torch.int64))


def test_subdivision_keeps_normals_colours_and_influences():
    mesh = tetrahedron(torch.float32)
    mesh.v_nrm = torch.nn.functional.normalize(mesh.v_pos - 0.25, dim=-1)
    mesh.t_nrm_idx = mesh.t_pos_idx.clone()
    mesh.v_color = torch.rand(4, 4)
    mesh.v_joints = torch.tensor([[0], [1], [2], [2]])
    mesh.v_weights = torch.ones(4, 1)
    fine = MeshSubdivision(mesh)(mesh)
    assert torch.allclose(fine.v_nrm.norm(dim=-1), torch.ones(fine.v_nrm.shape[0]))
    e = EdgeMidpointTopology(mesh.t_pos_idx, 4).edges
    assert torch.allclose(fine.v_color[4:], 0.5 * (mesh.v_color[e[:, 0]] + mesh.v_color[e[:, 1]]))
    assert fine.v_joints.shape == (10, 2) and torch.allclose(fine.v_weights.sum(-1), torch.ones(10))


def test_subdivision_gradient():
    mesh = grid_mesh(3)
    subdivision = MeshSubdivision(mesh)
    pos = mesh.v_pos.clone().requires_grad_(True)
    uv = mesh.uv[0][0].clone().requires_grad_(True)

    def fine(p, t):
        m = subdivision(Mesh(v_pos=p, t_pos_idx=mesh.t_pos_idx, uv=[(t, mesh.uv[0][1])]))
        return m.v_pos, m.uv[0][0]

    assert torch.autograd.gradcheck(fine, (pos, uv))


def test_subdivision_rejects_other_topology():
    with pytest.raises(ValueError):
        MeshSubdivision(grid_mesh(3))(grid_mesh(4))
