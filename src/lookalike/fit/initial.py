"""The initial guess (paper Sec. 4) and the plain-decimation baseline it is compared with.

Initial guess: quadric-error decimation of the input to the target triangle count, then
either a fresh UV atlas with the classic projection bake of the input (``"bake"``, the
default: normals, colours and specular copied along the low-poly normals), the input's own
UVs and textures (``"source"``, where the input has one material with UVs), or a fresh UV
atlas with textures that start at the input's mean material (``"average"``) or at uniform
noise (``"random"``, as in the paper) and a flat normal map.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import torch

from ..asset import Asset, Mesh
from ..asset.normals import face_normals
from ..errors import ConfigError
from ..init import unwrap
from ..init.bake import bake
from ..init.decimate import check_triangle_target
from .config import ClampConfig, LatentConfig
from .latent import Latent


def target_triangle_count(latent: LatentConfig, input_triangles: int) -> int:
    """The triangle count to decimate to: ``latent.triangles``, else ``latent.ratio`` (else the
    default ratio) times ``input_triangles``, rounded. Raises ``ConfigError`` when it is not
    positive or not below the input's count."""
    if latent.triangles is not None:
        return check_triangle_target(latent.triangles, input_triangles)
    ratio = latent.ratio if latent.ratio is not None else LatentConfig.DEFAULT_RATIO
    count = int(round(ratio * input_triangles))
    if count <= 0:
        raise ConfigError(f"a ratio of {ratio} leaves no triangles of the input's {input_triangles}")
    return check_triangle_target(count, input_triangles)


def surface_mean_material(asset: Asset) -> tuple[torch.Tensor, torch.Tensor]:
    """Mean base colour + alpha ``[4]`` and specular ``[3]`` over the surface: each material's
    mean texel, weighted by the area of the triangles that use it."""
    mesh = asset.mesh
    area = face_normals(mesh.v_pos.double(), mesh.t_pos_idx).norm(dim=-1)
    weight = torch.zeros(len(asset.materials), dtype=torch.float64).index_add_(0, mesh.t_mat_idx, area)
    weight = weight / weight.sum().clamp(min=1e-30)
    kd = sum(w * m.kd.data.double().reshape(-1, 4).mean(dim=0) for w, m in zip(weight, asset.materials))
    ks = sum(w * m.ks.data.double().reshape(-1, 3).mean(dim=0) for w, m in zip(weight, asset.materials))
    return kd.float(), ks.float()


def uses_alpha(asset: Asset) -> bool:
    """Whether any material of ``asset`` is not opaque (then the latent trains alpha)."""
    return any(m.uses_alpha for m in asset.materials)


def initial_textures(asset: Asset, size: int, init: str, limits: ClampConfig, train_alpha: bool,
                     rng: np.random.Generator) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """``(kd [S, S, 4 or 3], ks [S, S, 3], normal [S, S, 3])`` float32 starting textures.

    ``"average"``: every texel holds ``surface_mean_material(asset)``; ``"random"``: uniform
    noise within the clamp ranges (alpha starts at the mean alpha either way). The normal
    map is flat, (0, 0, 1).
    """
    channels = 4 if train_alpha else 3
    kd_mean, ks_mean = surface_mean_material(asset)
    if init == "average":
        kd = kd_mean[:channels].expand(size, size, channels).clone()
        ks = ks_mean.expand(size, size, 3).clone()
    elif init == "random":
        lo = [limits.kd[0]] * 3 + [float(kd_mean[3])]
        hi = [limits.kd[1]] * 3 + [float(kd_mean[3])]
        kd = torch.from_numpy(rng.uniform(lo[:channels], hi[:channels], size=(size, size, channels)))
        ranges = (limits.gamma, limits.roughness, limits.metalness)
        ks = torch.from_numpy(rng.uniform([r[0] for r in ranges], [r[1] for r in ranges], size=(size, size, 3)))
    else:
        raise ConfigError(f"unknown texture initialisation {init!r}")
    normal = torch.tensor([0.0, 0.0, 1.0]).expand(size, size, 3).clone()
    return kd.float(), ks.float(), normal


def reusable_source_material(asset: Asset, decimated: Mesh):
    """The input's material if the latent can start from its own textures and UVs: exactly one
    material, all its textures in UV set 0 without a texture transform, and UVs carried over
    to ``decimated``; else ``None``."""
    if len(asset.materials) != 1 or not decimated.uv:
        return None
    material = asset.materials[0]
    textures = [t for t in (material.kd, material.ks, material.normal) if t is not None]
    if any(t.uv_set != 0 or t.transform is not None for t in textures):
        return None
    return material


