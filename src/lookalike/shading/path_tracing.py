"""Path-traced pictures of an asset under fixed lighting, by Mitsuba 3 (paper Sec. 5.5: any
renderer can be the reference; a path tracer shows the shadows, bounced light and environment
that a rasterizer cannot).

The asset becomes a Mitsuba scene as glTF viewers would read it: per material, its triangles
with their UVs (glTF's convention, which Mitsuba's bitmaps share: ``v = 0`` is the image's top
row) and shading normals, the metallic-roughness material as Mitsuba's ``principled`` BSDF
(``base_color`` = ``kd``, ``roughness``, ``metallic``, ``specular = 0.5 (1 - gamma)``, i.e.
``F0 = 0.04 (1 - gamma)``), the normal map through a ``normalmap`` BSDF, alpha as an opacity
``mask`` (thresholded at the cutoff where alpha-tested) around ``twosided`` where the material is
double-sided, and emission as an area emitter. Mitsuba's tangent frame is ``s`` along
``dP/du`` and ``t = n x s`` per triangle; our bitangent is ``w (n x t)`` with ``w = -1`` where
the UVs are mirrored (``lookalike.asset.tangents``), so each material's mirrored triangles are
a shape of their own that reads the normal map with ``y`` negated. Vertex colours are not
converted.

Cameras are our OpenGL cameras (``perspective``, vertical field of view from the projection);
the film is box-filtered RGBA with directly seen emitters hidden, so a picture is, as every
``Reference``'s, linear RGB weighted by coverage, and coverage. Each view's samples are seeded
from its camera, so a view renders the same wherever it falls in a batch.

Mitsuba's variant is chosen by ``lookalike.io.mitsuba_runtime``. An asset read from a Mitsuba
scene file (``lookalike.io.mitsuba_xml``) is drawn as the file has it: its own shapes and BSDFs
under the run's lighting (the file's emitters left out).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import torch

from ..asset import Asset, Material
from ..asset.material import Texture
from ..io.mitsuba_runtime import mitsuba
from .camera import Camera
from .fixed_lighting import FixedLighting


def _bitmap(mi, data: np.ndarray, wrap: str) -> dict:
    """A linear ``bitmap`` texture of ``data [H, W, C]`` (C 1 or 3), bilinear."""
    return {"type": "bitmap", "bitmap": mi.Bitmap(np.ascontiguousarray(data, dtype=np.float32)), "raw": True,
            "filter_type": "bilinear", "wrap_mode": "repeat" if wrap == "wrap" else "clamp"}


def _channel(mi, texture: Texture, channels: slice | int, wrap: str):
    """A principled parameter from ``texture``'s ``channels``: a number or RGB where the texture
    is constant, else a bitmap."""
    data = texture.data.detach().float().cpu().numpy()[..., channels]
    data = data[..., None] if data.ndim == 2 else data
    if data.shape[:2] == (1, 1):
        value = data.reshape(-1)
        return float(value[0]) if value.size == 1 else {"type": "rgb", "value": value.tolist()}
    return _bitmap(mi, data, wrap)


def material_bsdf(mi, material: Material, mirrored: bool) -> dict:
    """The Mitsuba BSDF dictionary of ``material`` (see the module) for triangles whose UVs are
    ``mirrored`` or not (the normal map's ``y``)."""
    wrap = material.kd.wrap
    gamma = float(material.ks.data[..., 0].detach().float().mean())
    bsdf = {"type": "principled", "base_color": _channel(mi, material.kd, slice(0, 3), wrap),
            "roughness": _channel(mi, material.ks, 1, wrap), "metallic": _channel(mi, material.ks, 2, wrap),
            "specular": 0.5 * (1.0 - gamma)}
    if material.normal is not None:
        normal = material.normal.data.detach().float().cpu().numpy().copy()
        if mirrored:
            normal[..., 1] = -normal[..., 1]
        bsdf = {"type": "normalmap", "normalmap": _bitmap(mi, 0.5 * normal + 0.5, material.normal.wrap), "bsdf": bsdf}
    if material.double_sided:
        bsdf = {"type": "twosided", "bsdf": bsdf}
    if material.alpha_mode != "OPAQUE":
        alpha = material.kd.data[..., 3:4].detach().float()
        if material.alpha_mode == "MASK":
            alpha = (alpha >= material.alpha_cutoff).float()
        bsdf = {"type": "mask", "opacity": _channel(mi, Texture(alpha), 0, wrap), "bsdf": bsdf}
    return bsdf


def _mirrored(uv: torch.Tensor) -> torch.Tensor:
    """``[T]`` bool: triangles whose UVs are mirrored (``det > 0``, tangent handedness ``w = -1``:
    ``lookalike.asset.tangents``), from corner UVs ``[T, 3, 2]``."""
    d1, d2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    return d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1] > 0


def _uv_of(material: Material, mesh) -> tuple[torch.Tensor, torch.Tensor] | None:
    """``(v_tex, t_tex_idx)`` the material's base colour reads, its texture transform applied."""
    if not mesh.uv or material.kd.uv_set >= len(mesh.uv):
        return None
    v_tex, t_tex_idx = mesh.uv[material.kd.uv_set]
    if material.kd.transform is not None:
        homogeneous = torch.cat([v_tex, torch.ones_like(v_tex[:, :1])], dim=1)
        v_tex = (homogeneous @ material.kd.transform.to(v_tex).T)[:, :2]
    return v_tex, t_tex_idx


