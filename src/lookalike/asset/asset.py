"""An asset: one mesh (all primitives of the scene merged, node transforms applied),
its materials, and optionally a skin with animations."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from dataclasses import field as dataclass_field
from pathlib import Path

import torch

from .implicit import ImplicitSurface
from .material import Material
from .mesh import Mesh
from .skin import Animation, Skin


@dataclass
class PunctualLight:
    """A point light that belongs with a model: the light it was fitted under, which viewers
    and engines are given with it (glTF ``KHR_lights_punctual``).

    Attributes:
        position: ``[3]`` float32 world position.
        intensity: ``[3]`` float32 linear RGB radiant intensity (irradiance ``intensity / d^2``
            at distance ``d``, as ``lookalike.shading.light.PointLight``'s).
    """

    position: torch.Tensor
    intensity: torch.Tensor


@dataclass
class Asset:
    """Everything the renderer needs to draw a model.

    Attributes:
        mesh: the geometry; ``mesh.t_mat_idx`` indexes ``materials``.
        materials: at least one material.
        skin: skeleton, or ``None``.
        animations: clips that drive ``skin``.
        source: the file it was read from, if any.
        field: the implicit surface the asset was made from (``mesh`` is then its marching-cubes
            mesh, and a reference shows the field itself), or ``None``.
        lights: point lights that go with the model (not drawn by our renderer, whose views
            bring their own lights).
    """

    mesh: Mesh
    materials: list[Material] = field(default_factory=lambda: [Material()])
    skin: Skin | None = None
    animations: list[Animation] = field(default_factory=list)
    source: Path | None = None
    field: ImplicitSurface | None = None
    lights: list[PunctualLight] = dataclass_field(default_factory=list)

    @property
    def name(self) -> str:
        return self.source.stem if self.source else "asset"

    def fingerprint(self) -> str:
        """SHA-256 (hex) of the content: positions, triangles, normals, UVs, vertex colours,
        material indices and every material's textures and alpha mode, and the implicit surface's
        source; the same wherever the asset was read from, different when any of these differ."""
        mesh = self.mesh
        tensors = [mesh.v_pos, mesh.t_pos_idx, mesh.t_mat_idx, *(t for uv in mesh.uv for t in uv)]
        tensors += [t for t in (mesh.v_nrm, mesh.t_nrm_idx, mesh.v_color) if t is not None]
        digest = hashlib.sha256()
        if self.field is not None:
            digest.update(self.field.fingerprint().encode())
        for material in self.materials:
            digest.update(material.alpha_mode.encode())
            tensors += [t.data for t in (material.kd, material.ks, material.normal) if t is not None]
        for tensor in tensors:
            digest.update(str((tensor.dtype, tuple(tensor.shape))).encode())
            digest.update(tensor.detach().to("cpu", copy=False).contiguous().numpy().tobytes())
        return digest.hexdigest()
