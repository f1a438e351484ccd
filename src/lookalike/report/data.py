"""What a report shows: the reference views, one scored row per method, and the run's figures.

The optimisation fills a ``ReportData``; ``score_method`` computes a method's metrics and
error maps from its renders of the held-out views.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .metrics import error_share, flip_views, psnr_views


@dataclass
class MethodResult:
    """One method's renders of the held-out views and their scores against the reference.

    Attributes:
        key: short identifier, e.g. ``"decimated"``, ``"baked"``, ``"ours"``.
        label: what the page calls it, e.g. ``"Plain decimation"``.
        images: ``[B, H, W, C>=3]`` linear renders (torch or numpy).
        psnr_views: ``[B]`` float64 PSNR (dB) of each view.
        flip_views: ``[B]`` float64 mean FLIP of each view.
        flip_maps: ``[B, H, W, 3]`` uint8 FLIP error maps (magma).
        triangles: triangle count of the method's model.
        texture_size: side of its textures in texels, or ``None`` where it has no own textures.
        silhouette_error: the share of its squared error (all views) that lies near the
            reference's outline (``lookalike.report.metrics.error_share``), or ``None``.
    """

    key: str
    label: str
    images: Any
    psnr_views: np.ndarray
    flip_views: np.ndarray
    flip_maps: np.ndarray
    triangles: int
    texture_size: int | None = None
    silhouette_error: float | None = None

    @property
    def psnr(self) -> float:
        """Mean PSNR over the views (dB)."""
        return float(np.mean(self.psnr_views))

    @property
    def flip(self) -> float:
        """Mean FLIP over the views."""
        return float(np.mean(self.flip_views))


def score_method(key: str, label: str, reference, images, triangles: int,
                 texture_size: int | None = None, silhouette=None) -> MethodResult:
    """Score ``images [B, H, W, C]`` against ``reference [B, H, W, C]`` (both linear) with
    PSNR and FLIP (see ``lookalike.report.metrics``) and keep the FLIP maps for the page; with
    ``silhouette`` (``[B, H, W]`` bool, ``metrics.silhouette_band``) also the share of the error
    that lies there."""
    flip_means, flip_maps = flip_views(reference, images, with_maps=True)
    share = None if silhouette is None else error_share(reference, images, silhouette)
    return MethodResult(key, label, images, psnr_views(reference, images), flip_means, flip_maps,
                        int(triangles), texture_size, share)


@dataclass
class ReportData:
    """Everything ``write_report`` puts on the page.

    Attributes:
        asset_name: shown in the title.
        reference: ``[B, H, W, C>=3]`` linear renders of the input on the held-out views.
        methods: scored rows; the first is the baseline (plain decimation), the last is ours.
        input_triangles: triangle count of the input.
        loss_history: ``[N]`` training loss per iteration.
        wall_time: seconds the whole run took.
        iterations: optimisation steps taken.
        seconds_per_iteration: mean seconds per optimisation step.
        config: the configuration used (nested dicts of plain values).
        timings: optional seconds per stage, e.g. ``{"reference views": 12.0, ...}``.
        notes: optional remarks shown under the summary (e.g. "input had no UVs").
        validation_history: optional ``[K, 2]`` (iteration, PSNR on the validation views) of
            the optimisation's scorings, drawn with the loss curve.
    """

    asset_name: str
    reference: Any
    methods: list[MethodResult]
    input_triangles: int
    loss_history: Any
    wall_time: float
    iterations: int
    seconds_per_iteration: float
    config: dict
    timings: dict[str, float] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    validation_history: Any = None

    @property
    def baseline(self) -> MethodResult:
        return self.methods[0]

    @property
    def ours(self) -> MethodResult:
        return self.methods[-1]

    @property
    def num_views(self) -> int:
        return int(len(self.baseline.psnr_views))
