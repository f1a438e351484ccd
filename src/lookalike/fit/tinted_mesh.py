"""A latent model that keeps its start's materials: the mesh's vertices are fitted, and of each
material only a colour tint, its textures held at their own resolution.

For a start that reuses the input's own textures (``lookalike.init.leaf_texture_cards``: the
input's leaf texture on fewer, larger quads), training those texels would turn the input's
texture into an atlas of the fit's own; holding them keeps every leaf edge as sharp as the input
draws it. What the fewer leaves change in the picture (how much light the thinned crown lets
through, its shade) is left to the vertices and to one tint per material,

    kd'_m = (t_m * rgb_m, alpha_m),    t_m in [0, TINT_MAX]^3, 1 at the start.

The positions, their Laplacian regulariser, the alpha test's schedule and the drawing are
``surface``'s, a ``TexturedMesh`` of the same mesh whose own (constant) textures are not
trained.
"""

from __future__ import annotations

import dataclasses

import torch

from ..asset import Asset, Material, Texture
from ..asset.pose import Poses
from ..shading.camera import Camera
from ..shading.light import PointLight
from .textured_mesh import TexturedMesh

TINT_MAX = 2.0
"""Largest factor of a tint channel: a tint may brighten a texture, up to twice."""


def surface_of(start: Asset) -> Asset:
    """``start`` with one constant material in place of its own, alpha-tested as its alpha-using
    materials are (their cutoff and coverage ramp) or opaque: what ``TintedMesh``'s ``surface``
    is built from (its positions, normal slots, UVs and alpha schedule, no texels)."""
    alpha = next((m for m in start.materials if m.uses_alpha), None)
    material = (Material(kd=Texture.constant([1.0, 1.0, 1.0, 1.0]), alpha_mode=alpha.alpha_mode,
                         alpha_cutoff=alpha.alpha_cutoff, coverage_ramp=alpha.coverage_ramp,
                         double_sided=alpha.double_sided)
                if alpha is not None else Material(kd=Texture.constant([1.0, 1.0, 1.0, 1.0])))
    return dataclasses.replace(start, materials=[material])


class TintedMesh(torch.nn.Module):
    """The vertices of ``surface`` and a tint per material of ``start`` (module docstring).

    Parameters: ``surface``'s positions (group ``"positions"``) and ``tint [M, 3]`` float32
    (group ``"textures"``). Held: ``materials``, the start's, and ``t_mat_idx [T]`` and the UV
    sets of the start's mesh; ``surface``'s own textures are not trained.

    Args:
        surface: the mesh's ``TexturedMesh`` (built from ``surface_of(start)``).
        start: the start, whose materials and UV sets are kept.
    """

    def __init__(self, surface: TexturedMesh, start: Asset):
        super().__init__()
        self.surface = surface
        self.materials = list(start.materials)
        self.register_buffer("t_mat_idx", start.mesh.t_mat_idx.clone())
        self.uv = [(coords.detach().float(), index) for coords, index in start.mesh.uv]
        self.tint = torch.nn.Parameter(torch.ones(len(self.materials), 3))

    @property
    def layers_used(self):
        """The surface's ``LayerCount``: how deep its renders peeled."""
        return self.surface.layers_used

    def parameter_groups(self) -> dict[str, list[torch.nn.Parameter]]:
        return {"positions": [self.surface.v_pos], "textures": [self.tint]}

    def at_progress(self, fraction: float | None) -> None:
        self.surface.at_progress(fraction)

    def clamp_(self) -> None:
        """The tints into ``[0, TINT_MAX]``."""
        with torch.no_grad():
            self.tint.clamp_(0.0, TINT_MAX)

    def tinted(self, index: int, coverage_ramp: float) -> Material:
        """Material ``index`` with its base colour times its tint (``[H, W, 4]``, clamped to
        [0, 1], alpha as it is), an alpha-tested one at ``coverage_ramp``; differentiable."""
        material = self.materials[index]
        kd = material.kd.data
        rgb = (kd[..., :3] * self.tint[index]).clamp(0.0, 1.0)
        data = torch.cat([rgb, kd[..., 3:]], dim=-1)
        ramp = coverage_ramp if material.alpha_mode == "MASK" else material.coverage_ramp
        return dataclasses.replace(material, kd=dataclasses.replace(material.kd, data=data, mips=None),
                                   coverage_ramp=ramp)

    def as_asset(self, coverage_ramp: float | None = None) -> Asset:
        """The mesh at its current positions with the start's materials tinted, its alpha test
        at ``coverage_ramp`` (``None``: the schedule's current one); differentiable."""
        base = self.surface.as_asset(coverage_ramp)
        ramp = base.materials[0].coverage_ramp
        mesh = dataclasses.replace(base.mesh, uv=self.uv, t_mat_idx=self.t_mat_idx)
        return Asset(mesh=mesh, materials=[self.tinted(i, ramp) for i in range(len(self.materials))])

    @torch.no_grad()
    def export(self) -> Asset:
        """The model as written: detached, its alpha test hard (as glTF draws it)."""
        return self.as_asset(coverage_ramp=0.0)

    def render(self, camera: Camera, light: PointLight, resolution: int, pose: Poses | None = None) -> torch.Tensor:
        """``TexturedMesh.render`` of the tinted model (``[B, H, W, 4]``); ``pose`` is ignored."""
        return self.surface.draw(self.as_asset(), camera, light, resolution)

    def coverage(self, camera: Camera, resolution: int, pose: Poses | None = None) -> torch.Tensor | None:
        return self.surface.coverage(camera, resolution)

    def regularizers(self) -> dict[str, torch.Tensor]:
        return self.surface.regularizers()

    def regularizer_scales(self) -> dict[str, float]:
        return self.surface.regularizer_scales()
