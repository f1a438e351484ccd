"""Perspective cameras in OpenGL conventions (right-handed view space looking down -z,
clip space with ``x, y, z`` in ``[-w, w]``), batched over B views."""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch


def look_at(eye: torch.Tensor, target: torch.Tensor, up) -> torch.Tensor:
    """World-to-view matrices ``[B, 4, 4]`` of cameras at ``eye [B, 3]`` looking at
    ``target [B, 3]`` with ``up [3]`` projecting to the picture's upward direction.

    View space: ``x`` right, ``y`` up, ``-z`` forward (the camera sits at the origin).
    Where ``up`` is (nearly) parallel to the viewing direction, another axis is used as up.
    """
    forward = target - eye
    forward = forward / forward.norm(dim=-1, keepdim=True)
    up = torch.as_tensor(up, dtype=eye.dtype, device=eye.device).expand_as(forward)
    right = torch.linalg.cross(forward, up, dim=-1)
    degenerate = right.norm(dim=-1, keepdim=True) < 1e-6 * up.norm(dim=-1, keepdim=True)
    alternative = torch.linalg.cross(forward, torch.roll(up, 1, dims=-1), dim=-1)
    right = torch.where(degenerate, alternative, right)
    right = right / right.norm(dim=-1, keepdim=True)
    true_up = torch.linalg.cross(right, forward, dim=-1)
    rotation = torch.stack([right, true_up, -forward], dim=-2)  # rows: view axes in world space
    mv = torch.zeros(*eye.shape[:-1], 4, 4, dtype=eye.dtype, device=eye.device)
    mv[..., :3, :3] = rotation
    mv[..., :3, 3] = -(rotation @ eye.unsqueeze(-1)).squeeze(-1)
    mv[..., 3, 3] = 1.0
    return mv


def perspective(fovy: float, aspect: float, near: float, far: float) -> torch.Tensor:
    """OpenGL projection matrix ``[4, 4]`` float32 (``gluPerspective``): vertical field of view
    ``fovy`` in radians, ``aspect`` = width / height; view depth ``-near`` maps to NDC z = -1
    and ``-far`` to +1, and ``w = -z_view``."""
    f = 1.0 / math.tan(fovy / 2.0)
    return torch.tensor([
        [f / aspect, 0.0, 0.0, 0.0],
        [0.0, f, 0.0, 0.0],
        [0.0, 0.0, (far + near) / (near - far), 2.0 * far * near / (near - far)],
        [0.0, 0.0, -1.0, 0.0],
    ], dtype=torch.float32)


@dataclass
class Camera:
    """A batch of B perspective cameras.

    Attributes:
        mv: ``[B, 4, 4]`` float32 world-to-view matrices (OpenGL, looking down -z).
        proj: ``[B, 4, 4]`` float32 projection matrices.
        position: ``[B, 3]`` float32 camera centres in world space.
    """

    mv: torch.Tensor
    proj: torch.Tensor
    position: torch.Tensor

    @staticmethod
    def looking_at(eye: torch.Tensor, target: torch.Tensor, up=(0.0, 1.0, 0.0), fovy: float = math.radians(45.0),
                   aspect: float = 1.0, near: float = 0.1, far: float = 100.0) -> "Camera":
        """Cameras at ``eye [B, 3]`` looking at ``target [B, 3]`` with one shared projection."""
        mv = look_at(eye, target, up)
        proj = perspective(fovy, aspect, near, far).to(eye).expand(eye.shape[0], 4, 4)
        return Camera(mv=mv, proj=proj, position=eye)

    @property
    def batch_size(self) -> int:
        return int(self.mv.shape[0])

    @property
    def mvp(self) -> torch.Tensor:
        """``[B, 4, 4]`` world-to-clip matrices ``proj @ mv``."""
        return self.proj @ self.mv

    def clip(self, v_pos: torch.Tensor) -> torch.Tensor:
        """Clip-space positions ``[B, V, 4]`` of world positions ``v_pos [V, 3]``:
        ``(proj @ mv) @ (x, y, z, 1)``. Differentiable in ``v_pos`` and the matrices."""
        homogeneous = torch.cat([v_pos, torch.ones_like(v_pos[:, :1])], dim=-1)
        return homogeneous @ self.mvp.to(v_pos).transpose(-1, -2)

    def __getitem__(self, index) -> "Camera":
        """The cameras selected by ``index`` (a slice or index tensor), still batched."""
        if isinstance(index, int):
            index = slice(index, index + 1)
        return Camera(mv=self.mv[index], proj=self.proj[index], position=self.position[index])

    @staticmethod
    def cat(cameras: list["Camera"]) -> "Camera":
        """One batch of all the views of ``cameras``, in order (contiguous tensors)."""
        return Camera(mv=torch.cat([c.mv for c in cameras]).contiguous(),
                      proj=torch.cat([c.proj for c in cameras]).contiguous(),
                      position=torch.cat([c.position for c in cameras]).contiguous())
