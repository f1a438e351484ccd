"""Wavefront OBJ reader and writer (materials in ``lookalike.io.mtl``).

Reading is vectorised: one regular-expression pass collects the statements, NumPy parses the
numbers. Polygons are fan-triangulated ``(0, i, i + 1)``; negative indices count back from the
last vertex defined before the face; faces without ``vt`` get zero UVs when other faces have
them. The mesh keeps the file's normals (``lookalike.asset.normals.file_normals``: normalised,
welded into slots per (position, normal); corners without one, or with a zero ``vn``, take the
smooth vertex normal). ``v`` lines with six or more numbers carry vertex colours. Texture v is
flipped (``v_glTF = 1 - v_OBJ``) so UVs follow the glTF convention used inside lookalike.
"""

from __future__ import annotations

import io
import re
import logging
from pathlib import Path

import numpy as np
import torch

from ..asset import Asset, Material, Mesh
from ..asset.normals import file_normals
from ..errors import AssetError
from .mtl import read_mtl, write_mtl
from .normal_frames import export_normal_maps, import_normal_maps
from .registry import reader, writer

log = logging.getLogger(__name__)

_STATEMENT = re.compile(r"^[ \t]*(v|vt|vn|f|usemtl|mtllib)[ \t]+(.*?)[ \t]*$", re.M)


def _number_rows(rows: list[str], path: Path, what: str) -> np.ndarray:
    """``[n, k]`` float64 from whitespace-separated number rows (shorter rows padded with 0)."""
    if not rows:
        return np.zeros((0, 0))
    counts = np.char.count(np.array(rows), " ") + 1
    try:
        flat = np.array(" ".join(rows).split(), dtype=np.float64)
    except ValueError:
        raise AssetError(path, f"malformed '{what}' line (not numbers)") from None
    if flat.size == counts.sum() and np.all(counts == counts[0]):
        return flat.reshape(len(rows), counts[0])
    out = np.zeros((len(rows), counts.max()))
    mask = np.arange(counts.max())[None, :] < counts[:, None]
    out[mask] = flat
    return out


def _corner_fields(tokens: list[str], path: Path) -> np.ndarray:
    """``[n, 3]`` int64 (v, vt, vn) OBJ indices of face corners ``v``, ``v/vt``, ``v//vn`` or
    ``v/vt/vn``; absent fields are 0."""
    joined = " ".join(tokens)
    n = len(tokens)
    slashes = joined.count("/")
    try:
        if slashes == 0:
            fields = np.array(joined.split(), dtype=np.int64).reshape(n, 1)
        elif slashes == n and "//" not in joined:
            fields = np.array(joined.replace("/", " ").split(), dtype=np.int64).reshape(n, 2)
        elif slashes == 2 * n and joined.count("//") == n:
            fields = np.array(joined.replace("//", " ").split(), dtype=np.int64).reshape(n, 2)
            fields = np.stack([fields[:, 0], np.zeros(n, np.int64), fields[:, 1]], axis=1)
        elif slashes == 2 * n and "//" not in joined:
            fields = np.array(joined.replace("/", " ").split(), dtype=np.int64).reshape(n, 3)
        else:  # corners of mixed forms: parse each
            parts = [(t.split("/") + ["", ""])[:3] for t in tokens]
            fields = np.array([[int(x) if x else 0 for x in p] for p in parts], dtype=np.int64)
    except ValueError:
        raise AssetError(path, "malformed face ('f') line") from None
    return np.pad(fields, ((0, 0), (0, 3 - fields.shape[1])))


def _resolve(index: np.ndarray, defined_before: np.ndarray, count: int, path: Path, what: str) -> np.ndarray:
    """0-based indices from OBJ indices (1-based; negative = relative to the ``defined_before``
    elements defined before the face); 0 (absent) becomes -1."""
    out = np.where(index > 0, index - 1, defined_before + index)
    out = np.where(index == 0, -1, out)
    bad = (index != 0) & ((out < 0) | (out >= count))
    if bad.any():
        raise AssetError(path, f"face refers to {what} {int(index[bad][0])}, but only {count} exist")
    return out


