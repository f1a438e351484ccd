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
the film is box-filtered RGBA, so a picture is, as every ``Reference``'s, linear RGB weighted by
coverage, and coverage. The lighting must not be seen behind the asset, yet the asset's own
emission must be: Mitsuba's ``hide_emitters`` hides every shape that emits, the asset's too. So
an asset that emits is rendered as two scenes whose sum is the whole, light transport being
linear in its sources: ``lit``, the asset without its emission under the lighting with directly
seen emitters hidden (it gives the coverage), and ``glow``, the asset's emission alone, seen and
bounced, with no other light and nothing behind it. Mitsuba's alpha counts a camera ray as
covered wherever it meets a surface, even one its ``mask`` lets through; where an asset has
alpha, a third scene, ``holdout``, gives the coverage as glTF viewers composite it: every
surface black with its opacity, under a white sky seen behind it, so that a pixel's value is
the light that reaches the background through it, ``T``, and its coverage ``1 - T``. Each
view's samples are seeded from its camera, so a view renders the same wherever it falls in a
batch.

Mitsuba's variant is chosen by ``lookalike.io.mitsuba_runtime``. An asset read from a Mitsuba
scene file (``lookalike.io.mitsuba_xml``) is drawn as the file has it: its own shapes and BSDFs
under the run's lighting (the file's emitters left out).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
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


def _opacity(mi, material: Material, bsdf: dict) -> dict:
    """``bsdf`` behind ``material``'s alpha as a ``mask`` (thresholded at its cutoff where
    alpha-tested); ``bsdf`` itself where the material is opaque."""
    if material.alpha_mode == "OPAQUE":
        return bsdf
    alpha = material.kd.data[..., 3:4].detach().float()
    if material.alpha_mode == "MASK":
        alpha = (alpha >= material.alpha_cutoff).float()
    return {"type": "mask", "opacity": _channel(mi, Texture(alpha), 0, material.kd.wrap), "bsdf": bsdf}


def holdout_bsdf(mi, material: Material, mirrored: bool) -> dict:
    """A black BSDF with ``material``'s opacity: what stops the light of the ``holdout`` scene
    (see the module); ``mirrored`` is unused (no normal map)."""
    return _opacity(mi, material, {"type": "diffuse", "reflectance": 0.0})


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
    return _opacity(mi, material, bsdf)


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


@dataclass(frozen=True)
class TracedScene:
    """An asset ready to path trace: ``lit``, the Mitsuba scene of the asset under the lighting
    with directly seen emitters hidden and the asset's emission left out; ``glow``, the scene of
    its emission alone (no other light, emitters seen), or ``None`` where it emits nothing;
    ``holdout``, the scene whose pictures give its coverage, or ``None`` where it is opaque
    (then ``lit``'s alpha is its coverage). A view's colour is the sum of ``lit``'s and
    ``glow``'s (see the module)."""

    lit: object
    glow: object | None = None
    holdout: object | None = None


def _emits(material: Material) -> bool:
    """Whether ``material`` has an emission that is not black."""
    return material.emissive is not None and bool((material.emissive.data.detach() > 0).any())


def _asset_shapes(mi, asset: Asset, emission: bool, bsdf=material_bsdf) -> dict:
    """The Mitsuba meshes of ``asset`` by name, one per material and UV handedness, with the
    BSDF ``bsdf(mi, material, mirrored)`` gives, each an area emitter of its material's
    emission where ``emission`` (see the module)."""
    mesh = asset.mesh
    v_nrm, t_nrm_idx = mesh.normals()
    corners = mesh.v_pos.detach().float()[mesh.t_pos_idx]
    normals = v_nrm.detach().float()[t_nrm_idx]
    t_mat_idx = mesh.t_mat_idx if mesh.t_mat_idx is not None else torch.zeros(mesh.num_triangles, dtype=torch.int64)
    shapes = {}
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
            props["bsdf"] = mi.load_dict(bsdf(mi, material, flipped))
            if emission and _emits(material):
                props["emitter"] = mi.load_dict({"type": "area", "radiance": _channel(mi, material.emissive, slice(0, 3),
                                                                                     material.emissive.wrap)})
            name = f"material_{index}_{'mirrored' if flipped else 'plain'}"
            shapes[name] = _shape(mi, name, corners[rows], normals[rows], None if uv is None else uv[rows], props)
    return shapes


def mitsuba_scene(asset: Asset, lighting: FixedLighting, max_depth: int) -> TracedScene:
    """The scenes of ``asset`` under ``lighting`` (``TracedScene``), rendered by a path tracer
    of at most ``max_depth`` vertices per path (2: direct light only); an asset read from a
    Mitsuba scene file is its file's shapes that do not emit."""
    mi = mitsuba()
    integrator = {"type": "path", "max_depth": int(max_depth)}
    lit = {"type": "scene", "integrator": {**integrator, "hide_emitters": True}, **lighting.emitters}
    if asset.source is not None and Path(asset.source).suffix.lower() == ".xml":
        shapes = [shape for shape in mi.load_file(str(asset.source)).shapes() if not shape.is_emitter()]
        return TracedScene(mi.load_dict({**lit, **{f"file_shape_{k}": shape for k, shape in enumerate(shapes)}}))
    seen = {"type": "scene", "integrator": {**integrator, "hide_emitters": False}}
    glow = holdout = None
    if any(_emits(material) for material in asset.materials):
        glow = mi.load_dict({**seen, **_asset_shapes(mi, asset, emission=True)})
    if any(material.alpha_mode != "OPAQUE" for material in asset.materials):
        holdout = mi.load_dict({**seen, "white": {"type": "constant", "radiance": {"type": "rgb", "value": [1.0] * 3}},
                                **_asset_shapes(mi, asset, emission=False, bsdf=holdout_bsdf)})
    return TracedScene(mi.load_dict({**lit, **_asset_shapes(mi, asset, emission=False)}), glow, holdout)


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


def render_path_traced(scene: TracedScene, camera: Camera, resolution: int, spp: int, seed: int = 0) -> torch.Tensor:
    """``[B, H, W, 4]`` float32 pictures of ``scene`` (``mitsuba_scene``) from B cameras, ``spp``
    samples per pixel: linear RGB weighted by coverage, and coverage; row 0 at the top. An
    asset that emits is its lit scene's picture plus its glow's colour (same samples); one with
    alpha takes its coverage from its holdout."""
    mi = mitsuba()
    pictures = []
    for k in range(camera.batch_size):
        view = camera[k]
        sensor, view_seed_k = _sensor(mi, view, resolution, spp), view_seed(view, seed)
        picture = torch.from_numpy(np.array(mi.render(scene.lit, sensor=sensor, spp=spp, seed=view_seed_k),
                                            dtype=np.float32))
        if scene.glow is not None:
            glow = np.array(mi.render(scene.glow, sensor=sensor, spp=spp, seed=view_seed_k), dtype=np.float32)
            picture[..., :3] += torch.from_numpy(glow[..., :3])
        if scene.holdout is not None:
            through = np.array(mi.render(scene.holdout, sensor=sensor, spp=spp, seed=view_seed_k), dtype=np.float32)
            picture[..., 3] = torch.from_numpy(1.0 - through[..., :3].mean(axis=-1)).clamp(0.0, 1.0)
        pictures.append(picture)
    return torch.stack(pictures)
