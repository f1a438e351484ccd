"""Re-expressing tangent-space normal maps between tangent frames, texel by texel, for files.

Inside lookalike a normal map lives in our frame (``lookalike.asset.frames``: ``vertex_tangents``
on the mesh's shading normals, ``Mesh.normals``). Files use another frame on the same normals (a
mesh read from a file keeps the file's normals): the TANGENT attribute where present, else
MikkTSpace of the mesh as stored (what Blender always does and what the glTF specification
prescribes). Readers convert file -> ours, writers ours -> MikkTSpace of the written mesh;
``on_own_normals`` moves a map from authored normals onto the geometry's own, and
``on_crease_normals`` from smooth normals onto normals split at the geometry's creases.

Frames are given per triangle corner and interpolated, and values re-expressed, as
``lookalike.asset.frames`` describes. Texels no triangle covers take the mean of converted
neighbours up to ``GUTTER_TEXELS`` deep (dilation) and keep their value further out. A texture
transform (KHR_texture_transform) moves where the triangles land in the texture; both frames are
built from the untransformed UVs.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import torch
from numba import njit

from ..asset import Asset, Material, Mesh
from ..asset.frames import corner_normals, corner_uvs, frame_at, our_corner_frame, reexpress_texels, unit
from ..asset.normals import DEFAULT_CREASE_ANGLE, crease_normal_index, split_at_both
from ..asset.uv_raster import apply_uv_transform, dilate, rasterize_uv
from ..kernel_cache import CACHE
from .mikktspace import mikktspace_tangents


GUTTER_TEXELS = 2
"""Texels past the triangles' coverage that file-format conversions also convert (by dilation)."""


def reexpress_normal_map_python(pixels: np.ndarray, uv: np.ndarray, src: tuple[np.ndarray, np.ndarray],
                                dst: tuple[np.ndarray, np.ndarray], gutter: int = 0) -> np.ndarray:
    """Plain NumPy twin of ``reexpress_normal_map`` (same arguments and result), built on
    ``rasterize_uv``; slow on large textures, kept to test the compiled kernel against."""
    height, width = pixels.shape[:2]
    rows, cols, tri, bary = rasterize_uv(uv, height, width)
    out = pixels.astype(np.float64, copy=True)
    out[rows, cols] = reexpress_texels(pixels[rows, cols].astype(np.float64), src, dst, tri, bary)
    covered = np.zeros((height, width), bool)
    covered[rows, cols] = True
    return _extend_into_gutter(out, covered, gutter)


def _extend_into_gutter(out: np.ndarray, covered: np.ndarray, gutter: int) -> np.ndarray:
    """``[H, W, 3]`` float32: converted texels dilated ``gutter`` texels into uncovered ones (so
    bilinear lookups at chart borders see converted values), renormalised; texels further out
    keep their value."""
    grown_values, grown = dilate(out, covered, gutter)
    ring = grown & ~covered
    out[ring] = unit(grown_values[ring].astype(np.float64))
    return out.astype(np.float32)


