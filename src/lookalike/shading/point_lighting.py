"""Radiance of shading points lit by a point light: the BSDF (:mod:`.bsdf`) times the light's
irradiance, with the horizon test (:class:`.light.PointLight`).

:func:`lit_radiance` runs one compiled pass per point forward and one backward
(:mod:`.point_lighting_kernels`), where the torch expression launches some sixty operations
over ``[N, 3]`` tensors each way; :func:`lit_radiance_python` is that expression, the tests'
oracle.
"""

from __future__ import annotations

import numba
import torch

from ..devices import launch, uses_cuda_kernels
from . import bsdf
from . import point_lighting_kernels as kernels
from .light import PointLight


class _LitRadiance(torch.autograd.Function):
    """``(kd, ks, normal, view_dir, position [N, 3], geometric [N, 3] (no gradient), view [N],
    light_pos [L, 3], intensity [L, 3], horizon [L] bool)`` -> ``[N, 3]``."""

    @staticmethod
    def forward(ctx, kd, ks, normal, view_dir, position, geometric, view, light_pos, intensity, horizon):
        dtype = kd.dtype
        arrays = [t.detach().to(dtype).contiguous() for t in (kd, ks, normal, view_dir, position, geometric,
                                                                 light_pos, intensity)]
        view, horizon = view.contiguous(), horizon.contiguous()
        out = kd.new_empty(kd.shape[0], 3)
        if uses_cuda_kernels(kd):
            from . import point_lighting_cuda

            launch(point_lighting_cuda.lit_radiance_forward, kd.shape[0], *arrays[:6], view, *arrays[6:], horizon, out)
        else:
            kernels.lit_radiance_forward(*(a.numpy() for a in arrays[:6]), view.numpy(),
                                         *(a.numpy() for a in arrays[6:]), horizon.numpy(), out.numpy(),
                                         numba.get_num_threads())
        ctx.save_for_backward(*arrays, view, horizon)
        return out

    @staticmethod
    def backward(ctx, grad_out):
        *arrays, view, horizon = ctx.saved_tensors
        grads = [torch.empty_like(arrays[0]) for _ in range(6)]
        grad_out = grad_out.to(arrays[0].dtype).contiguous()
        if uses_cuda_kernels(grad_out):
            from . import point_lighting_cuda

            launch(point_lighting_cuda.lit_radiance_backward, grad_out.shape[0], *arrays[:6], view, *arrays[6:],
                   horizon, grad_out, *grads)
        else:
            kernels.lit_radiance_backward(*(a.numpy() for a in arrays[:6]), view.numpy(),
                                          *(a.numpy() for a in arrays[6:]), horizon.numpy(), grad_out.numpy(),
                                          *(g.numpy() for g in grads), numba.get_num_threads())
        grad_kd, grad_ks, grad_normal, grad_view_dir, grad_position, grad_intensity = grads
        light_pos = arrays[6]
        grad_light_pos = grad_light_intensity = None
        if ctx.needs_input_grad[7] or ctx.needs_input_grad[8]:
            slot = torch.zeros_like(view) if light_pos.shape[0] == 1 else view
            grad_light_pos = light_pos.new_zeros(light_pos.shape).index_add_(0, slot, -grad_position)
            grad_light_intensity = light_pos.new_zeros(light_pos.shape).index_add_(0, slot, grad_intensity)
        return (grad_kd, grad_ks, grad_normal, grad_view_dir, grad_position, None, None,
                grad_light_pos, grad_light_intensity, None)


def _horizon(light: PointLight) -> torch.Tensor:
    """``[L]`` bool on the light's device: which lights apply the horizon test (none where
    ``light.horizon`` is None)."""
    if light.horizon is None:
        return torch.zeros(light.position.shape[0], dtype=torch.bool, device=light.position.device)
    return light.horizon.to(device=light.position.device, dtype=torch.bool)


def lit_radiance(kd: torch.Tensor, ks: torch.Tensor, normal: torch.Tensor, view_dir: torch.Tensor,
                 position: torch.Tensor, geometric_normal: torch.Tensor, view: torch.Tensor,
                 light: PointLight) -> torch.Tensor:
    """Reflected radiance ``[N, 3]`` of N points under ``light``:
    ``bsdf.shade(kd, ks, normal, view_dir, l) * intensity / d^2``, zero where the view tests
    the horizon and the light lies below the geometric surface (``geometric_normal . l <= 0``).

    Args:
        kd: ``[N, 3]`` linear base colour; ks: ``[N, 3]`` (gamma, roughness, metalness).
        normal: ``[N, 3]`` unit shading normals; view_dir: ``[N, 3]`` unit directions to the
            camera; position: ``[N, 3]`` world positions.
        geometric_normal: ``[N, 3]`` unit face normals facing the viewer (the horizon test's;
            no gradient).
        view: ``[N]`` int64 view (light) of each point.
        light: the views' point lights (``l``, ``d`` from ``position``).

    Differentiable in every input but ``geometric_normal`` and ``view``, the light's position
    and intensity included. Compiled (:mod:`.point_lighting_kernels`; :mod:`.point_lighting_cuda`
    for tensors on the GPU); the twin is :func:`lit_radiance_python`.
    """
    dtype = torch.promote_types(kd.dtype, normal.dtype)
    return _LitRadiance.apply(kd.to(dtype), ks.to(dtype), normal.to(dtype), view_dir.to(dtype), position.to(dtype),
                              geometric_normal.to(dtype), view.to(torch.int64), light.position.to(dtype),
                              light.intensity.to(dtype), _horizon(light))


def lit_radiance_python(kd: torch.Tensor, ks: torch.Tensor, normal: torch.Tensor, view_dir: torch.Tensor,
                        position: torch.Tensor, geometric_normal: torch.Tensor, view: torch.Tensor,
                        light: PointLight) -> torch.Tensor:
    """Plain-torch twin of :func:`lit_radiance` (same contract)."""
    light_dir, irradiance = light.illuminate(position, view)
    below = light.below_horizon(geometric_normal, light_dir, view)
    if below is not None:
        irradiance = torch.where(below, 0.0, irradiance)
    return bsdf.shade(kd, ks, normal, view_dir, light_dir) * irradiance
