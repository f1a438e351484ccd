"""The record of a run: the reference views, one scored row per method, and the run's figures.

A job fills one ``RunRecord``; both the HTML page (``lookalike.report.html``) and
``metrics.json`` (``RunRecord.metrics``) read it. ``score_method`` computes a method's metrics
and error maps from its renders of the held-out views.
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
        map_noise: the high-frequency energy of each of its texture maps
            (``lookalike.report.map_noise``), or ``None`` where it was not measured.
        silhouette_iou: soft intersection over union of its coverage and the reference's,
            all views (``lookalike.report.metrics.silhouette_iou``), or ``None``.
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
    map_noise: dict[str, float] | None = None
    silhouette_iou: float | None = None

    @property
    def psnr(self) -> float:
        """Mean PSNR over the views (dB)."""
        return float(np.mean(self.psnr_views))

    @property
    def flip(self) -> float:
        """Mean FLIP over the views."""
        return float(np.mean(self.flip_views))


def score_method(key: str, label: str, reference, images, triangles: int,
                 texture_size: int | None = None, silhouette=None,
                 map_noise: dict[str, float] | None = None, silhouette_iou: float | None = None) -> MethodResult:
    """Score ``images [B, H, W, C]`` against ``reference [B, H, W, C]`` (both linear) with
    PSNR and FLIP (see ``lookalike.report.metrics``) and keep the FLIP maps for the page; with
    ``silhouette`` (``[B, H, W]`` bool, ``metrics.silhouette_band``) also the share of the error
    that lies there. ``map_noise`` and ``silhouette_iou`` are passed through."""
    flip_means, flip_maps = flip_views(reference, images, with_maps=True)
    share = None if silhouette is None else error_share(reference, images, silhouette)
    return MethodResult(key, label, images, psnr_views(reference, images), flip_means, flip_maps,
                        int(triangles), texture_size, share, map_noise, silhouette_iou)


@dataclass
class Motion:
    """An animated comparison over one clip of an animated input (the report's moving picture).

    Attributes:
        clip: the clip's name.
        seconds_per_frame: real time between frames.
        columns: ``{label: [F, H, W, C>=3] linear frames}``, in column order (the reference first).
    """

    clip: str
    seconds_per_frame: float
    columns: dict[str, Any]


@dataclass
class RunRecord:
    """Everything a run reports: the page shows it, ``metrics`` is ``metrics.json``.

    Attributes:
        asset_name: shown in the title.
        input: the input as given (a path, or the asset's name).
        reference: ``[B, H, W, C>=3]`` linear renders of the input on the held-out views.
        silhouette: ``[B, H, W]`` bool, the pixels near the reference's outline.
        methods: scored rows; the first is the baseline (plain decimation), the last is ours.
        input_triangles, output_triangles: triangle counts of the input and of our model.
        texture_size: side of our textures in texels.
        resolution: side of the training and held-out images in pixels.
        loss_history: ``[N]`` training loss per iteration (NaN for rolled-back steps).
        validation_history: ``[K, 2]`` (iteration, score on the validation views) of the
            optimisation's scorings, drawn with the loss curve.
        validation_views: how many validation views those scores are over.
        validation_metric: what those scores are: ``"PSNR"``, or where FLIP weighs in a
            description of the blend (``jobs.written_model.WrittenModel.metric``); in dB
            either way.
        iterations: optimisation steps taken.
        rollbacks: steps rolled back after a non-finite loss or gradient.
        position_backoffs: returns to the best state that halved the position learning rate
            (``optim.position_backoff``).
        interrupted: the run was stopped before its end (the record holds the best so far).
        wall_time: seconds the whole run took.
        seconds_per_iteration: mean seconds per optimisation step.
        timings: seconds per stage, e.g. ``{"reference views": 12.0, ...}``.
        config: the configuration used (nested dicts of plain values).
        device: where the run computed (``lookalike.devices.device_label``: ``"cpu"``,
            ``"cuda:0 (NVIDIA H200)"``).
        notes: remarks shown under the summary (e.g. "input had no UVs").
        profile: where the time went, by phase (``lookalike.phases.Profile.as_dict``), when
            the run was profiled; ``None`` otherwise.
        view_labels: what each held-out view shows besides its camera (an animated input's
            clip and time, e.g. ``"Walk at 0.42 s"``), or ``None``.
        motion: the animated comparison of an animated input, or ``None``.
        written: ``{"start": score, "ours": score}`` on the validation views of the start and
            of the fit's best model as written, by which the run chose what it wrote (empty
            without validation views; where the run checks an engine's draw too, also the fit
            with the start's base colour and each model's engine score, ``jobs.written_model``).
        written_model: which of them the run wrote (``WrittenModel.kept_label``).
        written_alpha: how the start, ours and the model written (``"written"``) write their
            alpha (``jobs.alpha_export.alpha_label``: ``"cutoff 0.4"``, ``"dithered"``,
            ``"blended"``, or ``None`` without alpha); empty where not chosen.
        levels: the application's table (``Application.files``), one dict per row (e.g. a
            displaced model's tessellation levels beside the classic bake at their triangle
            counts), shown in the report with its plot, or ``None``.
        reference_views: what a path-traced reference cost (its variant, lighting, samples,
            views rendered and read from the cache, seconds, and the pool's bytes), or ``None``.
        reference_label: what the report calls the reference's pictures.
        reference_coverage: the reference's coverage of each held-out and validation view as a
            share of the input's (``jobs.reference_coverage``): ``{"min", "max", "mean",
            "views"}``, or ``None``.
        start_distance: how far the start's mesh strays from the input
            (``InitialGuess.start_distance``: ``"of"``, ``"far_area"``, ``"mean"``, ``"p99"`` in
            bounding radii, ...), or ``None`` where it was not measured.
    """

    asset_name: str
    input: str
    reference: Any
    silhouette: Any
    methods: list[MethodResult]
    input_triangles: int
    output_triangles: int
    texture_size: int
    resolution: int
    loss_history: Any
    validation_history: Any
    validation_views: int
    iterations: int
    rollbacks: int
    interrupted: bool
    wall_time: float
    seconds_per_iteration: float
    timings: dict[str, float] = field(default_factory=dict)
    config: dict = field(default_factory=dict)
    device: str = "cpu"
    notes: list[str] = field(default_factory=list)
    profile: dict | None = None
    view_labels: list[str] | None = None
    motion: Motion | None = None
    written: dict[str, float] = field(default_factory=dict)
    written_alpha: dict[str, str | None] = field(default_factory=dict)
    written_model: str = "ours"
    levels: list[dict] | None = None
    reference_views: dict | None = None
    reference_label: str = "Reference"
    position_backoffs: int = 0
    reference_coverage: dict | None = None
    start_distance: dict | None = None
    validation_metric: str = "PSNR"

    @property
    def baseline(self) -> MethodResult:
        return self.methods[0]

    @property
    def ours(self) -> MethodResult:
        """The method keyed ``"ours"`` (forms of it, e.g. compressed, may follow it), else the last."""
        return next((m for m in self.methods if m.key == "ours"), self.methods[-1])

    @property
    def num_views(self) -> int:
        return len(self.baseline.psnr_views)

    def metrics(self) -> dict:
        """The content of ``metrics.json``: the figures of the record as plain values."""
        losses = np.asarray(self.loss_history, dtype=np.float64)
        finite = losses[np.isfinite(losses)]
        validation = np.asarray(self.validation_history, dtype=np.float64).reshape(-1, 2)
        scores = "psnr" if self.validation_metric == "PSNR" else "score"
        return {
            "input": self.input,
            "methods": [m.key for m in self.methods],
            "triangles": {"input": self.input_triangles, "output": self.output_triangles},
            "texture_size": self.texture_size,
            "resolution": self.resolution,
            "iterations": self.iterations,
            "rollbacks": self.rollbacks,
            "position_backoffs": self.position_backoffs,
            "interrupted": self.interrupted,
            "device": self.device,
            "seconds": {"total": self.wall_time, "per_iteration": self.seconds_per_iteration, **self.timings},
            "final_loss": float(finite[-1]) if len(finite) else None,
            "validation": {"views": self.validation_views, "iterations": [int(i) for i in validation[:, 0]],
                           "metric": self.validation_metric,
                           scores: [float(v) for v in validation[:, 1]],
                           "written": dict(self.written), "written_alpha": dict(self.written_alpha),
                           "written_model": self.written_model},
            "heldout": {
                "views": self.num_views,
                "silhouette_pixels": float(np.asarray(self.silhouette).mean()),
                **({"poses": self.view_labels} if self.view_labels is not None else {}),
                **{m.key: {"label": m.label, "psnr": m.psnr, "flip": m.flip, "silhouette_error": m.silhouette_error,
                           "silhouette_iou": m.silhouette_iou,
                           "map_noise": m.map_noise, "psnr_views": m.psnr_views.tolist(), "flip_views": m.flip_views.tolist()}
                   for m in self.methods},
            },
            "start_distance": self.start_distance,
            **({"levels": self.levels} if self.levels else {}),
            **({"reference_views": self.reference_views} if self.reference_views else {}),
            **({"reference_coverage": self.reference_coverage} if self.reference_coverage else {}),
            **({"profile": self.profile} if self.profile is not None else {}),
        }
