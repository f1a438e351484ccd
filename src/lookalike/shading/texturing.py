"""Sampling material ``Texture``s at a list of points with the differentiable texture
primitive, applying each texture's UV transform (KHR_texture_transform), boundary mode and
supplied mip levels.

Footprint: a trilinear lookup whose mip level follows a pixel's footprint ``f`` (in texels)
filters the texture much wider than the pixel: level ``L = log2 f`` averages boxes of ``f``
texels and interpolates between them with a tent of half-width ``f``, a filter of variance
``f^2 / 12 + f^2 / 6 = f^2 / 4``. A renderer that supersamples the pixel instead (Cycles, or
our supersampled reference) filters with the pixel's box, variance ``f^2 / 12``. A model
fitted through the wide filter pre-sharpens its textures to make up for it, and the sharpened
maps show as grain wherever the filter is narrower. Lookups therefore take the footprint times
``FOOTPRINT_SCALE = 1 / sqrt(3)``, whose filter has the box's variance. A model drawn as real-time
engines draw it (one sample per pixel, the GPU's mip level, ``log2 f``: 0.79 levels coarser)
is sampled with ``ENGINE_FOOTPRINT = 1`` instead, so that mips fitted for it are the ones an
engine reads at each distance.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

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


FOOTPRINT_SCALE = 3.0 ** -0.5
ENGINE_FOOTPRINT = 1.0
"""Factor on the screen-space UV derivatives that choose the mip level (module docstring)."""


UVLookup = Callable[[int], tuple[torch.Tensor, torch.Tensor | None]]
"""``uv_set -> (uv [N, 2], uv_da [N, 4] or None)`` of the points being shaded."""


def _is_constant(texture: Texture) -> bool:
    return texture.data.shape[0] == 1 and texture.data.shape[1] == 1


def _stack_key(texture: Texture) -> tuple:
    """Textures with equal keys can be looked up together, stacked channel-wise."""
    transform = None if texture.transform is None else tuple(texture.transform.reshape(-1).tolist())
    own_mips = id(texture) if texture.mips is not None else None
    return tuple(texture.data.shape[:2]), texture.uv_set, texture.wrap, transform, own_mips


@dataclass
class _Stack:
    """Textures looked up together: their channel-wise concatenated texels and mip pyramid.
    Holding ``textures`` keeps their ids (the cache key) from being reused."""

    textures: list[Texture]
    data: torch.Tensor
    mips: list[torch.Tensor] | dr.Pyramid | None = None


class TextureSampler:
    """Samples material textures at lists of points.

    Textures of one material that share size, UV set, transform and wrap mode (typically
    base colour, specular and normal map) are stacked channel-wise and filtered in one lookup.
    Each stack's mip pyramid (``dr.texture_pyramid``, compiled, differentiable) is built at
    most once per sampler: it depends only on the texels, so one serves every layer and view
    of a render. Textures with their own ``mips`` (latent prefiltered levels) use those. The
    stacks are built with gradients even in a ``no_grad`` lookup, so that a first lookup without
    gradients (the coverage of peeled layers) does not cut them from the later ones.
    """

    def __init__(self, footprint: float = FOOTPRINT_SCALE):
        self._stacks: dict[tuple[int, ...], _Stack] = {}
        self.footprint = footprint

    def _stack(self, textures: list[Texture], mipmapped: bool) -> tuple[torch.Tensor, list[torch.Tensor] | dr.Pyramid | None]:
        """``([1, H, W, sum C] texels, their mips or None)`` of ``textures``: the mips are the
        textures' own levels 1.. ``[1, h, w, sum C]`` or a ``dr.Pyramid`` built on the first
        mipmapped request."""
        key = tuple(id(t) for t in textures)
        with torch.enable_grad():  # cached for every later lookup, whatever the first one's grad mode
            if key not in self._stacks:
                self._stacks[key] = _Stack(textures, torch.cat([t.data for t in textures], dim=-1)[None])
            stack = self._stacks[key]
            if mipmapped and stack.mips is None:
                own = textures[0].mips
                stack.mips = [level[None] for level in own] if own is not None else dr.texture_pyramid(stack.data)
        return stack.data, stack.mips if mipmapped else None

    def sample(self, textures: list[Texture], uv_of: UVLookup, count: int) -> list[torch.Tensor]:
        """Values ``[N, C_i]`` of each texture at the ``count`` points described by ``uv_of``.

        Texture coordinates follow glTF (``(0, 0)`` = top-left corner of the image = texel row
        0). With derivatives the lookup is trilinear (mip level from the footprint times
        ``self.footprint``), without bilinear. A 1x1 texture is its constant value and needs no coordinates.
        Differentiable in texels (and own mips), coordinates and derivatives.
        """
        values: list[torch.Tensor | None] = [None] * len(textures)
        groups: dict[tuple, list[int]] = {}
        for i, texture in enumerate(textures):
            if _is_constant(texture):
                values[i] = texture.data.reshape(1, -1).expand(count, -1)
            else:
                groups.setdefault(_stack_key(texture), []).append(i)
        for members in groups.values():
            first = textures[members[0]]
            uv, uv_da = transform_uv(first, *uv_of(first.uv_set))
            mipmapped = uv_da is not None
            if mipmapped:
                uv_da = uv_da * self.footprint
            data, mips = self._stack([textures[i] for i in members], mipmapped)
            out = dr.texture(
                data,
                uv.reshape(1, -1, 1, 2).contiguous(),
                uv_da=uv_da.reshape(1, -1, 1, 4).contiguous() if mipmapped else None,
                mip=mips,
                filter_mode="linear-mipmap-linear" if mipmapped else "linear",
                boundary_mode=first.wrap,
            ).reshape(count, -1)
            channels = [textures[i].channels for i in members]
            for i, part in zip(members, torch.split(out, channels, dim=-1)):
                values[i] = part
        return values
