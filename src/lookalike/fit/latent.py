"""What the loop optimises: the ``Latent`` protocol (paper Sec. 4, the latent representation).

A latent model owns its trainable tensors, grouped so that each group gets its own learning
rate; renders itself (colour, and coverage alone for outline views); projects its tensors back
onto their valid ranges; states its regularisers; exports itself as an ``Asset``; and saves and
restores its state. ``lookalike.fit.textured_mesh.TexturedMesh`` is the mesh with PBR textures,
``lookalike.fit.skinned_mesh.SkinnedMesh`` the same with trainable skinning weights, drawn in
the pose of each view; cards with alpha and meshes with displacement follow the same protocol.
"""

from __future__ import annotations

from typing import Protocol

import torch

from ..asset import Asset
from ..asset.pose import Poses
from ..shading.camera import Camera
from ..shading.light import PointLight
from ..shading.peeled_layers import LayerCount


class Latent(Protocol):
    """A trainable model (a ``torch.nn.Module`` in practice); ``layers_used``, a
    ``lookalike.shading.peeled_layers.LayerCount``, counts how deep its renders peeled."""

    layers_used: LayerCount

    def parameter_groups(self) -> dict[str, list[torch.nn.Parameter]]:
        """Trainable tensors by group name (e.g. ``"positions"``, ``"textures"``); the loop
        gives each group its own learning rate."""
        ...

    def parameters(self):
        """Every trainable tensor (as ``torch.nn.Module.parameters``)."""
        ...

    def render(self, camera: Camera, light: PointLight, resolution: int, pose: Poses | None = None) -> torch.Tensor:
        """``[B, H, W, 4]`` linear RGB weighted by coverage, and coverage (H = W =
        ``resolution``, row 0 at the top), in poses ``pose`` (batch B) where the model moves
        (a skinned mesh); differentiable."""
        ...

    def coverage(self, camera: Camera, resolution: int, pose: Poses | None = None) -> torch.Tensor | None:
        """``[B, H, W]`` antialiased coverage alone (differentiable in the geometry; in poses
        ``pose`` where the model moves), or ``None`` where coverage is not geometry's alone
        (alpha), so outline views do not apply."""
        ...

    def clamp_(self) -> None:
        """Project the trainable tensors onto their valid ranges, in place."""
        ...

    def at_progress(self, fraction: float | None) -> None:
        """Follow the run's schedules (e.g. a narrowing alpha test) at ``fraction`` of the
        run's steps done (``None`` while the run's length is unknown); called before each step."""
        ...

    # Optional: ``image_weight(loss: float) -> float``, the factor of this step's image loss
    # (``lookalike.fit.objective``), for a latent drawn in several forms in turn; and
    # ``observe_form_gains(gains: list[float])``, told each form's validated gain over the start
    # (``lookalike.jobs.written_model.WrittenModel.validate``), to share the steps among them.

    def regularizers(self) -> dict[str, torch.Tensor]:
        """Scalar regulariser terms by name (differentiable)."""
        ...

    def regularizer_scales(self) -> dict[str, float]:
        """For each regulariser, the size of the quantity it constrains at the start (e.g. the
        absolute Laplacian energy of the initial mesh), against which the objective sets its
        weight when none is configured."""
        ...

    def export(self) -> Asset:
        """The model as a detached ``Asset`` in the input's frame and units."""
        ...

    def state_dict(self) -> dict:
        ...

    def load_state_dict(self, state: dict) -> None:
        ...