@njit(cache=CACHE)
def _reexpress_kernel(pixels, out, covered, xy, src_n, src_t, dst_n, dst_t):
    """Write ``out [H, W, 3]`` at texels covered by triangles ``xy [T, 3, 2]`` (texel-index space,
    ``uv * (W, H) - 0.5``) with ``pixels [H, W, 3]`` converted, and mark them in ``covered [H, W]``;
    triangles in order, so the last covering triangle wins."""
    height, width = out.shape[0], out.shape[1]
    for f in range(xy.shape[0]):
        ax, ay, bx, by, cx, cy = xy[f, 0, 0], xy[f, 0, 1], xy[f, 1, 0], xy[f, 1, 1], xy[f, 2, 0], xy[f, 2, 1]
        area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
        if area == 0.0:
            continue
        for row in range(int(np.ceil(min(ay, by, cy))), int(np.floor(max(ay, by, cy))) + 1):
            for col in range(int(np.ceil(min(ax, bx, cx))), int(np.floor(max(ax, bx, cx))) + 1):
                l0 = ((cx - bx) * (row - by) - (cy - by) * (col - bx)) / area
                l1 = ((ax - cx) * (row - cy) - (ay - cy) * (col - cx)) / area
                l2 = ((bx - ax) * (row - ay) - (by - ay) * (col - ax)) / area
                if l0 < -1e-9 or l1 < -1e-9 or l2 < -1e-9:
                    continue
                r, c = row % height, col % width
                t1x, t1y, t1z, b1x, b1y, b1z, n1x, n1y, n1z = frame_at(src_n, src_t, f, l0, l1, l2)
                t2x, t2y, t2z, b2x, b2y, b2z, n2x, n2y, n2z = frame_at(dst_n, dst_t, f, l0, l1, l2)
                m0, m1, m2 = pixels[r, c, 0], pixels[r, c, 1], pixels[r, c, 2]
                sx = m0 * t1x + m1 * b1x + m2 * n1x
                sy = m0 * t1y + m1 * b1y + m2 * n1y
                sz = m0 * t1z + m1 * b1z + m2 * n1z
                v0 = sx * t2x + sy * t2y + sz * t2z
                v1 = sx * b2x + sy * b2y + sz * b2z
                v2 = sx * n2x + sy * n2y + sz * n2z
                length = max(np.sqrt(v0 * v0 + v1 * v1 + v2 * v2), 1e-30)
                out[r, c, 0], out[r, c, 1], out[r, c, 2] = v0 / length, v1 / length, v2 / length
                covered[r, c] = True


def reexpress_normal_map(pixels: np.ndarray, uv: np.ndarray, src: tuple[np.ndarray, np.ndarray],
                         dst: tuple[np.ndarray, np.ndarray], gutter: int = 0) -> np.ndarray:
    """Convert a tangent-space normal map from frame ``src`` to frame ``dst`` (compiled kernel).

    Args:
        pixels: ``[H, W, 3]`` unit tangent-space normals in the ``src`` frame.
        uv: ``[T, 3, 2]`` corner UVs of the triangles that use the map.
        src, dst: ``(normals [T, 3, 3], tangents [T, 3, 4])`` corner frames.
        gutter: how many texels beyond the covered ones take dilated converted values.
    Returns:
        ``[H, W, 3]`` float32 unit normals in the ``dst`` frame; where several triangles cover a
        texel the last one wins; texels beyond the gutter keep their value.
    """
    height, width = pixels.shape[:2]
    source = np.ascontiguousarray(pixels, np.float64)
    out = source.copy()
    covered = np.zeros((height, width), bool)
    xy = np.asarray(uv, np.float64) * np.array([width, height]) - 0.5
    f64 = [np.ascontiguousarray(a, np.float64) for a in (*src, *dst)]
    _reexpress_kernel(source, out, covered, xy, *f64)
    return _extend_into_gutter(out, covered, gutter)


def _convert(mesh: Mesh, materials: list[Material], frames, to_ours: bool) -> list[Material]:
    """Materials with every normal map (and each of its own mip levels) converted between our
    frame on ``mesh`` and another; ``frames(uv_set) -> (normals, tangents)`` gives the other
    corner frame of a UV set (a file's)."""
    out = []
    t_mat_idx = mesh.t_mat_idx.numpy()
    cache = {}
    for index, material in enumerate(materials):
        normal = material.normal
        if normal is None or normal.uv_set >= len(mesh.uv) or not (t_mat_idx == index).any():
            out.append(material)
            continue
        used = t_mat_idx == index
        if normal.uv_set not in cache:
            cache[normal.uv_set] = (our_corner_frame(mesh, normal.uv_set), frames(normal.uv_set))
        ours, theirs = cache[normal.uv_set]
        src, dst = (theirs, ours) if to_ours else (ours, theirs)
        uv = apply_uv_transform(corner_uvs(mesh, normal.uv_set)[used], normal.transform)
        levels = [torch.from_numpy(reexpress_normal_map(level.detach().numpy(), uv, tuple(a[used] for a in src),
                                                        tuple(a[used] for a in dst), gutter=GUTTER_TEXELS))
                  for level in [normal.data, *(normal.mips or [])]]
        out.append(replace(material, normal=replace(normal, data=levels[0], mips=levels[1:] or None)))
    return out


