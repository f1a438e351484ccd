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

Mitsuba runs its ``llvm_ad_rgb`` variant where an LLVM it works with is installed (``libLLVM``
16 or newer; found on the library path and proven in a separate process first, since an LLVM
it cannot use aborts the process), else ``scalar_rgb`` (about five times slower);
``path_tracer_variant`` says which.
"""

from __future__ import annotations

import functools
import glob
import hashlib
import os
import re
import subprocess
import sys

import numpy as np
import torch

from ..asset import Asset, Material
from ..asset.material import Texture
from ..errors import ConfigError
from .camera import Camera
from .fixed_lighting import FixedLighting

VARIANTS = ("llvm_ad_rgb", "scalar_rgb")
"""Mitsuba variants in order of preference."""

MIN_LLVM = 16
"""Oldest LLVM major version tried for the ``llvm`` variant (older ones abort Dr.Jit)."""

LLVM_DIRS = ("/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/lib64", "/usr/lib", "/usr/local/lib")
"""Where ``libLLVM`` is looked for (besides ``DRJIT_LIBLLVM_PATH``)."""

PROBE = """
import mitsuba as mi
mi.set_variant("llvm_ad_rgb")
scene = mi.load_dict({"type": "scene", "integrator": {"type": "path"},
                      "s": {"type": "sphere", "bsdf": {"type": "principled", "roughness": 0.3}},
                      "l": {"type": "point", "position": [0, 0, 3]}})
sensor = mi.load_dict({"type": "perspective", "film": {"type": "hdrfilm", "width": 4, "height": 4}})
mi.render(scene, sensor=sensor, spp=1)
"""
"""A render in a child process: does Dr.Jit's LLVM back end work with this library?"""


def _llvm_libraries() -> list[str]:
    """``libLLVM`` files of major version ``MIN_LLVM`` or newer, newest first, the user's
    ``DRJIT_LIBLLVM_PATH`` before all."""
    found = {}
    for folder in LLVM_DIRS:
        for path in glob.glob(os.path.join(folder, "libLLVM*.so*")):
            match = re.search(r"libLLVM(?:-|\.so\.)(\d+)", os.path.basename(path))
            if match and int(match.group(1)) >= MIN_LLVM:
                found.setdefault(int(match.group(1)), path)
    user = os.environ.get("DRJIT_LIBLLVM_PATH")
    return ([user] if user else []) + [found[major] for major in sorted(found, reverse=True)]


@functools.cache
def path_tracer_variant() -> str:
    """The Mitsuba variant this process renders with (see the module); the first call probes
    LLVM in a child process (seconds) and points Dr.Jit at the library that worked."""
    for library in _llvm_libraries():
        env = {**os.environ, "DRJIT_LIBLLVM_PATH": library}
        try:
            probe = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, timeout=120)
        except subprocess.TimeoutExpired:
            continue
        if probe.returncode == 0:
            os.environ["DRJIT_LIBLLVM_PATH"] = library
            return VARIANTS[0]
    return VARIANTS[1]


def mitsuba():
    """The ``mitsuba`` module with ``path_tracer_variant`` set; ``ConfigError`` where it is not
    installed."""
    try:
        import mitsuba as mi
    except ImportError:
        raise ConfigError("the path-traced reference needs Mitsuba 3: pip install -e \".[pathtrace]\"") from None
    variant = path_tracer_variant()
    if mi.variant() != variant:
        mi.set_variant(variant)
    return mi


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
        alpha = material.kd.data[..., 3:4].detach().float().cpu().numpy()
        if material.alpha_mode == "MASK":
            alpha = (alpha >= material.alpha_cutoff).astype(np.float32)
        bsdf = {"type": "mask", "opacity": _bitmap(mi, alpha, wrap) if alpha.shape[:2] != (1, 1) else float(alpha.reshape(-1)[0]),
                "bsdf": bsdf}
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
    ``max_depth`` vertices per path (2: direct light only) with directly seen emitters hidden."""
    mi = mitsuba()
    mesh = asset.mesh
    v_nrm, t_nrm_idx = mesh.normals()
    corners = mesh.v_pos.detach().float()[mesh.t_pos_idx]
    normals = v_nrm.detach().float()[t_nrm_idx]
    t_mat_idx = mesh.t_mat_idx if mesh.t_mat_idx is not None else torch.zeros(mesh.num_triangles, dtype=torch.int64)
    scene = {"type": "scene", "integrator": {"type": "path", "max_depth": int(max_depth), "hide_emitters": True},
             **lighting.emitters}
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
