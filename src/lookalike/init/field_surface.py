"""What an implicit surface looks like at points named on its marching-cubes mesh (the classic
bake's source where the input is a field, ``lookalike.init.projection_bake``): the field's own
material and gradient normal, not the mesh's interpolation of them.

Each point ``p`` on the mesh (within a marching-cubes cube of the surface) is moved onto the zero
level set by Newton steps along the gradient, ``p <- p - f(p) g / |g|^2`` (``PROJECTION_STEPS``),
then read: base colour, roughness and metalness from ``material(p)``, the shading normal from the
field's unit gradient (``lookalike.asset.implicit.field_normals``), as the sphere tracer
shades the same point.
"""

from __future__ import annotations

import torch

from ..asset.asset import Asset
from ..asset.implicit import NORMAL_STEP, field_gradient, field_normals
from .reference_surface import SurfaceValues

PROJECTION_STEPS = 3


class FieldSurface:
    """Samples ``asset.field`` at points of ``asset.mesh`` (its marching-cubes mesh)."""

    def __init__(self, asset: Asset):
        self.asset = asset
        _, radius = asset.field.bounding_sphere()
        self.step = NORMAL_STEP * radius

    @torch.no_grad()
    def sample(self, triangle: torch.Tensor, barycentric: torch.Tensor, footprint: torch.Tensor) -> SurfaceValues:
        """Values at the N points ``(triangle [N], barycentric [N, 3])`` of the mesh
        (``footprint`` is unused: the field is read at the point itself)."""
        mesh, field = self.asset.mesh, self.asset.field
        corners = mesh.v_pos.float()[mesh.t_pos_idx[triangle]]
        points = (corners * barycentric.float()[:, :, None]).sum(dim=1)
        for _ in range(PROJECTION_STEPS):
            value, gradient = field_gradient(field.distance, points, self.step)
            points = points - (value / (gradient * gradient).sum(-1).clamp(min=1e-12))[:, None] * gradient
        normal = field_normals(field, points)
        kd, ks = field.channels(points)
        return SurfaceValues(kd=torch.cat([kd, torch.ones_like(kd[:, :1])], dim=1), ks=ks, emissive=None, normal=normal)