def resample(texture: torch.Tensor, size: int) -> torch.Tensor:
    """``texture [H, W, C]`` resampled to ``[size, size, C]`` (bilinear, antialiased when shrinking)."""
    image = texture.detach().float().permute(2, 0, 1)[None]
    resized = torch.nn.functional.interpolate(image, size=(size, size), mode="bilinear", align_corners=False,
                                              antialias=True)
    return resized[0].permute(1, 2, 0).contiguous()


def initial_latent(asset: Asset, decimated: Mesh, config_latent: LatentConfig, limits: ClampConfig,
                   rng: np.random.Generator) -> tuple[Latent, Asset | None]:
    """The latent model starting from the ``decimated`` mesh, and, when the start is
    ``"bake"``, the classic bake as an asset of its own (else ``None``), so that the report
    can show it.

    ``"bake"``: a fresh UV atlas and ``lookalike.init.bake`` of the input onto it. ``"source"``
    with an input whose material can be reused (``reusable_source_material``): the decimated
    mesh's carried-over UVs and the input's own textures resampled to the texture size (the
    paper's "texture maps from the reference scene as an initial guess"). Otherwise a fresh UV
    atlas and ``initial_textures`` (``"source"`` falling back to ``"average"``).
    """
    size = config_latent.texture_size
    train_alpha = uses_alpha(asset)
    channels = 4 if train_alpha else 3
    source = reusable_source_material(asset, decimated) if config_latent.init == "source" else None
    baked = None
    if source is not None:
        mesh = Mesh(v_pos=decimated.v_pos, t_pos_idx=decimated.t_pos_idx, uv=[decimated.uv[0]])
        kd = resample(source.kd.data, size)[..., :channels]
        ks = resample(source.ks.data, size)
        normal = (torch.nn.functional.normalize(resample(source.normal.data, size), dim=-1)
                  if source.normal is not None else torch.tensor([0.0, 0.0, 1.0]).expand(size, size, 3))
        wrap = source.kd.wrap
    elif config_latent.init == "bake":
        atlas = unwrap(decimated, texture_size=size)
        mesh = Mesh(v_pos=atlas.v_pos, t_pos_idx=atlas.t_pos_idx, uv=[atlas.uv[0]])   # one material, no colours
        material = bake(asset, mesh, texture_size=size).material
        baked = Asset(mesh=mesh, materials=[material], source=asset.source)
        kd, ks, normal = material.kd.data[..., :channels], material.ks.data, material.normal.data
        wrap = "clamp"
    else:
        mesh = unwrap(decimated, texture_size=size)
        init = "average" if config_latent.init == "source" else config_latent.init
        kd, ks, normal = initial_textures(asset, size, init, limits, train_alpha, rng)
        wrap = "clamp"
    centre, radius = asset.mesh.bounding_sphere()
    alpha_mode = _latent_alpha_mode(asset) if train_alpha else "OPAQUE"
    double_sided = any(m.double_sided for m in asset.materials)
    normal = _facing_outwards(normal, limits)
    latent = Latent(mesh, kd, ks, normal, centre, radius, alpha_mode=alpha_mode, double_sided=double_sided, wrap=wrap)
    latent.clamp_(limits)
    return latent, baked


def _facing_outwards(normal: torch.Tensor, limits: ClampConfig) -> torch.Tensor:
    """``normal [S, S, 3]`` with z raised to at least ``1 / normal_max_slope`` and renormalised:
    the latent stores normals as slopes (x / z, y / z), which need z > 0 (a bake can see a few
    texels from behind)."""
    lifted = normal.clone()
    lifted[..., 2].clamp_(min=1.0 / limits.normal_max_slope)
    return torch.nn.functional.normalize(lifted, dim=-1)


def _latent_alpha_mode(asset: Asset) -> str:
    """``"BLEND"`` if any input material blends, else ``"MASK"``."""
    return "BLEND" if any(m.alpha_mode == "BLEND" for m in asset.materials) else "MASK"


def decimation_baseline(asset: Asset, decimated: Mesh) -> Asset:
    """Plain decimation as users know it: the ``decimated`` mesh with the input's own materials
    (through its carried-over UVs where the input has them) and no normal maps."""
    materials = [dataclasses.replace(m, normal=None) for m in asset.materials]
    return Asset(mesh=decimated, materials=materials, source=asset.source)
