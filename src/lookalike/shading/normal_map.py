"""Shading normals: tangent-space normal mapping, back faces of double-sided materials, and
normals bent back towards the viewer.

Tangent frame (``lookalike.asset.tangents``): per pixel the interpolated normal ``n`` and
tangent ``t`` (with handedness ``w``) give ``t' = normalize(t - (n.t) n)`` (Gram-Schmidt),
``b = sign(w) n x t'``, and a tangent-space value ``(x, y, z)`` the shading normal
``normalize(x t' + y b + z n)``.
"""

from __future__ import annotations

import torch

from ..asset.normals import safe_normalize
from ..devices import launch, uses_cuda_kernels
from . import normal_map_kernels

BEND_THRESHOLD = 0.1
"""Shading normals whose cosine with the view direction is below this are blended towards the
geometric normal (fully geometric at cosine 0 or below)."""


def _dot(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    return (a * b).sum(dim=-1, keepdim=True)


def perturb_normal(normal: torch.Tensor, tangent: torch.Tensor, tangent_space: torch.Tensor) -> torch.Tensor:
    """Normal-mapped shading normals.

    Args:
        normal: ``[N, 3]`` interpolated vertex normals (any length).
        tangent: ``[N, 4]`` interpolated tangents, ``w`` = handedness.
        tangent_space: ``[N, 3]`` normal-map values ``(x, y, z)``.
    Returns:
        ``[N, 3]`` unit normals ``normalize(x t' + y b + z n)`` (see the module docstring).
    """
    n = safe_normalize(normal)
    t = safe_normalize(tangent[:, :3] - _dot(tangent[:, :3], n) * n)
    sign = torch.where(tangent[:, 3:4] < 0, -1.0, 1.0).to(n)
    b = sign * torch.linalg.cross(n, t, dim=-1)
    x, y, z = tangent_space.unbind(dim=-1)
    return safe_normalize(x[:, None] * t + y[:, None] * b + z[:, None] * n)


def bend_towards_viewer(normal: torch.Tensor, geometric: torch.Tensor, view: torch.Tensor) -> torch.Tensor:
    """Blend shading normals that (nearly) face away from the viewer towards the front-facing
    geometric normal, so silhouettes of smooth or normal-mapped surfaces get no black speckles:
    ``normalize(lerp(geometric, normal, clamp(normal.view / BEND_THRESHOLD, 0, 1)))``.

    Args:
        normal: ``[N, 3]`` unit shading normals.
        geometric: ``[N, 3]`` unit face normals, oriented towards the viewer.
        view: ``[N, 3]`` unit directions from the surface to the viewer.
    Returns:
        ``[N, 3]`` unit normals.
    """
    weight = (_dot(normal, view) / BEND_THRESHOLD).clamp(0.0, 1.0)
    return safe_normalize(torch.lerp(geometric, normal, weight))


class _ShadingNormal(torch.autograd.Function):
    """``(normal [N,3], tangent [N,4], tangent_space [N,3], mapped [N] bool, geometric [N,3],
    view_dir [N,3], facing [N])`` -> ``[N, 3]`` with the compiled kernels."""

    @staticmethod
    def forward(ctx, normal, tangent, tangent_space, mapped, geometric, view_dir, facing):
        arrays = [t.detach().to(normal.dtype).contiguous() for t in (normal, tangent, tangent_space)]
        rest = [t.detach().to(normal.dtype).contiguous() for t in (geometric, view_dir, facing)]
        mapped = mapped.contiguous()
        out = torch.empty_like(arrays[0])
        if uses_cuda_kernels(normal):
            from . import normal_map_cuda

            launch(normal_map_cuda.shading_normal_forward, out.shape[0], *arrays, mapped, *rest, BEND_THRESHOLD, out)
        else:
            normal_map_kernels.shading_normal_forward(*(a.numpy() for a in arrays), mapped.numpy(),
                                                      *(a.numpy() for a in rest), BEND_THRESHOLD, out.numpy())
        ctx.save_for_backward(*arrays, mapped, *rest)
        return out

    @staticmethod
    def backward(ctx, grad_out):
        normal, tangent, tangent_space, mapped, geometric, view_dir, facing = ctx.saved_tensors
        grads = [torch.empty_like(t) for t in (normal, tangent, tangent_space, geometric, view_dir)]
        grad_out = grad_out.to(normal.dtype).contiguous()
        if uses_cuda_kernels(normal):
            from . import normal_map_cuda

            launch(normal_map_cuda.shading_normal_backward, normal.shape[0], *ctx.saved_tensors, BEND_THRESHOLD,
                   grad_out, *grads)
        else:
            normal_map_kernels.shading_normal_backward(*(t.numpy() for t in ctx.saved_tensors), BEND_THRESHOLD,
                                                       grad_out.numpy(), *(g.numpy() for g in grads))
        grad_normal, grad_tangent, grad_tangent_space, grad_geometric, grad_view_dir = grads
        return grad_normal, grad_tangent, grad_tangent_space, None, grad_geometric, grad_view_dir, None


def shading_normal(normal: torch.Tensor, tangent: torch.Tensor, tangent_space: torch.Tensor, mapped: torch.Tensor,
                   geometric: torch.Tensor, view_dir: torch.Tensor, facing: torch.Tensor) -> torch.Tensor:
    """The unit shading normals ``[N, 3]`` of N points: normal-mapped where ``mapped``, flipped by
    ``facing``, bent towards the viewer:
    ``bend_towards_viewer(f * m, f * geometric, view_dir)`` with ``m = perturb_normal(normal,
    tangent, tangent_space)`` where ``mapped`` and ``safe_normalize(normal)`` elsewhere.

    Args:
        normal: ``[N, 3]`` interpolated vertex normals (any length).
        tangent: ``[N, 4]`` interpolated tangents (``w`` = handedness), read where ``mapped``.
        tangent_space: ``[N, 3]`` normal-map values, read where ``mapped``.
        mapped: ``[N]`` bool.
        geometric: ``[N, 3]`` unit face normals; view_dir: ``[N, 3]`` unit directions to the camera.
        facing: ``[N]`` +1 for front faces, -1 for back faces (no gradient).

    Differentiable in ``normal``, ``tangent``, ``tangent_space``, ``geometric`` and
    ``view_dir``. Compiled (:mod:`.normal_map_kernels`; :mod:`.normal_map_cuda` for tensors on
    the GPU), one pass per point each way; the twin is :func:`shading_normal_python`.
    """
    return _ShadingNormal.apply(normal, tangent, tangent_space, mapped, geometric, view_dir, facing)


def shading_normal_python(normal: torch.Tensor, tangent: torch.Tensor, tangent_space: torch.Tensor,
                          mapped: torch.Tensor, geometric: torch.Tensor, view_dir: torch.Tensor,
                          facing: torch.Tensor) -> torch.Tensor:
    """Plain-torch twin of :func:`shading_normal` (same contract)."""
    shading = safe_normalize(normal)
    rows = torch.nonzero(mapped).reshape(-1)
    if rows.numel():
        shading = shading.index_put((rows,), perturb_normal(normal[rows], tangent[rows], tangent_space[rows]))
    facing = facing[:, None].to(normal)
    return bend_towards_viewer(shading * facing, geometric * facing, view_dir)
