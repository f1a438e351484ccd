"""Sampling a material ``Texture`` at a list of points with the differentiable texture
primitive: applies the texture's UV transform (KHR_texture_transform), boundary mode and
supplied mip levels."""

from __future__ import annotations

import torch

import lookalike.render as dr

from ..asset.material import Texture


def transform_uv(texture: Texture, uv: torch.Tensor, uv_da: torch.Tensor | None):
    """Apply ``texture.transform`` (``[3, 3]`` affine ``M``) to points ``uv [N, 2]``:
    ``uv' = M[:2, :2] uv + M[:2, 2]``, and its linear part to the screen-space derivatives
    ``uv_da [N, 4] = (du/dX, du/dY, dv/dX, dv/dY)``. Returns ``(uv', uv_da')``."""
    if texture.transform is None:
        return uv, uv_da
    m = texture.transform.to(uv)
    uv = uv @ m[:2, :2].T + m[:2, 2]
    if uv_da is not None:
        uv_da = (m[:2, :2] @ uv_da.reshape(-1, 2, 2)).reshape(-1, 4)
    return uv, uv_da


def sample_texture(texture: Texture, uv: torch.Tensor, uv_da: torch.Tensor | None = None) -> torch.Tensor:
    """Texels ``[N, C]`` of ``texture`` at ``uv [N, 2]`` (glTF convention: ``(0, 0)`` is the
    top-left corner of the image = texel row 0).

    With ``uv_da [N, 4]`` the lookup is trilinear (mip level from the derivatives, using
    ``texture.mips`` where given); without, bilinear. A 1x1 texture is its constant value.
    Differentiable in ``texture.data`` (and its mips), ``uv`` and ``uv_da``.
    """
    data = texture.data
    if data.shape[0] == 1 and data.shape[1] == 1:
        return data.reshape(1, -1).to(uv.dtype).expand(uv.shape[0], -1)
    uv, uv_da = transform_uv(texture, uv, uv_da)
    mipmapped = uv_da is not None
    out = dr.texture(
        data[None],
        uv.reshape(1, -1, 1, 2).contiguous(),
        uv_da=uv_da.reshape(1, -1, 1, 4).contiguous() if mipmapped else None,
        mip=[level[None] for level in texture.mips] if mipmapped and texture.mips is not None else None,
        filter_mode="linear-mipmap-linear" if mipmapped else "linear",
        boundary_mode=texture.wrap,
    )
    return out.reshape(-1, data.shape[-1])
