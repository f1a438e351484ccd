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

    Attributes:
        position: ``[B, 3]`` float32 world positions (B = 1 broadcasts over every view).
        intensity: ``[B, 3]`` float32 linear RGB radiant intensity.
    """

    position: torch.Tensor
    intensity: torch.Tensor

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

    def __getitem__(self, index) -> "PointLight":
        """The lights selected by ``index`` (a slice or index tensor), still batched."""
        if isinstance(index, int):
            index = slice(index, index + 1)
        if self.position.shape[0] == 1:
            return self
        return PointLight(position=self.position[index], intensity=self.intensity[index])

    @staticmethod
    def cat(lights: list["PointLight"]) -> "PointLight":
        """One batch of all the lights of ``lights``, in order."""
        return PointLight(position=torch.cat([l.position for l in lights]),
                          intensity=torch.cat([l.intensity for l in lights]))
