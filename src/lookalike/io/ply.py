"""PLY reader (binary and ASCII, via plyfile): positions, faces (fan-triangulated), vertex
colours (``red``/``green``/``blue``[/``alpha``], 8-bit or float, sRGB decoded to linear), vertex
normals (``nx``/``ny``/``nz``, ``lookalike.asset.normals.file_normals``) and texture coordinates (``s``/``t`` or ``u``/``v``, flipped to
glTF's v-down convention). PLY has no materials: the asset gets the default material."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import plyfile
import torch

from ..asset import Asset, Material, Mesh
from ..asset.normals import file_normals
from ..errors import AssetError
from .image_files import srgb_to_linear
from .registry import reader


def _fan(faces: list[np.ndarray]) -> np.ndarray:
    """``[T, 3]`` fan triangulation ``(f0, fi, fi+1)`` of polygons of any sizes, in face order
    (vectorised over the faces of each size)."""
    sizes = np.array([len(f) for f in faces], dtype=np.int64)
    first_triangle = np.cumsum(np.maximum(sizes - 2, 0)) - np.maximum(sizes - 2, 0)
    out = np.zeros((int(np.maximum(sizes - 2, 0).sum()), 3), np.int64)
    for size in np.unique(sizes[sizes >= 3]):
        ids = np.flatnonzero(sizes == size)
        polygons = np.stack([faces[i] for i in ids]).astype(np.int64)
        i = np.arange(1, size - 1)
        fan = np.stack([np.broadcast_to(polygons[:, :1], (len(ids), size - 2)), polygons[:, i], polygons[:, i + 1]], -1)
        out[(first_triangle[ids][:, None] + np.arange(size - 2)).reshape(-1)] = fan.reshape(-1, 3)
    return out


def _face_list(element) -> list[np.ndarray] | np.ndarray:
    """Face index lists of a PLY ``face`` element (property ``vertex_indices`` or ``vertex_index``)."""
    names = element.data.dtype.names
    key = "vertex_indices" if "vertex_indices" in names else "vertex_index"
    return element.data[key]


@reader(".ply")
def read_ply(path: Path) -> Asset:
    """Read a PLY mesh into an ``Asset``; see the module docstring."""
    path = Path(path)
    try:
        ply = plyfile.PlyData.read(str(path))
    except OSError as e:
        raise AssetError(path, f"cannot read file: {e.strerror or e}") from None
    except Exception as e:  # plyfile raises PlyParseError, ValueError, struct errors on bad input
        raise AssetError(path, f"not a valid PLY file ({type(e).__name__}: {e})") from None
    elements = {e.name: e for e in ply.elements}
    if "vertex" not in elements:
        raise AssetError(path, "no 'vertex' element")
    vertex = elements["vertex"].data
    names = vertex.dtype.names
    if not {"x", "y", "z"} <= set(names):
        raise AssetError(path, "vertices lack x, y, z")
    positions = np.stack([vertex["x"], vertex["y"], vertex["z"]], axis=-1).astype(np.float32)
    if "face" not in elements or len(elements["face"].data) == 0:
        raise AssetError(path, "no faces: the mesh is empty (point clouds are not supported)")
    triangles = _fan(list(_face_list(elements["face"])))
    if len(triangles) == 0:
        raise AssetError(path, "no faces with three or more corners: the mesh is empty")
    if triangles.min() < 0 or triangles.max() >= len(positions):
        raise AssetError(path, f"face index out of range for {len(positions)} vertices")
    if not np.isfinite(positions[triangles.reshape(-1)]).all():
        raise AssetError(path, "vertex positions contain NaN or infinite values")
    colors = None
    if {"red", "green", "blue"} <= set(names):
        channels = [vertex[c] for c in ("red", "green", "blue", "alpha") if c in names]
        scale = 255.0 if np.issubdtype(channels[0].dtype, np.integer) else 1.0
        rgba = np.stack(channels, axis=-1).astype(np.float32) / scale
        rgb = srgb_to_linear(rgba[:, :3])
        alpha = rgba[:, 3:] if rgba.shape[1] == 4 else np.ones((len(rgba), 1), np.float32)
        colors = torch.from_numpy(np.concatenate([rgb, alpha], axis=-1))
    t_pos_idx = torch.from_numpy(triangles)
    uv = []
    for u, v in (("s", "t"), ("u", "v"), ("texture_u", "texture_v")):
        if {u, v} <= set(names):
            v_tex = np.stack([vertex[u], 1.0 - vertex[v]], axis=-1).astype(np.float32)
            uv = [(torch.from_numpy(v_tex), t_pos_idx.clone())]
            break
    v_pos = torch.from_numpy(positions)
    v_nrm = t_nrm_idx = None
    if {"nx", "ny", "nz"} <= set(names):
        values = torch.from_numpy(np.stack([vertex["nx"], vertex["ny"], vertex["nz"]], axis=-1).astype(np.float32))
        v_nrm, t_nrm_idx = file_normals(v_pos, t_pos_idx, values, t_pos_idx)
    mesh = Mesh(v_pos=v_pos, t_pos_idx=t_pos_idx, uv=uv, v_nrm=v_nrm, t_nrm_idx=t_nrm_idx, v_color=colors)
    return Asset(mesh=mesh, materials=[Material(name="default")], source=path)
