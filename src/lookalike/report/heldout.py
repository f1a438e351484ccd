"""Held-out views: a fixed set of cameras and lights, never trained on, on which every method
(plain decimation, the classic bake, ours) is scored against the reference (PSNR and FLIP),
and on which (another set of them) the optimisation validates its states (PSNR, and FLIP
where it weighs in: ``HeldoutViews.validation_score``)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import torch

from ..asset import Asset
from ..asset.pose import Poses
from ..devices import CPU, moved
from ..fit.losses import composite
from ..fit.reference import RENDER_CHUNK, Reference, render_in_chunks
from ..fit.training_views import ViewSampler
from ..shading.camera import Camera
from ..shading.light import PointLight
from .map_noise import map_noise
from .metrics import flip, perceptual_score, psnr, silhouette_band, silhouette_iou
from .record import MethodResult, score_method

BACKGROUND = (0.2, 0.2, 0.2)
"""Linear grey that every held-out image is composited over (silhouette errors show against it)."""

AssetRenderer = Callable[[Asset, Camera, PointLight, Poses | None], torch.Tensor]
"""Draws an asset under B views (in B poses, where given and the asset is skinned):
``[B, H, W, 4]``."""


def over_background(rgba: torch.Tensor) -> torch.Tensor:
    """``[B, H, W, 3]`` float32: the renders ``rgba [B, H, W, 4]`` composited over ``BACKGROUND``."""
    background = torch.tensor(BACKGROUND, dtype=torch.float32).expand(rgba.shape[0], 3)
    return composite(rgba.float(), background)


class HeldoutViews:
    """``count`` views drawn from ``np.random.default_rng(seed)`` and the reference's images,
    rendered at ``resolution`` with ``spp`` x ``spp`` samples per pixel.

    Attributes:
        camera, light: the views (batch ``count``).
        pose: the poses they show (batch ``count``), where the sampler draws poses, else ``None``.
        reference: ``[count, H, W, 3]`` float32 linear reference images over ``BACKGROUND`` (on the CPU).
        coverage: ``[count, H, W]`` float32 the reference's antialiased coverage.
        silhouette: ``[count, H, W]`` bool, the pixels near the reference's outline
            (``lookalike.report.metrics.silhouette_band``).
        device: where every model scored on these views is drawn (a run's device).
    """

    def __init__(self, reference: Reference, sampler: ViewSampler, count: int, seed: int, resolution: int, spp: int,
                 device=CPU):
        self.device = torch.device(device)
        views = sampler(np.random.default_rng(seed), count)
        self.camera, self.light, self.pose = views.camera, views.light, views.pose
        rgba = render_in_chunks(reference, self.camera, self.light, resolution, spp, pose=self.pose).cpu()
        self.reference = over_background(rgba)
        self.coverage = rgba[..., 3].float()
        self.silhouette = silhouette_band(rgba[..., 3])

    @torch.no_grad()
    def renders(self, asset: Asset, render: AssetRenderer) -> torch.Tensor:
        """``[count, H, W, 4]`` linear RGB and coverage of ``asset`` drawn by ``render`` on the
        views' ``device`` (asset and views moved there), returned on the CPU, where the references are."""
        n, asset = self.camera.batch_size, moved(asset, self.device)
        chunks = [slice(i, i + RENDER_CHUNK) for i in range(0, n, RENDER_CHUNK)]
        return torch.cat([render(asset, *moved((self.camera[c], self.light[c], None if self.pose is None else self.pose[c]),
                                               self.device)).cpu()
                          for c in chunks])

    def images(self, asset: Asset, render: AssetRenderer) -> torch.Tensor:
        """``[count, H, W, 3]`` linear images of ``asset`` drawn by ``render``, over ``BACKGROUND``."""
        return over_background(self.renders(asset, render))

    def score(self, key: str, label: str, asset: Asset, render: AssetRenderer, texture_size: int | None) -> MethodResult:
        """Render ``asset`` on the held-out views and score it against the reference
        (``lookalike.report.record.score_method``: PSNR, FLIP and FLIP maps per view, the
        share of the error near the outline, the silhouette's intersection over union, and the
        noise of its maps where it has its own textures, ``texture_size`` given)."""
        noise = map_noise(asset) if texture_size is not None else None
        rgba = self.renders(asset, render)
        return score_method(key, label, self.reference, over_background(rgba), asset.mesh.num_triangles,
                            texture_size, self.silhouette, noise, silhouette_iou(self.coverage, rgba[..., 3]))

    def psnr(self, asset: Asset, render: AssetRenderer) -> float:
        """Mean PSNR (dB, ``lookalike.report.metrics.psnr``) of ``asset`` drawn by ``render``."""
        return psnr(self.reference, self.images(asset, render))

    def validation_score(self, asset: Asset, render: AssetRenderer, flip_share: float) -> float:
        """``lookalike.report.metrics.perceptual_score`` (dB) of ``asset`` drawn by ``render``:
        the mean PSNR, and where ``flip_share`` > 0 the mean FLIP with that weight (FLIP is
        computed only then)."""
        images = self.images(asset, render)
        score = psnr(self.reference, images)
        return perceptual_score(score, flip(self.reference, images), flip_share) if flip_share > 0 else score
