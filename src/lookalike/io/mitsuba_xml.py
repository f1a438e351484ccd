"""Mitsuba 3 scene files (``.xml``) read as assets, through Mitsuba itself
(``lookalike.io.mitsuba_runtime``): the scene's mesh shapes, in world space, with their normals
and UVs (Mitsuba's, which follow glTF's convention), one material per BSDF.

A BSDF becomes a material by its parameters, whatever wraps them (``twosided`` makes it
double-sided, ``normalmap`` gives the normal map, ``mask`` the alpha, blended): the base colour
is ``base_color`` (``principled``), ``reflectance`` (``diffuse``) or ``diffuse_reflectance``
(``plastic``, ``roughplastic``), grey where none; roughness is ``roughness``, or the square root
of ``alpha`` (the rough BSDFs' GGX width), else 1 for a diffuse BSDF and 0.5 otherwise;
metalness is ``metallic``, 1 for a conductor (``eta`` and ``k``). Shapes that emit (light fixtures) and shapes that
are not meshes (analytic spheres, rectangles) are left out, with a warning naming them. This
is what a fit starts from and what our rasterizer draws; a path-traced reference renders the
file's own shapes and BSDFs (``lookalike.shading.path_tracing``).
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import torch

from ..asset import Asset, Material, Mesh, Texture
from ..colour import srgb_decode
from ..errors import AssetError
from .mitsuba_runtime import mitsuba
from .registry import reader

log = logging.getLogger(__name__)

GREY = (0.5, 0.5, 0.5)
"""Base colour of a BSDF that names none."""


def _parameter(parameters: dict, *names: str, colour: bool = False) -> np.ndarray | None:
    """The first of ``names`` found at the end of a parameter's key (a texture's ``.data`` or a
    constant's ``.value``), as ``[H, W, C]`` float32 linear values (a constant ``[1, 1, C]``), or
    ``None``. An 8-bit texture is Mitsuba's image as stored: sRGB where it is a ``colour``, as
    Mitsuba reads it."""
    for name in names:
        for key, value in parameters.items():
            if key == name or key.endswith("." + name):
                array = np.array(value, dtype=np.float32)
                if "u8" in type(value).__name__.lower():
                    array = array / 255.0
                    array = np.asarray(srgb_decode(array), np.float32) if colour else array
                return array.reshape(1, 1, -1) if array.ndim < 3 else array
    return None


def _texture(values: np.ndarray, channels: int) -> Texture:
    """``values [H, W, C]`` as a texture of ``channels`` (a single channel repeated)."""
    if values.shape[-1] != channels:
        values = np.repeat(values[..., :1], channels, axis=-1)
    return Texture(torch.from_numpy(np.ascontiguousarray(values, dtype=np.float32)))


def bsdf_material(mi, bsdf, name: str) -> Material:
    """The material of one Mitsuba BSDF (see the module)."""
    parameters = {key: value for key, value in mi.traverse(bsdf).items()}
    base = _parameter(parameters, "base_color.data", "base_color.value", "reflectance.data", "reflectance.value",
                      "diffuse_reflectance.data", "diffuse_reflectance.value", colour=True)
    base = np.asarray(GREY, np.float32).reshape(1, 1, 3) if base is None else base
    opacity = _parameter(parameters, "opacity.data", "opacity.value")
    alpha = np.ones(base.shape[:2] + (1,), np.float32) if opacity is None else opacity[..., :1]
    if alpha.shape[:2] != base.shape[:2]:
        alpha = np.broadcast_to(alpha[..., :1].mean(axis=(0, 1), keepdims=True), base.shape[:2] + (1,))
    leaves = {key.rsplit(".", 2)[-2] if key.endswith((".data", ".value")) else key.rsplit(".", 1)[-1]
              for key in parameters}
    roughness = _parameter(parameters, "roughness.data", "roughness.value")
    if roughness is None:
        width = _parameter(parameters, "alpha.data", "alpha.value")
        roughness = (np.sqrt(np.clip(width, 0, None)) if width is not None
                     else np.full((1, 1, 1), 1.0 if "reflectance" in leaves else 0.5, np.float32))
    metallic = _parameter(parameters, "metallic.data", "metallic.value")
    if metallic is None:
        metallic = np.full((1, 1, 1), 1.0 if {"eta", "k"} <= leaves else 0.0, np.float32)
    if roughness.shape[:2] != metallic.shape[:2]:
        size = max(roughness.shape[:2], metallic.shape[:2])
        roughness, metallic = (np.broadcast_to(v[..., :1].mean(axis=(0, 1), keepdims=True), size + (1,))
                               if v.shape[:2] != size else v[..., :1] for v in (roughness, metallic))
    ks = np.concatenate([np.zeros_like(roughness[..., :1]), roughness[..., :1], metallic[..., :1]], axis=-1)
    normal = _parameter(parameters, "normalmap.data")
    if normal is not None:
        normal = 2.0 * normal[..., :3] - 1.0
        normal /= np.maximum(np.linalg.norm(normal, axis=-1, keepdims=True), 1e-12)
    return Material(name=name, kd=_texture(np.concatenate([base[..., :3] if base.shape[-1] >= 3 else
                                                           np.repeat(base[..., :1], 3, -1), alpha], -1), 4),
                    ks=_texture(ks, 3), normal=None if normal is None else _texture(normal, 3),
                    alpha_mode="OPAQUE" if opacity is None else "BLEND",
                    double_sided=any(".brdf_0." in key or key.startswith("brdf_0.") for key in parameters))


@reader(".xml")
def read_mitsuba_scene(path: Path) -> Asset:
    """Read a Mitsuba 3 scene file into an ``Asset`` (see the module)."""
    mi = mitsuba()
    try:
        scene = mi.load_file(str(path))
    except Exception as error:  # Mitsuba's parser says what and where
        raise AssetError(path, f"Mitsuba cannot load it: {str(error).strip().splitlines()[-1]}") from None
    positions, triangles, normals, uvs, material_index, materials, names = [], [], [], [], [], [], {}
    offset = 0
    for shape in scene.shapes():
        label = shape.id() or type(shape).__name__
        if shape.is_emitter():
            log.warning("%s: shape %r emits light: left out of the asset (a light fixture)", path, label)
            continue
        if not shape.is_mesh():
            log.warning("%s: shape %r is not a mesh: left out of the asset", path, label)
            continue
        parameters = mi.traverse(shape)
        v = np.array(parameters["vertex_positions"], dtype=np.float32).reshape(-1, 3)
        f = np.array(parameters["faces"], dtype=np.int64).reshape(-1, 3)
        n = np.array(parameters["vertex_normals"], dtype=np.float32).reshape(-1, 3)
        t = np.array(parameters["vertex_texcoords"], dtype=np.float32).reshape(-1, 2)
        bsdf = shape.bsdf()
        key = bsdf.id() or str(id(bsdf))
        if key not in names:
            names[key] = len(materials)
            materials.append(bsdf_material(mi, bsdf, bsdf.id() or f"material_{len(materials)}"))
        positions.append(v)
        triangles.append(f + offset)
        normals.append(n if len(n) == len(v) else np.full_like(v, np.nan))
        uvs.append(t if len(t) == len(v) else np.zeros((len(v), 2), np.float32))
        material_index.append(np.full(len(f), names[key], dtype=np.int64))
        offset += len(v)
    if not triangles:
        raise AssetError(path, "the scene has no mesh shapes (only lights or analytic shapes)")
    v_pos = torch.from_numpy(np.concatenate(positions))
    t_pos_idx = torch.from_numpy(np.concatenate(triangles))
    v_nrm = np.concatenate(normals)
    mesh = Mesh(v_pos=v_pos, t_pos_idx=t_pos_idx, uv=[(torch.from_numpy(np.concatenate(uvs)), t_pos_idx.clone())],
                t_mat_idx=torch.from_numpy(np.concatenate(material_index)))
    if not np.isnan(v_nrm).any():
        mesh.v_nrm, mesh.t_nrm_idx = torch.from_numpy(v_nrm), t_pos_idx.clone()
    return Asset(mesh=mesh, materials=materials)
