"""The latent model of ``displace``: a coarse base mesh, a one-channel displacement map and the
PBR maps, drawn subdivided and displaced (paper Sec. 5.1, ``lookalike.asset.displacement``),
fitted so that the surface looks right at every one of its tessellation levels.

Each step draws the next of ``levels`` in turn, its image loss weighed towards the level that
gains least over the start (``DisplacedMesh.image_weight``); the base mesh holds the shape, the
displacement the relief its edges can follow, the normal map the rest. On a UV seam a vertex
takes the mean of its sides' heights; the regulariser ``seams``, ``mean (h_side - h_vertex)^2``
over the (vertex, UV) pairs, pulls the sides together, so that an engine or Blender, which read
one side, sees (nearly) the same surface.
"""

from __future__ import annotations

import dataclasses
import math

import torch

from ..asset import Asset, Mesh, Texture
from ..asset.displacement import displaced, seam_gaps, stitched_displacement
from ..asset.material import Displacement
from ..asset.pose import Poses
from ..shading.camera import Camera
from ..shading.light import PointLight
from ..shading.pipeline import render_coverage
from .textured_mesh import TexturedMesh
from .texture_pyramid import TexturePyramid

LEVEL_LOSS_EMA = 0.9
"""beta of each level's loss average m_k (``DisplacedMesh.image_weight``)."""

LEVEL_GAIN_SPREAD = 0.5
"""tau (dB) of the levels' shares ``softmax(-g / tau)`` by their gains over the start
(``DisplacedMesh.image_weight``): a level 0.5 dB further ahead gets e^-1 the share."""

SEAM_TOLERANCE = 0.002
"""The gap between the heights of a seam's two sides (in the map's [0, 1] units) that costs as
much as a quarter of the image loss at the start (``regularizer_scales``)."""