@reader(".obj")
def read_obj(path: Path) -> Asset:
    """Read an OBJ (and its MTL libraries) into an ``Asset``; see the module docstring."""
    path = Path(path)
    try:
        text = path.read_text(errors="replace")
    except OSError as e:
        raise AssetError(path, f"cannot read file: {e.strerror or e}") from None
    # Whole-text clean-up: line continuations, comments, runs of blanks become one space.
    text = re.sub(r"[ \t]+", " ", re.sub(r"#[^\n]*", "", text.replace("\r\n", "\n").replace("\\\n", " ")))
    statements = _STATEMENT.findall(text)
    if not statements:
        raise AssetError(path, "no vertices ('v' lines)")
    keywords_and_rests = np.array(statements, dtype=object)
    keywords = keywords_and_rests[:, 0].astype(str)
    rests = keywords_and_rests[:, 1]
    rows = {k: rests[keywords == k].tolist() for k in ("v", "vt", "vn", "f")}
    v = _number_rows(rows["v"], path, "v")
    if len(v) == 0:
        raise AssetError(path, "no vertices ('v' lines)")
    positions = v[:, :3].astype(np.float32)
    vt = _number_rows(rows["vt"], path, "vt")
    vn = _number_rows(rows["vn"], path, "vn")

    is_face = keywords == "f"
    faces = rows["f"]
    if not faces:
        raise AssetError(path, "no faces ('f' lines): the mesh is empty")
    corners_per_face = np.char.count(np.array(faces), " ") + 1
    if corners_per_face.min() < 3:
        raise AssetError(path, "a face has fewer than three corners")
    fields = _corner_fields(" ".join(faces).split(" "), path)
    defined = [np.repeat(np.cumsum(keywords == k)[is_face], corners_per_face) for k in ("v", "vt", "vn")]
    pos_idx = _resolve(fields[:, 0], defined[0], len(v), path, "vertex")
    if (pos_idx < 0).any():
        raise AssetError(path, "a face corner has no vertex index")
    tex_idx = _resolve(fields[:, 1], defined[1], len(vt), path, "texture coordinate")
    nrm_idx = _resolve(fields[:, 2], defined[2], len(vn), path, "normal")

    # Fan triangulation: face f with n corners starting at corner s gives (s, s+i, s+i+1), i = 1..n-2.
    starts = np.concatenate([[0], np.cumsum(corners_per_face)[:-1]])
    tri_face = np.repeat(np.arange(len(faces)), corners_per_face - 2)
    fan_step = np.arange(len(tri_face)) - np.repeat(np.cumsum(corners_per_face - 2) - (corners_per_face - 2),
                                                     corners_per_face - 2) + 1
    tri_corners = np.stack([starts[tri_face], starts[tri_face] + fan_step, starts[tri_face] + fan_step + 1], axis=1)

    if not np.isfinite(positions[pos_idx]).all():
        raise AssetError(path, "vertex positions contain NaN or infinite values")

    def indexed(values: np.ndarray, idx: np.ndarray, width: int):
        """Attribute array and ``[T, 3]`` indices, with a zero entry for corners that lack it."""
        if (idx < 0).all() or len(values) == 0:
            return None
        values = np.concatenate([values[:, :width].astype(np.float32), np.zeros((1, width), np.float32)])
        return torch.from_numpy(values), torch.from_numpy(np.where(idx < 0, len(values) - 1, idx)[tri_corners])

    if len(vt):
        vt = np.stack([vt[:, 0], 1.0 - vt[:, 1]], axis=1) if vt.shape[1] > 1 else np.pad(vt, ((0, 0), (0, 1)))
    tex = indexed(vt, tex_idx, 2)
    uv = [] if tex is None else [tex]
    nrm = indexed(vn, nrm_idx, 3)
    colors = None
    if v.shape[1] >= 6:
        colors = torch.from_numpy(np.concatenate([v[:, 3:6], np.ones((len(v), 1))], axis=1).astype(np.float32))

    materials, t_mat_idx = _materials(path, statements, keywords, is_face, tri_face)
    v_pos = torch.from_numpy(np.ascontiguousarray(positions))
    t_pos_idx = torch.from_numpy(pos_idx[tri_corners])
    v_nrm, t_nrm_idx = (None, None) if nrm is None else file_normals(v_pos, t_pos_idx, *nrm)
    mesh = Mesh(v_pos=v_pos, t_pos_idx=t_pos_idx, uv=uv, v_nrm=v_nrm, t_nrm_idx=t_nrm_idx, v_color=colors,
                t_mat_idx=torch.from_numpy(t_mat_idx))
    return Asset(mesh=mesh, materials=import_normal_maps(mesh, materials), source=path)