def _shape(mi, name: str, corners: torch.Tensor, normals: torch.Tensor, uv: torch.Tensor | None, props):
    """A Mitsuba mesh of ``T`` triangles given per corner: positions and normals ``[T, 3, 3]``,
    UVs ``[T, 3, 2]`` or ``None``."""
    count = corners.shape[0]
    mesh = mi.Mesh(name, 3 * count, count, props=props, has_vertex_normals=True, has_vertex_texcoords=uv is not None)
    params = mi.traverse(mesh)
    arrays = {"vertex_positions": corners.reshape(-1), "vertex_normals": normals.reshape(-1),
              "faces": torch.arange(3 * count, dtype=torch.int64)}
    if uv is not None:
        arrays["vertex_texcoords"] = uv.reshape(-1)
    for key, values in arrays.items():
        dtype = np.uint32 if key == "faces" else np.float32
        params[key] = type(params[key])(values.detach().cpu().numpy().astype(dtype))
    params.update()
    return mesh


def mitsuba_scene(asset: Asset, lighting: FixedLighting, max_depth: int):
    """The Mitsuba scene of ``asset`` under ``lighting``, rendered by a path tracer of at most
    ``max_depth`` vertices per path (2: direct light only) with directly seen emitters hidden; an
    asset read from a Mitsuba scene file is its file's shapes that do not emit."""
    mi = mitsuba()
    scene = {"type": "scene", "integrator": {"type": "path", "max_depth": int(max_depth), "hide_emitters": True},
             **lighting.emitters}
    if asset.source is not None and Path(asset.source).suffix.lower() == ".xml":
        shapes = [shape for shape in mi.load_file(str(asset.source)).shapes() if not shape.is_emitter()]
        return mi.load_dict({**scene, **{f"file_shape_{k}": shape for k, shape in enumerate(shapes)}})
    mesh = asset.mesh
    v_nrm, t_nrm_idx = mesh.normals()
    corners = mesh.v_pos.detach().float()[mesh.t_pos_idx]
    normals = v_nrm.detach().float()[t_nrm_idx]
    t_mat_idx = mesh.t_mat_idx if mesh.t_mat_idx is not None else torch.zeros(mesh.num_triangles, dtype=torch.int64)
    for index, material in enumerate(asset.materials):
        chosen = t_mat_idx == index
        uv_of = _uv_of(material, mesh)
        uv = None if uv_of is None else uv_of[0].detach().float()[uv_of[1]]
        mirrored = _mirrored(uv) if uv is not None else torch.zeros_like(chosen)
        for flipped in (False, True):
            rows = torch.nonzero(chosen & (mirrored == flipped)).reshape(-1)
            if rows.numel() == 0:
                continue
            props = mi.Properties()
            props["bsdf"] = mi.load_dict(material_bsdf(mi, material, flipped))
            if material.emissive is not None:
                props["emitter"] = mi.load_dict({"type": "area", "radiance": _channel(mi, material.emissive, slice(0, 3),
                                                                                     material.emissive.wrap)})
            name = f"material_{index}_{'mirrored' if flipped else 'plain'}"
            scene[name] = _shape(mi, name, corners[rows], normals[rows], None if uv is None else uv[rows], props)
    return mi.load_dict(scene)


def _sensor(mi, camera: Camera, resolution: int, spp: int) -> object:
    """The Mitsuba perspective sensor of one camera (batch 1) with a box-filtered RGBA film."""
    rotation = camera.mv[0, :3, :3].double()
    eye = camera.position[0].double()
    forward, up = -rotation[2], rotation[1]
    proj = camera.proj[0].double()
    near, far = float(proj[2, 3] / (proj[2, 2] - 1.0)), float(proj[2, 3] / (proj[2, 2] + 1.0))
    fovy = float(2.0 * torch.atan(1.0 / proj[1, 1]))
    return mi.load_dict({
        "type": "perspective", "fov_axis": "y", "fov": float(np.degrees(fovy)), "near_clip": near, "far_clip": far,
        "to_world": mi.ScalarTransform4f().look_at(origin=eye.tolist(), target=(eye + forward).tolist(), up=up.tolist()),
        "film": {"type": "hdrfilm", "width": resolution, "height": resolution, "rfilter": {"type": "box"},
                 "pixel_format": "rgba", "sample_border": False},
        "sampler": {"type": "multijitter", "sample_count": spp}})


def view_seed(camera: Camera, seed: int) -> int:
    """A 31-bit seed of one camera's samples: a hash of ``seed`` and its matrices."""
    digest = hashlib.sha256(np.asarray(camera.mv[0].detach().cpu(), dtype=np.float32).tobytes()
                            + np.asarray(camera.proj[0].detach().cpu(), dtype=np.float32).tobytes()
                            + int(seed).to_bytes(8, "little", signed=True)).digest()
    return int.from_bytes(digest[:4], "little") & 0x7FFFFFFF


def render_path_traced(scene, camera: Camera, resolution: int, spp: int, seed: int = 0) -> torch.Tensor:
    """``[B, H, W, 4]`` float32 pictures of ``scene`` (``mitsuba_scene``) from B cameras, ``spp``
    samples per pixel: linear RGB weighted by coverage, and coverage; row 0 at the top."""
    mi = mitsuba()
    pictures = []
    for k in range(camera.batch_size):
        view = camera[k]
        image = mi.render(scene, sensor=_sensor(mi, view, resolution, spp), spp=spp, seed=view_seed(view, seed))
        pictures.append(torch.from_numpy(np.array(image, dtype=np.float32)))
    return torch.stack(pictures)
