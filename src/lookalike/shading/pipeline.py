"""The paper's deferred rendering pipeline (Sec. 5.2):

mesh operations (shading normals: authored, or split smooth normals of the positions; tangent
frames) -> rasterize at ``resolution * spp``
(depth-peeled into ``layers``) -> G-buffer -> material lookup -> shade -> per layer, composite
over what lies behind it and antialias -> box-downsample by ``spp``.

Images are linear RGB plus alpha, ``[B, H, W, 4]`` with row 0 at the TOP of the picture (the
rasterizer's memory order is flipped at the end). Everything is differentiable with respect to
the mesh positions, texture data and camera/light tensors.

Conventions:
- Back faces of double-sided materials are shaded with flipped normals; back faces of
  single-sided materials are culled (alpha 0, so the next depth layer or the background shows
  through), as glTF prescribes.
- Alpha modes: OPAQUE 1, MASK ``kd.a >= cutoff`` (straight-through gradient), BLEND ``kd.a``.
  Layers are peeled front to back, then composited back to front (starting from the
  background) with the "over" operator on straight alpha, antialiasing after each layer. With
  ``layers=1`` a blended surface composites over the background only. Samples behind a fully
  opaque nearer layer are not shaded (they cannot show), and peeling stops early once nothing
  more can show (``LayerCount`` counts the layers used). Each layer's work covers only the
  window of the frame that holds its fragments.
- ``msaa=True`` (stochastic MSAA, for the latent model in training): visibility,
  antialiasing and compositing run at ``spp x spp`` samples per pixel, but each pixel is
  shaded once, at one of its covered samples drawn uniformly at random (``torch``'s global
  generator), with that sample's own texture footprint; the shaded colour is replicated to the
  pixel's samples. In expectation over the draw, the image equals shading every sample, which
  is how the reference, our held-out scoring, Cycles and engines with temporal antialiasing
  see a surface. The paper's MSAA shades the pixel centre at the pixel's footprint instead: a
  fit against supersampled targets then learns maps that compensate for shading once per
  pixel, which show as grain in every renderer that shades per sample.
- No ambient light: surfaces the point light does not reach are black. No shadows unless
  ``render`` is given ``shadows``: then a point's light is scaled by the share of it that the
  asset lets through (deep opacity shadow maps, ``lookalike.shading.shadow_maps``); emission is not.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn.functional as F

import lookalike.render as dr

from ..asset import Asset
from ..asset.displacement import tessellated
from .camera import Camera
from .gbuffer import MeshBuffers
from .light import PointLight
from .peeled_layers import Frame, LayerCount, composite_layers, peel_and_shade
from .shadow_maps import ShadowMapping, deep_shadow_map
from .texturing import FOOTPRINT_SCALE, TextureSampler


def background_image(background, batch: int, height: int, width: int, factor: int,
                     like: torch.Tensor) -> torch.Tensor:
    """``[B, H*factor, W*factor, 4]`` background in the rasterizer's row order: zero (alpha 0)
    for ``None``; else opaque, from an RGB colour ``[3]`` or an image ``[B, H, W, 3]`` (row 0 at
    the top; nearest-upsampled by ``factor``)."""
    shape = (batch, height * factor, width * factor)
    if background is None:
        return like.new_zeros(*shape, 4)
    background = torch.as_tensor(background).to(like)
    if background.dim() == 1:
        rgb = background.expand(*shape, 3)
    else:
        rgb = background.flip(1).repeat_interleave(factor, dim=1).repeat_interleave(factor, dim=2)
        rgb = rgb.expand(*shape, 3)
    return torch.cat([rgb, torch.ones_like(rgb[..., :1])], dim=-1)


def render_coverage(mesh, camera: Camera, resolution, spp: int = 1) -> torch.Tensor:
    """``[B, H, W]`` antialiased coverage of ``mesh`` (its opaque silhouette, no materials):
    1 inside, 0 outside, fractional where an outline edge crosses a pixel, differentiable in
    the positions through ``antialias``; ``spp x spp`` visibility samples per pixel, averaged.
    Row 0 = top, as ``render``."""
    height, width = image_size(resolution)
    tri = mesh.t_pos_idx.to(torch.int32)
    clip = camera.clip(mesh.v_pos)
    rast, _ = dr.rasterize(dr.RasterizeContext(), clip, tri, (height * spp, width * spp))
    covered = (rast[..., 3:] > 0).to(clip.dtype)
    covered = dr.antialias(covered, rast, clip, tri, topology_hash=dr.antialias_construct_topology_hash(tri))
    return box_downsample(covered, spp).flip(1)[..., 0]


def box_downsample(image: torch.Tensor, factor: int) -> torch.Tensor:
    """Average ``factor x factor`` blocks of ``image [B, H*factor, W*factor, C]`` -> ``[B, H, W, C]``."""
    if factor == 1:
        return image
    # avg_pool2d on the channels-last view, because it is several times faster each way than a
    # mean over the reshaped blocks' dims (figures in docs/benchmarks.md).
    return F.avg_pool2d(image.permute(0, 3, 1, 2), factor).permute(0, 2, 3, 1)


def image_size(resolution) -> tuple[int, int]:
    """``(H, W)`` of a ``resolution`` given as ``H`` (square) or ``(H, W)``."""
    if isinstance(resolution, int):
        return resolution, resolution
    height, width = resolution
    return int(height), int(width)


def render(asset, camera: Camera, light: PointLight, resolution, spp: int = 1, layers: int = 1,
           background=None, msaa: bool = False, layer_count: LayerCount | None = None,
           footprint: float = FOOTPRINT_SCALE, shadows: ShadowMapping | None = None) -> torch.Tensor:
    """Render B views of an asset.

    Args:
        asset: an ``Asset`` (with a displacement map, drawn tessellated at its level,
            ``lookalike.asset.displacement``) or anything with ``.mesh`` (``Mesh``) and
            ``.materials``.
        camera: B cameras.
        light: B point lights (or 1, shared).
        resolution: ``H`` (square) or ``(H, W)`` of the output.
        spp: supersampling factor per axis (``spp x spp`` samples per pixel).
        layers: depth-peeled layers composited at most (1 = nearest surface only).
        background: ``None`` (black, alpha 0), an RGB colour ``[3]`` or an image
            ``[B, H, W, 3]`` (row 0 at the top); opaque.
        msaa: shade once per pixel, at a random covered sample, while sampling visibility
            ``spp x spp`` times (stochastic MSAA, see the module docstring).
        layer_count: where given, counts the layers this render used.
        footprint: scale of the texture lookups' footprint (``lookalike.shading.texturing``:
            ``FOOTPRINT_SCALE`` as supersampling renderers filter, ``ENGINE_FOOTPRINT`` as GPUs).
        shadows: where given, the asset shadows itself: each view's light is drawn into deep
            opacity shadow maps of these layers and resolution, once per call, and the light
            reaching each shaded point is scaled by its transmittance
            (``lookalike.shading.shadow_maps``); ``None``, no shadows.
    Returns:
        ``[B, H, W, 4]`` linear RGB radiance and alpha, row 0 = top of the picture. RGB is
        composited over the background; with none, over black (so RGB is premultiplied by
        alpha).

    Each layer is shaded, composited and antialiased only within the window that holds its
    fragments (``lookalike.render.window.covered_window``), the same pixels' values as over the whole frame: a deep
    layer of foliage covers a small part of it.
    """
    height, width = image_size(resolution)
    if isinstance(asset, Asset):
        asset = tessellated(asset)
    buffers = mesh_buffers(asset, camera)
    sampler = texture_sampler(asset, footprint)
    shadow = None if shadows is None else deep_shadow_map(asset, buffers, light, sampler, shadows)
    frame = Frame(asset, buffers, camera, light, sampler, shadow)
    shaded = peel_and_shade(frame, (height * spp, width * spp), spp, layers, msaa and spp > 1)
    if layer_count is not None:
        layer_count.add(len(shaded))
    accum = background_image(background, camera.batch_size, height, width, spp, buffers.clip)
    accum = composite_layers(shaded, accum, buffers, edge_topology(asset, buffers))
    return box_downsample(accum, spp).flip(1)


def mesh_buffers(asset, camera: Camera) -> MeshBuffers:
    """``MeshBuffers`` of ``asset.mesh`` for ``camera``, with tangent frames for the UV sets its
    materials' normal maps use (those of a ``FixedAsset`` computed once)."""
    if isinstance(asset, FixedAsset):
        return asset.buffers.with_camera(camera)
    return MeshBuffers.build(asset.mesh, camera, tangent_uv_sets(asset))