def _mikktspace_frame(mesh: Mesh, uv_set: int) -> tuple[np.ndarray, np.ndarray]:
    """MikkTSpace corner frame of the mesh as stored or written (its shading normals, float32
    positions and UVs): ``(normals [T, 3, 3], tangents [T, 3, 4])`` float64."""
    normals = corner_normals(mesh)
    positions = mesh.v_pos.detach().float()[mesh.t_pos_idx].numpy()
    return normals, mikktspace_tangents(positions, normals, corner_uvs(mesh, uv_set)).astype(np.float64)


def import_normal_maps(mesh: Mesh, materials: list[Material], file_tangents: np.ndarray | None = None) -> list[Material]:
    """Materials with normal maps converted from the file's frame to ours.

    Args:
        mesh: the mesh as read, with the file's normals.
        file_tangents: ``[T, 3, 4]`` the file's corner tangents (glTF TANGENT), or ``None``; rows
            that are NaN (or all of them, for ``None``) use MikkTSpace of the file's mesh.
    """
    def frames(uv_set: int):
        normals, mikk = _mikktspace_frame(mesh, uv_set)
        tangents = mikk if file_tangents is None else np.where(np.isnan(file_tangents), mikk, file_tangents)
        return normals, tangents

    return _convert(mesh, materials, frames, to_ours=True)


def export_normal_maps(mesh: Mesh, materials: list[Material]) -> list[Material]:
    """Materials with normal maps converted from our frame to MikkTSpace of the mesh as written
    (its shading normals, float32 positions and UVs)."""
    return _convert(mesh, materials, lambda uv_set: _mikktspace_frame(mesh, uv_set), to_ours=False)


def on_own_normals(asset: Asset) -> Asset:
    """``asset`` shading as it does, on its geometry's own normals: the authored normals
    (``Mesh.v_nrm``) dropped for the split smooth normals of the positions (the normal slots
    kept), and every normal map re-expressed from our frame on the authored normals into ours on
    the new ones, so that the shading normal ``m.x t + m.y b + m.z n`` stays the same at every
    texel. Where shading normals tilt far from the facets (a displaced mesh shaded by its base's
    normals), renderers part from each other (they test the light and the view against the
    facets, or filter the map, each its own way); on normals that follow the facets the map holds
    only the residual and they agree. An asset without authored normals is returned as it is."""
    mesh = asset.mesh
    if mesh.v_nrm is None:
        return asset
    return _reframed(asset, replace(mesh, v_nrm=None))


def on_crease_normals(asset: Asset, crease_angle: float = DEFAULT_CREASE_ANGLE,
                      apart: torch.Tensor | None = None) -> Asset:
    """``asset`` shading as it does, on normals split at its geometry's creases: its normal
    slots split further wherever two triangles meet at more than ``crease_angle`` degrees
    (``crease_normal_index``, ``split_at_both``), and wherever the slots ``apart [T, 3]`` split
    (where given), the authored normals dropped, and every normal
    map re-expressed onto the new frames as ``on_own_normals`` does. A model fitted on smooth
    normals (Blender's pipeline shades its decimation so) leans its normals up to 45 degrees
    from the facets at a hard edge; renderers that test the light against the facets (Cycles'
    bump shadowing) draw those texels black, where on crease normals the map holds the lean and
    they agree with a rasterizer. Returned as it is where no slot splits and no normal is
    authored."""
    mesh = asset.mesh
    slots = mesh.t_pos_idx if mesh.t_nrm_idx is None else mesh.t_nrm_idx
    split = split_at_both(slots, crease_normal_index(mesh.v_pos, mesh.t_pos_idx, crease_angle))
    if apart is not None:
        split = split_at_both(split, apart)
    if mesh.v_nrm is None and int(split.max()) + 1 == len(torch.unique(slots)):
        return asset
    return _reframed(asset, replace(mesh, v_nrm=None, t_nrm_idx=split))


def _reframed(asset: Asset, own: Mesh) -> Asset:
    """``asset`` on ``own`` (its mesh with other shading normals), every normal map re-expressed
    from our frame on its mesh into ours on ``own``, texel by texel."""
    return replace(asset, mesh=own, materials=_convert(asset.mesh, asset.materials,
                                                       lambda uv_set: our_corner_frame(own, uv_set), to_ours=False))
