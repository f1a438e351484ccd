"""Small synthetic assets and helpers shared by the I/O, tangent and atlas tests."""

from __future__ import annotations

import math
import os
import shutil
import subprocess
from pathlib import Path

import pytest
import torch

from lookalike.asset import Asset, Material, Mesh, Texture
from lookalike.asset.normals import weld_normals

NPM_CACHE = Path(os.environ.get("LOOKALIKE_NPM_CACHE", Path.home() / ".cache" / "lookalike-tests" / "npm"))


def plane(n: int = 4, dtype=torch.float32) -> Mesh:
    """An ``n x n`` vertex grid on z = 0 spanning [0, 1]^2, counter-clockwise seen from +z, with
    u = x and v = 1 - y (glTF convention: image top at y = 1)."""
    ys, xs = torch.meshgrid(torch.linspace(0, 1, n, dtype=dtype), torch.linspace(0, 1, n, dtype=dtype), indexing="ij")
    v_pos = torch.stack([xs, ys, torch.zeros_like(xs)], dim=-1).reshape(-1, 3)
    idx = torch.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].reshape(-1), idx[:-1, 1:].reshape(-1), idx[1:, :-1].reshape(-1), idx[1:, 1:].reshape(-1)
    t_pos_idx = torch.cat([torch.stack([a, b, d], 1), torch.stack([a, d, c], 1)])
    v_tex = torch.stack([v_pos[:, 0], 1 - v_pos[:, 1]], dim=-1)
    return Mesh(v_pos=v_pos, t_pos_idx=t_pos_idx, uv=[(v_tex, t_pos_idx.clone())])


def uv_sphere(n_lat: int = 12, n_lon: int = 24, dtype=torch.float32) -> Mesh:
    """A unit UV sphere: positions welded (one vertex per pole), UVs with a seam at u = 0/1
    (``n_lon + 1`` columns of UVs) and per-triangle pole UVs; u grows eastwards
    (counter-clockwise about +z), v = 0 at the north pole."""
    lat = torch.linspace(0, math.pi, n_lat + 1, dtype=torch.float64)[1:-1]
    lon = torch.arange(n_lon, dtype=torch.float64) * (2 * math.pi / n_lon)
    ring = torch.stack([torch.sin(lat)[:, None] * torch.cos(lon)[None], torch.sin(lat)[:, None] * torch.sin(lon)[None],
                        torch.cos(lat)[:, None].expand(-1, n_lon)], dim=-1).reshape(-1, 3)
    v_pos = torch.cat([torch.tensor([[0.0, 0, 1]], dtype=torch.float64), ring,
                       torch.tensor([[0.0, 0, -1]], dtype=torch.float64)]).to(dtype)
    rings = n_lat - 1
    south = 1 + rings * n_lon
    # UVs: grid (rings x (n_lon + 1)), then per-column pole UVs (north, south).
    us = torch.arange(n_lon + 1, dtype=torch.float64) / n_lon
    vs = torch.arange(1, n_lat, dtype=torch.float64) / n_lat
    grid_uv = torch.stack([us[None].expand(rings, -1), vs[:, None].expand(-1, n_lon + 1)], dim=-1).reshape(-1, 2)
    pole_u = (torch.arange(n_lon, dtype=torch.float64) + 0.5) / n_lon
    north_uv = torch.stack([pole_u, torch.zeros(n_lon, dtype=torch.float64)], -1)
    south_uv = torch.stack([pole_u, torch.ones(n_lon, dtype=torch.float64)], -1)
    v_tex = torch.cat([grid_uv, north_uv, south_uv]).to(dtype)
    g = rings * (n_lon + 1)
    j = torch.arange(n_lon)
    jn = (j + 1) % n_lon

    def pos(r, c):
        return 1 + r * n_lon + c

    def tex(r, c):
        return r * (n_lon + 1) + c

    tris_p, tris_t = [torch.stack([torch.zeros_like(j), pos(0, j), pos(0, jn)], 1)], \
        [torch.stack([g + j, tex(0, j), tex(0, j + 1)], 1)]
    r = torch.arange(rings - 1)[:, None].expand(-1, n_lon).reshape(-1)
    c = j[None].expand(rings - 1, -1).reshape(-1)
    cn = (c + 1) % n_lon
    tris_p += [torch.stack([pos(r, c), pos(r + 1, c), pos(r + 1, cn)], 1),
               torch.stack([pos(r, c), pos(r + 1, cn), pos(r, cn)], 1)]
    tris_t += [torch.stack([tex(r, c), tex(r + 1, c), tex(r + 1, c + 1)], 1),
               torch.stack([tex(r, c), tex(r + 1, c + 1), tex(r, c + 1)], 1)]
    tris_p.append(torch.stack([pos(rings - 1, j), torch.full_like(j, south), pos(rings - 1, jn)], 1))
    tris_t.append(torch.stack([tex(rings - 1, j), g + n_lon + j, tex(rings - 1, j + 1)], 1))
    return Mesh(v_pos=v_pos, t_pos_idx=torch.cat(tris_p), uv=[(v_tex, torch.cat(tris_t))])