def _materials(path: Path, statements, keywords: np.ndarray, is_face: np.ndarray, tri_face: np.ndarray):
    """Materials in order of first ``usemtl`` and the ``[T]`` int64 material index per triangle;
    faces before any ``usemtl`` (or naming an unknown material) get the default material."""
    library: dict[str, Material] = {}
    for kw, rest in statements:
        if kw == "mtllib":
            mtl = path.parent / rest.strip()
            if mtl.is_file():
                library.update(read_mtl(mtl))
            else:
                log.warning(f"{path}: material library '{rest.strip()}' not found; using default materials")
    is_use = keywords == "usemtl"
    use_names = [rest.strip() for (kw, rest) in statements if kw == "usemtl"]
    names = list(dict.fromkeys(use_names))
    for name in names:
        if name not in library:
            log.warning(f"{path}: material {name!r} is not defined in any material library; using the default")
    materials = [library.get(name, Material(name=name)) for name in names]
    name_index = np.array([names.index(n) for n in use_names] + [len(names)], dtype=np.int64)
    # The material of a face is the last usemtl before it (index len(names) = default when none).
    last_use = np.cumsum(is_use)[is_face] - 1
    face_mat = np.where(last_use >= 0, name_index[np.maximum(last_use, 0)], len(names))
    t_mat_idx = face_mat[tri_face]
    if (t_mat_idx == len(names)).any() or not materials:
        materials.append(Material(name="default"))
    return materials, t_mat_idx


def _unique_names(materials: list[Material]) -> list[str]:
    """File-safe, unique material names."""
    names = []
    for i, m in enumerate(materials):
        base = re.sub(r"[^A-Za-z0-9_.-]+", "_", m.name) or f"material{i}"
        name, k = base, 1
        while name in names:
            name, k = f"{base}_{k}", k + 1
        names.append(name)
    return names


@writer(".obj")
def write_obj(asset: Asset, path: Path) -> None:
    """Write ``asset`` as OBJ + MTL + PNG textures next to it (``<stem>.mtl``,
    ``<stem>_<material>_<channel>.png``). Normals written are the shading normals lookalike renders
    with (``Mesh.normals``: authored, or split smooth), one ``vn`` per slot; normal maps are
    converted to the MikkTSpace frame of the written mesh.
    Only UV set 0 is written; skins, animations and vertex colours are not. ``gamma``
    (KHR_materials_specular) has no MTL equivalent and is dropped with a warning where non-zero, as
    is an ambient occlusion map."""
    path = Path(path)
    mesh = asset.mesh.detach()
    names = _unique_names(asset.materials)
    materials = export_normal_maps(mesh, asset.materials)
    if any(float(m.ks.data[..., 0].abs().max()) > 0 for m in asset.materials):
        log.warning(f"{path}: gamma (specular scale) cannot be stored in MTL; dropped")
    if any(m.occlusion is not None for m in asset.materials):
        log.warning(f"{path}: MTL has no standard ambient occlusion map; occlusion dropped")
    mtl_path = path.with_suffix(".mtl")
    write_mtl(materials, names, mtl_path)
    v_nrm, t_nrm_idx = mesh.normals()
    lines = [f"# written by lookalike: {mesh.num_vertices} vertices, {mesh.num_triangles} triangles",
             f"mtllib {mtl_path.name}"]
    chunks = ["\n".join(lines) + "\n", _rows("v %.7g %.7g %.7g", mesh.v_pos.numpy())]
    has_uv = bool(mesh.uv)
    if has_uv:
        v_tex = mesh.uv[0][0].numpy().copy()
        v_tex[:, 1] = 1.0 - v_tex[:, 1]
        chunks.append(_rows("vt %.7g %.7g", v_tex))
    chunks.append(_rows("vn %.7g %.7g %.7g", v_nrm.numpy()))
    pos = mesh.t_pos_idx.numpy() + 1
    nrm = t_nrm_idx.numpy() + 1
    tex = mesh.uv[0][1].numpy() + 1 if has_uv else None
    order = np.argsort(mesh.t_mat_idx.numpy(), kind="stable")
    mat_sorted = mesh.t_mat_idx.numpy()[order]
    bounds = np.flatnonzero(np.diff(np.concatenate([[-1], mat_sorted, [len(names)]])))
    for start, stop in zip(bounds[:-1], bounds[1:]):
        tris = order[start:stop]
        p, n = pos[tris], nrm[tris]
        if has_uv:
            corners = np.stack([p, tex[tris], n], axis=-1).reshape(len(tris), 9)
            fmt = "f " + " ".join(["%d/%d/%d"] * 3)
        else:
            corners = np.stack([p, n], axis=-1).reshape(len(tris), 6)
            fmt = "f " + " ".join(["%d//%d"] * 3)
        chunks.append(f"usemtl {names[int(mat_sorted[start])]}\n")
        chunks.append(_rows(fmt, corners))
    try:
        path.write_text("".join(chunks))
    except OSError as e:
        raise AssetError(path, f"cannot write file: {e.strerror or e}") from None


def _rows(fmt: str, values: np.ndarray) -> str:
    """One line per row of ``values [n, k]``, formatted with ``fmt`` (printf style, k fields)."""
    buffer = io.StringIO()
    np.savetxt(buffer, values, fmt=fmt)
    return buffer.getvalue()
