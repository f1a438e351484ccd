"""An asset: one mesh (all primitives of the scene merged, node transforms applied),
its materials, and optionally a skin with animations."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from .material import Material
from .mesh import Mesh
from .skin import Animation, Skin


@dataclass
class Asset:
    """Everything the renderer needs to draw a model.

    Attributes:
        mesh: the geometry; ``mesh.t_mat_idx`` indexes ``materials``.
        materials: at least one material.
        skin: skeleton, or ``None``.
        animations: clips that drive ``skin``.
        source: the file it was read from, if any.
    """

    mesh: Mesh
    materials: list[Material] = field(default_factory=lambda: [Material()])
    skin: Skin | None = None
    animations: list[Animation] = field(default_factory=list)
    source: Path | None = None

    @property
    def name(self) -> str:
        return self.source.stem if self.source else "asset"