class DisplacedMesh(torch.nn.Module):
    """A ``TexturedMesh`` (the base mesh and its maps) with a displacement map.

    Parameters: those of ``surface``, and ``heights``, a ``TexturePyramid`` of ``[S, S, 1]``
    heights in [0, 1], in group ``"displacement"``. Fixed: ``displacement_scale`` (world units
    per unit of height, offset 1/2), ``shading`` (the start's convention,
    ``Displacement.shading``) and ``levels`` (the tessellation levels fitted);
    ``level_index`` picks the level the next render draws (saved, so
    that a resumed run goes on with the same one); ``level_losses`` are the levels' loss
    averages that balance them, ``level_gains`` the levels' last validated gains over the start
    (``observe_form_gains``) that share the steps among them (``image_weight``).

    Args:
        surface: the base mesh and its maps.
        start: the starting ``Displacement`` (its heights and scale).
        levels: the tessellation levels to fit.
        texture_scales: the step scale of each level of the heights' pyramid, finest first.
    """

    def __init__(self, surface: TexturedMesh, start: Displacement, levels: tuple[int, ...],
                 texture_scales: tuple[float, ...] = (1.0,)):
        super().__init__()
        self.surface = surface
        self.heights = TexturePyramid(start.heights.data.float(), texture_scales, 0.0, 1.0)
        self.displacement_scale = float(start.scale)
        self.shading = start.shading
        self.levels = tuple(sorted(levels))
        self.level_index = 0
        self.level_losses: list[float | None] = [None] * len(self.levels)
        self.level_gains: list[float] | None = None

    def get_extra_state(self) -> dict:
        return {"displacement_scale": self.displacement_scale, "shading": self.shading, "levels": list(self.levels),
                "level_index": self.level_index, "level_losses": list(self.level_losses),
                "level_gains": self.level_gains}

    def set_extra_state(self, state: dict) -> None:
        self.displacement_scale = state["displacement_scale"]
        self.shading = state["shading"]
        self.levels = tuple(state["levels"])
        self.level_index = state["level_index"]
        self.level_losses = list(state["level_losses"])
        self.level_gains = state.get("level_gains")

    def image_weight(self, loss: float) -> float:
        """The factor of the current level's image loss ``L_k``: ``K p_k mean_j m_j / m_k``, with
        ``m_k = LEVEL_LOSS_EMA m_k + (1 - LEVEL_LOSS_EMA) L_k`` each level's loss average (the
        levels seen so far) and ``p = softmax(-g / LEVEL_GAIN_SPREAD)`` the shares of the ``K``
        levels by their validated gains over the start ``g`` (uniform before the first), so that
        the step descends ``sum_k p_k mean_j m_j log L_k``: the levels gain in dB, where plain
        losses let the coarse levels, whose errors are the largest, pull the shared heights away
        from the fine ones, and the level that gains least gets most of the steps, since the
        model is worth its least gain."""
        k, m = self.level_index, self.level_losses
        m[k] = loss if m[k] is None else LEVEL_LOSS_EMA * m[k] + (1 - LEVEL_LOSS_EMA) * loss
        known = [value for value in m if value is not None]
        return len(self.levels) * self.level_shares()[k] * sum(known) / len(known) / max(m[k], 1e-12)

    def level_shares(self) -> list[float]:
        """``p_k``, the levels' shares of the image loss (``image_weight``)."""
        if self.level_gains is None:
            return [1 / len(self.levels)] * len(self.levels)
        low = min(self.level_gains)
        weights = [math.exp(-(gain - low) / LEVEL_GAIN_SPREAD) for gain in self.level_gains]
        return [weight / sum(weights) for weight in weights]

    def observe_form_gains(self, gains: list[float]) -> None:
        """The validated gains over the start of the model's forms in ``Application.variants``'
        order, the finest level first and then the coarser ones in order (``displace``'s
        ``level_variants``), kept by level as ``level_gains``."""
        self.level_gains = [float(gain) for gain in gains[1:] + gains[:1]]

    @property
    def level(self) -> int:
        """The tessellation level the next render draws."""
        return self.levels[self.level_index]

    @property
    def layers_used(self):
        """The surface's ``LayerCount``: how deep its renders peeled."""
        return self.surface.layers_used

    def parameter_groups(self) -> dict[str, list[torch.nn.Parameter]]:
        return {**self.surface.parameter_groups(), "displacement": list(self.heights.parameters())}

    def at_progress(self, fraction: float | None) -> None:
        """The surface's schedule, and the next level in turn."""
        self.surface.at_progress(fraction)
        self.level_index = (self.level_index + 1) % len(self.levels)

    def clamp_(self) -> None:
        self.surface.clamp_()

    def displacement(self, level: int | None = None) -> Displacement:
        """The ``Displacement`` drawn at ``level`` (default the current one); differentiable.
        With engine shading its coarse levels straddle the finest level's relief
        (``Displacement.detail_level``), which is where the coarse levels' compromise with the
        finest lies; with recomputed shading every level reads the map at its vertices, as
        Blender's Displace modifier does."""
        return Displacement(Texture(self.heights(), wrap="clamp"), self.displacement_scale, 0.5,
                            level=self.level if level is None else level, shading=self.shading,
                            detail_level=self.levels[-1] if self.shading == "engine" else None)

    def base_mesh(self) -> Mesh:
        """The base mesh in world coordinates with its atlas and normal slots; differentiable."""
        s = self.surface
        return Mesh(v_pos=s.world_positions(), t_pos_idx=s.t_pos_idx, uv=[(s.v_tex, s.t_tex_idx)],
                    t_nrm_idx=s.t_nrm_idx)

    def as_asset(self, coverage_ramp: float | None = None, level: int | None = None) -> Asset:
        """The base mesh with its maps and ``displacement(level)`` (the pipeline draws it
        tessellated and displaced); differentiable."""
        base = self.surface.as_asset(coverage_ramp)
        material = dataclasses.replace(base.materials[0], displacement=self.displacement(level))
        return dataclasses.replace(base, materials=[material])

    def render(self, camera: Camera, light: PointLight, resolution: int, pose: Poses | None = None) -> torch.Tensor:
        """``TexturedMesh.render`` of the displaced surface at the current level; ``pose`` is
        ignored."""
        return self.surface.draw(self.as_asset(), camera, light, resolution)

    def coverage(self, camera: Camera, resolution: int, pose: Poses | None = None) -> torch.Tensor | None:
        """``[B, H, W]`` antialiased coverage of the displaced surface at the current level."""
        mesh, _ = displaced(self.base_mesh(), self.displacement())
        return render_coverage(mesh, camera, (resolution, resolution), self.surface.msaa)

    def regularizers(self) -> dict[str, torch.Tensor]:
        """The surface's Laplacian, and ``seams`` at the current level (module docstring)."""
        gaps = seam_gaps(self.base_mesh(), self.displacement())
        return {**self.surface.regularizers(), "seams": (gaps ** 2).mean()}

    def regularizer_scales(self) -> dict[str, float]:
        return {**self.surface.regularizer_scales(), "seams": SEAM_TOLERANCE ** 2}

    @torch.no_grad()
    def export(self) -> Asset:
        """The model as written, at its finest level, its map stitched across UV seams
        (``lookalike.asset.displacement.stitched_displacement``)."""
        model = self.as_asset(coverage_ramp=0.0, level=self.levels[-1])
        material = model.materials[0]
        displacement = stitched_displacement(model.mesh, material.displacement, self.levels[-1])
        return dataclasses.replace(model, materials=[dataclasses.replace(material, displacement=displacement)])
