"""Differentiable rasterization primitives with nvdiffrast's contracts, on the CPU.

Use as ``import lookalike.render as dr``; code written for nvdiffrast runs unchanged.
Conventions (all nvdiffrast's):

- Input positions are clip space ``(x, y, z, w)``; pixel ``(ix, iy)`` of an ``H x W`` image
  samples NDC ``((2 ix + 1)/W - 1, (2 iy + 1)/H - 1)``.
- Image row 0 is ``y = -1`` (OpenGL memory order), so images come out upside down and are
  flipped vertically for display.
- ``rast[..., 3]`` is triangle index + 1 (0 = background), ``rast[..., 0:2]`` the
  perspective-correct barycentric weights of vertices 0 and 1, ``rast[..., 2]`` is z/w.
- Texture coordinate ``(0, 0)`` is texel row 0, column 0 corner; texel ``(r, c)`` has its
  centre at ``uv = ((c + 0.5) / W, (r + 0.5) / H)``.

The per-pixel work is compiled Numba kernels.  Two answer discrete questions, through which
no gradient flows: visibility (:mod:`.visibility`) and the antialiasing outline search
(:mod:`.antialias_kernels`; antialias's blend is torch, and ``outline_blend`` keeps it to
apply to other colours of the same geometry).  The others have hand-written
backward passes inside ``torch.autograd.Function``: barycentrics (:mod:`.barycentrics_kernels`),
interpolation (:mod:`.interpolate_kernels`), texturing (:mod:`.texture_kernels`) and mipmap
construction (:mod:`.mip_kernels`).  Each has a plain-torch twin that the tests compare values
and gradients with, named ``*_python`` beside the fast op (e.g.
:func:`.interpolate.interpolate_python`, :func:`.visibility_python.visibility_python`); the
mipmap kernels' twin is :func:`.mipmap.texture_construct_mip`.
"""

from .antialias import OutlineBlend, antialias, antialias_construct_topology_hash, outline_blend
from .context import RasterizeContext, RasterizeCudaContext, RasterizeGLContext
from .interpolate import interpolate, interpolate_at
from .mipmap import texture_construct_mip, texture_pyramid
from .peel import DepthPeeler
from .rasterize import rasterize
from .sampling import Pyramid
from .texture import texture
from .topology import EdgeTopology

__all__ = [
    "RasterizeContext",
    "RasterizeCudaContext",
    "RasterizeGLContext",
    "rasterize",
    "interpolate",
    "interpolate_at",
    "texture",
    "texture_construct_mip",
    "texture_pyramid",
    "Pyramid",
    "antialias",
    "antialias_construct_topology_hash",
    "EdgeTopology",
    "outline_blend",
    "OutlineBlend",
    "DepthPeeler",
]
