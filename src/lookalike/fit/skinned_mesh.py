"""The latent model of an animated character (paper Sec. 5.3): a :class:`TexturedMesh` in its
bind pose whose skinning weights are trainable too, drawn in the pose of each view.

Each vertex ``i`` has ``K`` candidate joints ``j_ik`` (fixed: the joints that weigh most on the
input's surface near it, ``lookalike.init.skin_weights``) and trainable logits ``l_ik``; its
weights are ``w_ik = softmax_k(l_ik)``, so they stay positive and sum to one. A pose's
positions are the linear-blend skinning ``v_i^s = sum_k w_ik M_(j_ik) v_i`` of the bind-pose
positions (``lookalike.asset.skinning.posed``), with the bone transforms ``M`` of the input's
skeleton at the view's clip and time (known, not trained). Its normals are the bind-pose split
normals skinned with it, as engines and viewers skin the NORMAL of the written glTF (and as the
reference's are), and tangent frames are computed on the posed mesh at every render (paper
Sec. 6.1), so the normal map is right in every pose; the Laplacian acts in the bind pose. The export keeps each vertex's
``EXPORT_INFLUENCES`` largest weights, renormalised (glTF's JOINTS_0 / WEIGHTS_0).
"""

from __future__ import annotations

from dataclasses import replace

import torch

from ..asset import Animation, Asset, Skin
from ..asset.pose import Poses
from ..asset.skinning import posed, strongest_influences
from ..shading.camera import Camera
from ..shading.light import PointLight
from .textured_mesh import TexturedMesh

EXPORT_INFLUENCES = 4
"""Influences per vertex in the export (one glTF JOINTS_0 / WEIGHTS_0 set)."""

WEIGHT_FLOOR = 1e-3
"""A candidate's starting weight is at least this (its logit ``log(w + floor)``), so that
candidates the start gives no weight can still gain some."""


class SkinnedMesh(torch.nn.Module):
    """Trainable bind-pose mesh, textures and skinning weights.

    Parameters: those of ``surface`` (groups ``"positions"``, ``"textures"``, maybe
    ``"emissive"``), and ``weight_logits [V, K]`` float32 in group ``"weights"``.
    Buffers: ``candidates [V, K]`` int64 joint indices into ``skin.joints``.

    Args:
        surface: the mesh and its textures, in the bind pose (the frame of the input's
            loaded positions).
        skin: the input's skeleton; animations: its clips (the poses' clip indices index it).
        candidates: ``[V, K]`` int64 candidate joints of each vertex, distinct within a row.
        weights: ``[V, K]`` float starting weights of the candidates (rows sum to 1).
    """

    def __init__(self, surface: TexturedMesh, skin: Skin, animations: list[Animation], candidates: torch.Tensor,
                 weights: torch.Tensor):
        super().__init__()
        self.surface = surface
        self.skin = skin
        self.animations = animations
        self.register_buffer("candidates", candidates.long().clone())
        self.weight_logits = torch.nn.Parameter(torch.log(weights.detach().float() + WEIGHT_FLOOR))

    @classmethod
    def from_asset(cls, asset: Asset, **surface_options) -> SkinnedMesh:
        """The latent starting from a skinned ``asset``: its surface as
        ``TexturedMesh.from_asset(asset, **surface_options)`` makes it, its skin and clips, and
        its influences (``Mesh.v_joints``, ``v_weights``) as the candidates and their weights."""
        surface = TexturedMesh.from_asset(asset, **surface_options)
        return cls(surface, asset.skin, asset.animations, asset.mesh.v_joints, asset.mesh.v_weights)

    def parameter_groups(self) -> dict[str, list[torch.nn.Parameter]]:
        return {**self.surface.parameter_groups(), "weights": [self.weight_logits]}

    def weights(self) -> torch.Tensor:
        """``[V, K]`` weights of the candidates: ``softmax`` of the logits over each row."""
        return torch.softmax(self.weight_logits, dim=1)

    def skinned(self) -> Asset:
        """The model in its bind pose with its candidate joints and their weights as influences,
        and the input's skeleton and clips (differentiable; ``posed`` poses it)."""
        surface = self.surface.as_asset()
        mesh = replace(surface.mesh, v_joints=self.candidates, v_weights=self.weights())
        return Asset(mesh=mesh, materials=surface.materials, skin=self.skin, animations=self.animations)

    def render(self, camera: Camera, light: PointLight, resolution: int, pose: Poses | None = None) -> torch.Tensor:
        """``TexturedMesh.render`` in the pose of each view (one render per run of views that
        share a pose); in the bind pose where ``pose`` is ``None``."""
        if pose is None:
            return self.surface.render(camera, light, resolution)
        model = self.skinned()
        return torch.cat([self.surface.draw(posed(model, clip, time), camera[views], light[views], resolution)
                          for views, clip, time in pose.runs()])

    def coverage(self, camera: Camera, resolution: int, pose: Poses | None = None) -> torch.Tensor | None:
        """``TexturedMesh.coverage`` in the pose of each view (bind pose without ``pose``)."""
        if pose is None:
            return self.surface.coverage(camera, resolution)
        model = self.skinned()
        covered = [self.surface.coverage_at(posed(model, clip, time).mesh.v_pos, camera[views], resolution)
                   for views, clip, time in pose.runs()]
        return None if covered[0] is None else torch.cat(covered)

    @property
    def layers_used(self):
        """The surface's ``LayerCount``: how deep its renders peeled."""
        return self.surface.layers_used

    def clamp_(self) -> None:
        self.surface.clamp_()

    def at_progress(self, fraction: float | None) -> None:
        self.surface.at_progress(fraction)

    def regularizers(self) -> dict[str, torch.Tensor]:
        return self.surface.regularizers()

    def regularizer_scales(self) -> dict[str, float]:
        return self.surface.regularizer_scales()

    @torch.no_grad()
    def export(self) -> Asset:
        """The bind-pose model with the input's skeleton and clips, and each vertex's
        ``EXPORT_INFLUENCES`` strongest weights (renormalised) as its influences."""
        surface = self.surface.export()
        joints, weights = strongest_influences(self.candidates, self.weights(), EXPORT_INFLUENCES)
        mesh = replace(surface.mesh, v_joints=joints, v_weights=weights)
        return Asset(mesh=mesh, materials=surface.materials, skin=self.skin, animations=self.animations)