def box(n: int = 2, flat_normals: bool = True) -> Mesh:
    """The cube [-1, 1]^3, each face an ``n x n`` vertex grid, positions welded across faces,
    counter-clockwise outward; each face's UVs fill one tile of a 3 x 2 layout (v down). With
    ``flat_normals`` it carries authored face normals (three slots at every cube corner)."""
    coords = torch.linspace(-1, 1, n)
    ys, xs = torch.meshgrid(coords, coords, indexing="ij")
    idx = torch.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].reshape(-1), idx[:-1, 1:].reshape(-1), idx[1:, :-1].reshape(-1), idx[1:, 1:].reshape(-1)
    grid_tris = torch.cat([torch.stack([a, b, d], 1), torch.stack([a, d, c], 1)])
    positions, uvs, tris, normals = [], [], [], []
    for face, (axis, sign) in enumerate((a, s) for a in range(3) for s in (1.0, -1.0)):
        p = torch.zeros(n * n, 3)
        p[:, axis] = sign
        p[:, (axis + 1) % 3] = xs.reshape(-1)
        p[:, (axis + 2) % 3] = sign * ys.reshape(-1)
        tile = torch.tensor([face % 3, face // 3], dtype=torch.float32)
        uv01 = torch.stack([(xs.reshape(-1) + 1) / 2, (1 - ys.reshape(-1)) / 2], -1)
        uvs.append((tile + 0.05 + 0.9 * uv01) / torch.tensor([3.0, 2.0]))
        tris.append(grid_tris + face * n * n)
        positions.append(p)
        normals.append(torch.zeros(len(grid_tris), 3, 3).index_fill_(2, torch.tensor([axis]), sign))
    v_pos, weld = torch.unique(torch.cat(positions), dim=0, return_inverse=True)
    t_tex_idx = torch.cat(tris)
    t_pos_idx = weld[t_tex_idx]
    mesh = Mesh(v_pos=v_pos, t_pos_idx=t_pos_idx, uv=[(torch.cat(uvs), t_tex_idx)])
    if flat_normals:
        mesh.v_nrm, mesh.t_nrm_idx = weld_normals(t_pos_idx, torch.cat(normals))
    return mesh


def mirrored_plane(n: int = 5) -> Mesh:
    """A plane whose right half mirrors the left half's UVs (u = 1 - |2x - 1|): a mirror seam
    sharing UV coordinates along x = 0.5, as symmetric game assets have."""
    mesh = plane(n)
    v_tex = mesh.uv[0][0].clone()
    v_tex[:, 0] = 1 - (2 * mesh.v_pos[:, 0] - 1).abs()
    return Mesh(v_pos=mesh.v_pos, t_pos_idx=mesh.t_pos_idx, uv=[(v_tex, mesh.t_pos_idx.clone())])


def bumpy_normal_map(size: int = 32) -> torch.Tensor:
    """``[size, size, 3]`` unit tangent-space normals of a smooth bump pattern."""
    y, x = torch.meshgrid(torch.linspace(0, 1, size), torch.linspace(0, 1, size), indexing="ij")
    n = torch.stack([0.4 * torch.sin(2 * math.pi * x) * torch.cos(4 * math.pi * y),
                     0.3 * torch.cos(2 * math.pi * (x + y)), torch.ones_like(x)], dim=-1)
    return n / n.norm(dim=-1, keepdim=True)


def gradient_texture(size: int, channels: int, seed: int = 0) -> torch.Tensor:
    """``[size, size, channels]`` smooth values in [0.1, 0.9] (survives 8-bit quantisation well)."""
    g = torch.Generator().manual_seed(seed)
    y, x = torch.meshgrid(torch.linspace(0, 1, size), torch.linspace(0, 1, size), indexing="ij")
    phase = torch.rand(channels, generator=g) * 6.28
    return 0.5 + 0.4 * torch.sin(3 * x[..., None] + 2 * y[..., None] + phase)


def two_material_asset(normal_map: bool = True) -> Asset:
    """A UV sphere whose northern triangles use a textured, normal-mapped material and southern
    ones a constant blended material."""
    mesh = uv_sphere(8, 16)
    centroid_z = mesh.v_pos[mesh.t_pos_idx].mean(1)[:, 2]
    mesh.t_mat_idx = (centroid_z < 0).to(torch.int64)
    textured = Material(
        name="textured",
        kd=Texture(torch.cat([gradient_texture(16, 3, 1), torch.ones(16, 16, 1)], -1)),
        ks=Texture(torch.cat([torch.full((16, 16, 1), 0.2), gradient_texture(16, 2, 2)], -1)),
        normal=Texture(bumpy_normal_map(16)) if normal_map else None,
    )
    blended = Material(name="blended", kd=Texture.constant([0.2, 0.4, 0.6, 0.5]), ks=Texture.constant([0.0, 0.7, 1.0]),
                       alpha_mode="BLEND", double_sided=True)
    return Asset(mesh=mesh, materials=[textured, blended])


def npm_package(name: str) -> Path:
    """``node_modules`` folder holding npm package ``name`` (``name@version`` pins one), installed
    once into a cache outside the repository (``$LOOKALIKE_NPM_CACHE`` or
    ``~/.cache/lookalike-tests/npm``); skips the test with the reason where node or npm is missing
    or the registry is unreachable."""
    if shutil.which("node") is None or shutil.which("npm") is None:
        pytest.skip(f"needs node and npm to run the npm package {name!r}")
    modules = NPM_CACHE / "node_modules"
    folder = name.rsplit("@", 1)[0] if name.rfind("@") > 0 else name
    if not (modules / folder / "package.json").is_file():
        NPM_CACHE.mkdir(parents=True, exist_ok=True)
        result = subprocess.run(["npm", "install", "--no-audit", "--no-fund", "--prefix", str(NPM_CACHE), name],
                                capture_output=True, text=True, timeout=300)
        if result.returncode != 0 or not (modules / folder / "package.json").is_file():
            pytest.skip(f"cannot install npm package {name!r} (registry unreachable?): {result.stderr.strip()[-300:]}")
    return modules


def covered_texels(mesh: Mesh, material: int, height: int, width: int) -> torch.Tensor:
    """``[H, W]`` bool: texels whose centres the triangles of ``material`` cover in UV set 0."""
    from lookalike.asset.uv_raster import rasterize_uv

    uv = mesh.uv[0][0][mesh.uv[0][1]][mesh.t_mat_idx == material].numpy()
    rows, cols, _, _ = rasterize_uv(uv, height, width)
    mask = torch.zeros(height, width, dtype=torch.bool)
    mask[torch.from_numpy(rows), torch.from_numpy(cols)] = True
    return mask
