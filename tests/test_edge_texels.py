"""Texels beside hard edges taken from further in (``asset.edge_texels``): a box's faces lose a
rim painted along the cube's edges and keep everything else, a smooth sphere and an alpha-tested
material are left alone, and a chart with no texel further in keeps its own; ``hard_sides`` and
``near_hard_sides`` agree with loops over the sides."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import torch

from io_factory import box, uv_sphere
from lookalike.asset import Asset, Material, Mesh, Texture
from lookalike.asset.edge_texels import near_hard_sides, with_texels_from_inside
from lookalike.asset.normals import DEFAULT_CREASE_ANGLE, crease_normal_index, hard_sides
from lookalike.jobs.written_model import EDGE_TEXELS_TAKEN, with_edge_texels_taken
from mesh_factory import icosphere

RIM = 5.0


def hard_sides_loop(mesh: Mesh, crease_angle: float = DEFAULT_CREASE_ANGLE) -> torch.Tensor:
    """``hard_sides`` side by side: a side is soft where exactly one other side joins the same two
    positions the other way round, both triangles have area, their normals part by at most
    ``crease_angle`` and their slots agree at both ends."""
    tris = mesh.t_pos_idx.tolist()
    slots = (mesh.t_pos_idx if mesh.t_nrm_idx is None else mesh.t_nrm_idx).tolist()
    p = mesh.v_pos.double()

    def normal(t):
        a, b, c = (p[i] for i in tris[t])
        n = torch.linalg.cross(b - a, c - a)
        return n / n.norm() if n.norm() > 0 else None

    hard = torch.ones(len(tris), 3, dtype=torch.bool)
    for t, corners in enumerate(tris):
        for k in range(3):
            a, b = corners[k], corners[(k + 1) % 3]
            joined = [(u, j) for u, other in enumerate(tris) for j in range(3)
                      if {other[j], other[(j + 1) % 3]} == {a, b} and (u, j) != (t, k)]
            if len(joined) != 1:
                continue
            u, j = joined[0]
            n1, n2 = normal(t), normal(u)
            if tris[u][j] != b or n1 is None or n2 is None or float(n1 @ n2) < math.cos(math.radians(crease_angle)):
                continue
            hard[t, k] = not (slots[t][k] == slots[u][(j + 1) % 3] and slots[t][(k + 1) % 3] == slots[u][j])
    return hard


def test_hard_sides_agree_with_a_loop_on_a_box_a_sphere_and_an_open_mesh():
    cube = box(3)
    sphere = uv_sphere(6, 10)
    creased = dataclasses.replace(sphere, t_nrm_idx=crease_normal_index(sphere.v_pos, sphere.t_pos_idx, 20.0))
    lid = icosphere(1)
    open_cap = Mesh(v_pos=lid.v_pos, t_pos_idx=lid.t_pos_idx[lid.v_pos[lid.t_pos_idx].mean(1)[:, 2] > -0.2])
    for mesh in (cube, sphere, creased, open_cap):
        assert torch.equal(hard_sides(mesh.v_pos, mesh.t_pos_idx, mesh.t_nrm_idx), hard_sides_loop(mesh))
    sides = {name: hard_sides(m.v_pos, m.t_pos_idx, m.t_nrm_idx)
             for name, m in (("cube", cube), ("sphere", sphere), ("creased", creased), ("open", open_cap))}
    assert int(sides["cube"].sum()) == 6 * 4 * 2              # each face's border, two sides per cube edge
    assert not sides["sphere"].any()
    assert sides["creased"].any() and sides["open"].any()


def boxed_asset(size: int, alpha_mode: str = "OPAQUE") -> tuple[Asset, torch.Tensor, torch.Tensor]:
    """The box (its faces one tile each of a 3 x 2 layout, hard at the cube's edges) with a base
    colour map ``size`` square: a smooth ramp, and ``RIM`` on the texels whose centres lie
    within one texel of a tile's border (the cube's edges) inside it. Also ``[S, S]`` bool masks:
    the texels inside the tiles, and those of them two texels or more from a tile's border."""
    mesh = box(3)
    centre = (torch.arange(size, dtype=torch.float64) + 0.5) / size
    v, u = torch.meshgrid(centre, centre, indexing="ij")
    inside, rim, far = (torch.zeros(size, size, dtype=torch.bool) for _ in range(3))
    for tile in range(6):
        u0, v0 = (tile % 3 + 0.05) / 3, (tile // 3 + 0.05) / 2
        u1, v1 = u0 + 0.9 / 3, v0 + 0.9 / 2
        gap = torch.minimum(torch.minimum(u - u0, u1 - u), torch.minimum(v - v0, v1 - v)) * size   # texels to the border
        inside |= gap > 0
        rim |= (gap > 0) & (gap < 1)
        far |= gap >= 2
    ramp = torch.stack([u, v, 0.5 * (u + v), torch.ones_like(u)], -1).float()
    ramp[rim] = RIM
    material = Material(kd=Texture(ramp), alpha_mode=alpha_mode)
    return Asset(mesh=mesh, materials=[material]), inside, far


def test_a_rim_along_a_box_s_edges_is_taken_from_further_in_and_the_rest_is_kept():
    asset, inside, far = boxed_asset(96)
    taken = with_texels_from_inside(asset)
    before, after = asset.materials[0].kd.data, taken.materials[0].kd.data
    assert (before[inside] == RIM).any()
    assert not (after[inside] == RIM).any()                        # no rim is left on a face
    assert torch.equal(after[far], before[far])                    # the faces' own texels are kept
    assert (after != RIM).all()                                    # nor in the padding a lookup reads
    moved = inside & (before[..., 0] == RIM)
    rows, cols = torch.nonzero(moved, as_tuple=True)
    for r, c in zip(rows.tolist(), cols.tolist()):                 # each from a texel of its own face nearby
        near = before[max(r - 2, 0):r + 3, max(c - 2, 0):c + 3].reshape(-1, 4)
        assert (near == after[r, c]).all(-1).any()


def test_a_smooth_sphere_an_alpha_tested_material_and_constant_maps_are_left_as_they_are():
    sphere = uv_sphere(8, 16)
    mapped = Material(kd=Texture(torch.rand(32, 32, 4)), normal=Texture(torch.nn.functional.normalize(torch.rand(32, 32, 3) + 1, dim=-1)))
    assert with_texels_from_inside(Asset(mesh=sphere, materials=[mapped])) is None
    asset, _, _ = boxed_asset(64, alpha_mode="MASK")
    assert with_texels_from_inside(asset) is None
    assert with_texels_from_inside(Asset(mesh=box(3), materials=[Material()])) is None


def test_a_chart_with_no_texel_further_in_keeps_its_own():
    asset, inside, _ = boxed_asset(6)
    before = asset.materials[0].kd.data
    taken = with_texels_from_inside(asset)
    after = before if taken is None else taken.materials[0].kd.data
    assert torch.equal(after[inside], before[inside])


def test_the_run_is_offered_each_model_with_its_edge_texels_taken_where_that_changes_it():
    asset, _, _ = boxed_asset(64)
    sphere = Asset(mesh=uv_sphere(8, 16), materials=[Material(kd=Texture(torch.rand(16, 16, 4)))])
    offered = with_edge_texels_taken({"ours": asset, "another": sphere})
    assert list(offered) == [f"ours, {EDGE_TEXELS_TAKEN}"]


def test_near_hard_sides_agrees_with_every_texel_measured_against_every_hard_side():
    mesh = box(3)
    hard = hard_sides(mesh.v_pos, mesh.t_pos_idx, mesh.t_nrm_idx).numpy()
    corner_uv = mesh.uv[0][0].double()[mesh.uv[0][1]].numpy()
    height, width = 20, 28
    rows, cols = np.meshgrid(np.arange(height), np.arange(width), indexing="ij")
    centres = np.stack([cols, rows], -1).reshape(-1, 2).astype(np.float64)
    xy = corner_uv * np.array([width, height]) - 0.5
    closest = np.full(len(centres), np.inf)
    for t, k in zip(*np.nonzero(hard)):
        a, b = xy[t, k], xy[t, (k + 1) % 3]
        onto = np.clip((centres - a) @ (b - a) / max((b - a) @ (b - a), 1e-24), 0, 1)
        closest = np.minimum(closest, np.linalg.norm(centres - (a + onto[:, None] * (b - a)), axis=-1))
    for distance in (0.5, 1.0, 1.7):
        expected = (closest < distance).reshape(height, width)
        assert np.array_equal(near_hard_sides(corner_uv, hard, height, width, distance), expected)
