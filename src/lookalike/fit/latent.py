"""The latent model: a low-poly mesh with one PBR material whose textures are trainable.

Positions are stored in the unit frame of the reference's bounding sphere,
``world = centre + radius * v_pos``, so that learning rates mean the same on a model in
millimetres and one in metres; :meth:`Latent.as_asset` returns world coordinates, i.e. the
input's own frame and units.
"""

from __future__ import annotations

import torch

from ..asset import Asset, Material, Mesh, Texture
from .config import ClampConfig


class Latent(torch.nn.Module):
    """Trainable mesh and textures.

    Parameters (float32):
        v_pos: ``[V, 3]`` positions in the unit frame.
        kd: ``[S, S, 4]`` base colour + alpha when alpha is trained, else ``[S, S, 3]``
            (alpha is then 1).
        ks: ``[S, S, 3]`` (gamma, roughness, metalness).
        normal: ``[S, S, 2]`` slopes (x, y) of the tangent-space normal, which is
            normalize(x, y, 1): always facing out of the surface, flat at (0, 0), and two
            parameters per texel instead of three with a unit-length constraint.

    Buffers (fixed): ``t_pos_idx [T, 3]`` int64, ``v_tex [VT, 2]`` float32 and
    ``t_tex_idx [T, 3]`` int64 (the UV atlas), ``centre [3]`` and ``radius []`` float32.

    Args:
        mesh: the initial mesh in world coordinates, with its UV atlas in UV set 0.
        kd, ks: initial textures as above.
        normal: initial ``[S, S, 3]`` tangent-space normals (z > 0), converted to slopes.
        centre, radius: the unit frame.
        alpha_mode: the material's glTF alpha mode (``"OPAQUE"`` unless alpha is trained).
        double_sided: whether the material renders back faces.
        wrap: texture boundary mode, ``"clamp"`` for an atlas or the input's own mode when
            the latent reuses its UVs.
    """

    def __init__(self, mesh: Mesh, kd: torch.Tensor, ks: torch.Tensor, normal: torch.Tensor,
                 centre: torch.Tensor, radius: float | torch.Tensor, alpha_mode: str = "OPAQUE",
                 double_sided: bool = False, wrap: str = "clamp"):
        super().__init__()
        centre = torch.as_tensor(centre, dtype=torch.float32)
        radius = torch.as_tensor(radius, dtype=torch.float32)
        self.register_buffer("centre", centre.clone())
        self.register_buffer("radius", radius.clone())
        self.register_buffer("t_pos_idx", mesh.t_pos_idx.clone())
        self.register_buffer("v_tex", mesh.v_tex.clone())
        self.register_buffer("t_tex_idx", mesh.t_tex_idx.clone())
        self.v_pos = torch.nn.Parameter((mesh.v_pos.float() - centre) / radius)
        self.kd = torch.nn.Parameter(kd.float().clone())
        self.ks = torch.nn.Parameter(ks.float().clone())
        self.normal = torch.nn.Parameter(normal_to_slopes(normal.float()))
        self.alpha_mode = alpha_mode
        self.double_sided = double_sided
        self.wrap = wrap

    @classmethod
    def from_state_dict(cls, state: dict) -> "Latent":
        """Rebuild a latent model from ``state_dict()`` (as stored in a checkpoint)."""
        mesh = Mesh(v_pos=state["centre"] + state["radius"] * state["v_pos"], t_pos_idx=state["t_pos_idx"],
                    uv=[(state["v_tex"], state["t_tex_idx"])])
        latent = cls(mesh, state["kd"], state["ks"], slopes_to_normal(state["normal"]), state["centre"], state["radius"])
        latent.load_state_dict(state)
        return latent

    def get_extra_state(self) -> dict:
        return {"alpha_mode": self.alpha_mode, "double_sided": self.double_sided, "wrap": self.wrap}

    def set_extra_state(self, state: dict) -> None:
        self.alpha_mode = state["alpha_mode"]
        self.double_sided = state["double_sided"]
        self.wrap = state["wrap"]

    @property
    def trains_alpha(self) -> bool:
        return self.kd.shape[-1] == 4

    def position_parameters(self) -> list[torch.nn.Parameter]:
        return [self.v_pos]

    def texture_parameters(self) -> list[torch.nn.Parameter]:
        return [self.kd, self.ks, self.normal]

    def world_positions(self) -> torch.Tensor:
        """``[V, 3]`` positions in the input's frame: centre + radius * v_pos (differentiable)."""
        return self.centre + self.radius * self.v_pos

    def base_color(self) -> torch.Tensor:
        """``[S, S, 4]`` base colour and alpha (alpha 1 where it is not trained)."""
        if self.trains_alpha:
            return self.kd
        return torch.cat([self.kd, torch.ones_like(self.kd[..., :1])], dim=-1)

    def unit_normal(self) -> torch.Tensor:
        """``[S, S, 3]`` unit tangent-space normal map, normalize(x, y, 1)."""
        return slopes_to_normal(self.normal)

    def as_asset(self) -> Asset:
        """The model as an ``Asset`` in world coordinates, differentiable with respect to the
        parameters (detach it, or call under ``torch.no_grad()``, for export)."""
        mesh = Mesh(v_pos=self.world_positions(), t_pos_idx=self.t_pos_idx, uv=[(self.v_tex, self.t_tex_idx)])
        material = Material(
            name="lookalike",
            kd=Texture(self.base_color(), wrap=self.wrap),
            ks=Texture(self.ks, wrap=self.wrap),
            normal=Texture(self.unit_normal(), wrap=self.wrap),
            alpha_mode=self.alpha_mode,
            double_sided=self.double_sided,
        )
        return Asset(mesh=mesh, materials=[material])

    @torch.no_grad()
    def clamp_(self, limits: ClampConfig) -> None:
        """Project the textures onto their valid ranges in place: kd into ``limits.kd``, each
        specular channel into its range, each normal slope into
        [-limits.normal_max_slope, limits.normal_max_slope]."""
        self.kd.clamp_(*limits.kd)
        ranges = torch.tensor([limits.gamma, limits.roughness, limits.metalness], dtype=self.ks.dtype)
        self.ks.clamp_(min=ranges[:, 0], max=ranges[:, 1])
        self.normal.clamp_(-limits.normal_max_slope, limits.normal_max_slope)


def normal_to_slopes(normal: torch.Tensor) -> torch.Tensor:
    """``[..., 2]`` slopes (x / z, y / z) of tangent-space normals ``[..., 3]`` (z > 0)."""
    return normal[..., :2] / normal[..., 2:].clamp(min=1e-6)


def slopes_to_normal(slopes: torch.Tensor) -> torch.Tensor:
    """``[..., 3]`` unit normals normalize(x, y, 1) of slopes ``[..., 2]`` (differentiable)."""
    return torch.nn.functional.normalize(torch.cat([slopes, torch.ones_like(slopes[..., :1])], dim=-1), dim=-1)