def tangent_uv_sets(asset) -> set[int]:
    """The UV sets of ``asset.mesh`` that its materials' normal maps use."""
    return {m.normal.uv_set for m in asset.materials if m.normal is not None and m.normal.uv_set < len(asset.mesh.uv)}


def texture_sampler(asset, footprint: float = FOOTPRINT_SCALE) -> TextureSampler:
    """The sampler for one render of ``asset`` with lookups of ``footprint``: a ``FixedAsset``'s
    shared one where it keeps one of that footprint, else a new one (whose stacks and pyramids
    serve that render's layers and views)."""
    shared = asset.sampler if isinstance(asset, FixedAsset) else None
    return shared if shared is not None and shared.footprint == footprint else TextureSampler(footprint)


def texel_bytes(materials) -> int:
    """Bytes of the distinct texture maps of ``materials``."""
    maps = {id(t): t for m in materials for t in m.textures}
    return sum(t.data.numel() * t.data.element_size() for t in maps.values())


def edge_topology(asset, buffers: MeshBuffers) -> dr.EdgeTopology:
    """The antialiasing topology of ``buffers.tri`` (a ``FixedAsset``'s computed once)."""
    if isinstance(asset, FixedAsset):
        return asset.topology
    return dr.antialias_construct_topology_hash(buffers.tri)


