"""Point lights."""

from __future__ import annotations

from dataclasses import dataclass

import torch


@dataclass
class PointLight:
    """A batch of B isotropic point lights, one per view.

    Irradiance on a surface facing the light at distance ``d`` is ``intensity / d^2`` (inverse
    square falloff, no cut-off); a surface tilted by angle ``theta`` receives ``cos(theta)``
    times that (applied by the BSDF).

    Renderers disagree where a normal map (or a smooth normal) turns the shading normal towards
    the light while the geometric surface faces away from it: Cycles and most offline renderers
    give no light there (the light is below the surface's horizon), real-time engines light it
    by the shading normal alone. ``horizon`` picks the convention per view.

    Attributes:
        position: ``[B, 3]`` float32 world positions (B = 1 broadcasts over every view).
        intensity: ``[B, 3]`` float32 linear RGB radiant intensity.
        horizon: ``[B]`` bool, or ``None`` (all False): where True, a point whose geometric
            normal (facing the viewer) faces away from the light gets none of it.
    """

    position: torch.Tensor
    intensity: torch.Tensor
    horizon: torch.Tensor | None = None

    def illuminate(self, points: torch.Tensor, view: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Unit directions to the light and irradiance at normal incidence.

        Args:
            points: ``[N, 3]`` world positions.
            view: ``[N]`` int64 index of the view (light) each point belongs to.
        Returns:
            ``(direction [N, 3], irradiance [N, 3])`` with
            ``irradiance = intensity / max(d^2, 1e-12)``.
        """
        if self.position.shape[0] == 1:
            view = torch.zeros_like(view)
        offset = self.position.to(points)[view] - points
        distance2 = (offset * offset).sum(dim=-1, keepdim=True).clamp(min=1e-12)
        return offset * torch.rsqrt(distance2), self.intensity.to(points)[view] / distance2

    def below_horizon(self, geometric_normal: torch.Tensor, direction: torch.Tensor,
                      view: torch.Tensor) -> torch.Tensor | None:
        """``[N, 1]`` bool, True where the view's ``horizon`` test applies and the light lies
        below the geometric surface (``geometric_normal . direction <= 0``, both ``[N, 3]``);
        ``None`` where no view tests."""
        if self.horizon is None or not bool(self.horizon.any()):
            return None
        if self.position.shape[0] == 1:
            view = torch.zeros_like(view)
        tested = self.horizon.to(view.device)[view][:, None]
        return tested & ((geometric_normal * direction).sum(dim=-1, keepdim=True) <= 0)

    def __getitem__(self, index) -> "PointLight":
        """The lights selected by ``index`` (a slice or index tensor), still batched."""
        if isinstance(index, int):
            index = slice(index, index + 1)
        if self.position.shape[0] == 1:
            return self
        return PointLight(position=self.position[index], intensity=self.intensity[index],
                          horizon=None if self.horizon is None else self.horizon[index])

    @staticmethod
    def cat(lights: list["PointLight"]) -> "PointLight":
        """One batch of all the lights of ``lights``, in order."""
        horizon = None
        if any(l.horizon is not None for l in lights):
            horizon = torch.cat([l.horizon if l.horizon is not None else torch.zeros(l.position.shape[0], dtype=torch.bool)
                                 for l in lights])
        return PointLight(position=torch.cat([l.position for l in lights]),
                          intensity=torch.cat([l.intensity for l in lights]), horizon=horizon)
