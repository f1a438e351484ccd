"""Tangent-space normal maps held as slopes: ``(x / z, y / z)`` per texel, so that any value is
a valid normal facing outwards and the trained map needs no renormalising projection.

``slopes_to_normal`` (compiled, hand-written backward, run once per optimisation step on the
whole map, because torch's concatenation, norm and division each make a full pass over the map
both ways) has the plain-torch twin ``slopes_to_normal_python``; tests compare values and
gradients. The kernels are :mod:`.slope_normals_kernels` (and :mod:`.slope_normals_cuda` for
tensors on the GPU).
"""

from __future__ import annotations

import torch

from ..devices import launch, uses_cuda_kernels
from . import slope_normals_kernels as kernels


def normal_to_slopes(normal: torch.Tensor) -> torch.Tensor:
    """``[..., 2]`` slopes (x / z, y / z) of tangent-space normals ``[..., 3]`` (z > 0)."""
    return normal[..., :2] / normal[..., 2:].clamp(min=1e-6)


def slopes_to_normal_python(slopes: torch.Tensor) -> torch.Tensor:
    """``[..., 3]`` unit normals ``n = (x, y, 1) / sqrt(x^2 + y^2 + 1)`` of slopes ``[..., 2]``
    (differentiable): the twin of ``slopes_to_normal``."""
    return torch.nn.functional.normalize(torch.cat([slopes, torch.ones_like(slopes[..., :1])], dim=-1), dim=-1)


def slopes_to_normal(slopes: torch.Tensor) -> torch.Tensor:
    """``[..., 3]`` unit normals ``n = (x, y, 1) / r``, ``r = sqrt(x^2 + y^2 + 1)``, of slopes
    ``[..., 2]``, compiled; the backward is ``g_(x, y) = (g - n (n . g))_(x, y) / r``."""
    return _SlopesToNormal.apply(slopes)


class _SlopesToNormal(torch.autograd.Function):
    @staticmethod
    def forward(ctx, slopes):
        flat = slopes.detach().contiguous().reshape(-1, 2)
        normal = flat.new_empty(flat.shape[0], 3)
        if uses_cuda_kernels(flat):
            from . import slope_normals_cuda

            launch(slope_normals_cuda.slopes_to_normal, flat.shape[0], flat, normal)
        else:
            kernels.slopes_to_normal(flat.numpy(), normal.numpy())
        ctx.save_for_backward(normal)
        return normal.reshape(*slopes.shape[:-1], 3)

    @staticmethod
    def backward(ctx, grad):
        (normal,) = ctx.saved_tensors
        out = normal.new_empty(normal.shape[0], 2)
        flat = grad.to(normal.dtype).contiguous().reshape(-1, 3)
        if uses_cuda_kernels(normal):
            from . import slope_normals_cuda

            launch(slope_normals_cuda.slopes_to_normal_backward, normal.shape[0], normal, flat, out)
        else:
            kernels.slopes_to_normal_backward(normal.numpy(), flat.numpy(), out.numpy())
        return out.reshape(*grad.shape[:-1], 2)