SHARED_SAMPLER_TEXEL_BYTES = 512 * 2**20
"""A ``FixedAsset`` whose maps hold at most this many bytes keeps one ``TextureSampler`` for
all its views: its material stacks and their mip pyramids (about 2.3 times the maps' bytes)
are built once. Larger maps are stacked again for each render, as a latent's are."""


@dataclass
class FixedAsset:
    """An asset that never changes (a reference), rendered as the asset is (it has its
    ``mesh``, ``materials`` and ``source``), with what every view of it shares computed once:
    ``MeshBuffers.without_camera``, the antialiasing topology and the texture stacks with their
    mip pyramids, because rebuilding them for every view was a large share of each capture and
    each pool refresh (``docs/benchmarks.md``).

    Attributes:
        asset: the asset; buffers: its ``MeshBuffers`` without a camera; topology: its
            ``EdgeTopology``; sampler: the ``TextureSampler`` every view shares, or ``None``
            where the maps exceed ``SHARED_SAMPLER_TEXEL_BYTES``.
    """

    asset: object
    buffers: MeshBuffers
    topology: dr.EdgeTopology
    sampler: TextureSampler | None = None

    @staticmethod
    @torch.no_grad()
    def of(asset) -> FixedAsset:
        buffers = MeshBuffers.without_camera(asset.mesh, tangent_uv_sets(asset))
        shared = TextureSampler() if texel_bytes(asset.materials) <= SHARED_SAMPLER_TEXEL_BYTES else None
        return FixedAsset(asset, buffers, dr.antialias_construct_topology_hash(buffers.tri), shared)

    @torch.no_grad()
    def sharing(self, asset) -> FixedAsset:
        """A ``FixedAsset`` of ``asset``, which has this one's triangles and materials but other
        positions (a pose of it): its buffers are computed, the topology and the sampler shared."""
        return FixedAsset(asset, MeshBuffers.without_camera(asset.mesh, tangent_uv_sets(asset)), self.topology,
                          self.sampler)

    @property
    def mesh(self):
        return self.asset.mesh

    @property
    def materials(self):
        return self.asset.materials

    @property
    def source(self):
        return getattr(self.asset, "source", None)


