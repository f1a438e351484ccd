"""The initial guess (paper Sec. 4) and the plain-decimation baseline it is compared with.

Initial guess: quadric-error decimation of the input to the target triangle count, a fresh
UV atlas, and textures that start either at the input's mean material (``"average"``) or at
uniform noise (``"random"``, as in the paper); the normal map starts flat.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import torch

from ..asset import Asset, Mesh
from ..asset.normals import face_normals
from ..errors import ConfigError
from ..init import unwrap
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


def initial_latent(asset: Asset, decimated: Mesh, config_latent: LatentConfig, limits: ClampConfig,
                   rng: np.random.Generator) -> Latent:
    """The latent model starting from the ``decimated`` mesh with a fresh UV atlas."""
    atlas = unwrap(decimated, texture_size=config_latent.texture_size)
    train_alpha = uses_alpha(asset)
    kd, ks, normal = initial_textures(asset, config_latent.texture_size, config_latent.init, limits, train_alpha, rng)
    centre, radius = asset.mesh.bounding_sphere()
    alpha_mode = _latent_alpha_mode(asset) if train_alpha else "OPAQUE"
    double_sided = any(m.double_sided for m in asset.materials)
    return Latent(atlas, kd, ks, normal, centre, radius, alpha_mode=alpha_mode, double_sided=double_sided)


def _latent_alpha_mode(asset: Asset) -> str:
    """``"BLEND"`` if any input material blends, else ``"MASK"``."""
    return "BLEND" if any(m.alpha_mode == "BLEND" for m in asset.materials) else "MASK"


def decimation_baseline(asset: Asset, decimated: Mesh) -> Asset:
    """Plain decimation as users know it: the ``decimated`` mesh with the input's own materials
    (through its carried-over UVs where the input has them) and no normal maps."""
    materials = [dataclasses.replace(m, normal=None) for m in asset.materials]
    return Asset(mesh=decimated, materials=materials, source=asset.source)
