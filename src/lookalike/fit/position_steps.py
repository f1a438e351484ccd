"""Per-vertex step sizes for positions (``optim.position_steps = "local"``).

Adam moves every parameter by about its learning rate per step, whatever the gradient's size,
so one ``lr_positions`` moves a card a tenth of a bounding radius wide and one a hundredth wide
by the same distance: the small one flips and tears while the large one barely moves. Fitting
``v = s * u`` instead of ``v`` (``u`` the trained parameter, ``s`` fixed per vertex) makes a
vertex step by ``s * lr``: with ``s`` its local size, every card moves by the same share of
itself.

A vertex's local size is ``sqrt(2 * mean area of its triangles)`` (a square card's side, for its
corners), in the unit frame of the bounding sphere; its step scale ``min(1, size /
LOCAL_STEP_SIZE)``: never larger than ``lr_positions`` itself, so that large parts (a trunk
kept as a mesh) step as a mesh fit does.
"""

from __future__ import annotations

import torch

LOCAL_STEP_SIZE = 0.22
"""The local size, in bounding-sphere radii, from which a vertex steps by ``lr_positions`` (and
below which by its share of it): about the median card of a billboard cloud of a few hundred
cards (``docs/benchmarks.md``)."""


def local_step_scale(v_pos: torch.Tensor, t_pos_idx: torch.Tensor, radius: float) -> torch.Tensor:
    """``[V, 1]`` step scale ``min(1, sqrt(2 * mean incident triangle area) / (radius *
    LOCAL_STEP_SIZE))`` of each vertex of the mesh ``v_pos [V, 3]``, ``t_pos_idx [T, 3]`` whose
    bounding sphere has radius ``radius``; 1 for a vertex no triangle uses."""
    corners = v_pos.detach().double()[t_pos_idx]
    area = 0.5 * torch.linalg.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]).norm(dim=1)
    total = torch.zeros(v_pos.shape[0], dtype=torch.float64).index_add_(0, t_pos_idx.reshape(-1), area.repeat_interleave(3))
    count = torch.bincount(t_pos_idx.reshape(-1), minlength=v_pos.shape[0]).double()
    size = torch.sqrt(2.0 * total / count.clamp(min=1)) / radius
    scale = torch.where(count > 0, (size / LOCAL_STEP_SIZE).clamp(max=1.0), torch.ones_like(size))
    return scale.clamp(min=1e-6).float()[:, None]
