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
- No ambient light: surfaces the point light does not reach are black.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial

import torch
import torch.nn.functional as F

import lookalike.render as dr
from lookalike.render.msaa import covered_sample_index, pick_samples, upsample_over
from lookalike.render.window import Window

from ..asset.normals import safe_normalize
from .camera import Camera
from .gbuffer import GBuffer, MeshBuffers
from .light import PointLight
from .normal_map import shading_normal
from .point_lighting import lit_radiance
from .surface import Surface, sample_surface
from .texturing import TextureSampler


def _dot(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    return (a * b).sum(dim=-1, keepdim=True)


@dataclass
class SurfacePoints:
    """What shading needs of N G-buffer points that does not depend on the light (so a
    G-buffer can be lit again under other lights).

    Attributes:
        view: ``[N]`` int64 view (batch) index.
        position: ``[N, 3]`` world positions.
        normal: ``[N, 3]`` unit shading normal: normal-mapped, flipped on back faces, bent
            towards the viewer (``normal_map``).
        geometric_normal: ``[N, 3]`` unit face normal, flipped on back faces (the horizon test's).
        view_dir: ``[N, 3]`` unit direction to the camera.
        kd: ``[N, 3]`` linear base colour; ks: ``[N, 3]`` (gamma, roughness, metalness).
        emissive: ``[N, 3]`` linear emission, or ``None``.
        alpha: ``[N, 1]`` coverage (0 on culled back faces).
    """

    view: torch.Tensor
    position: torch.Tensor
    normal: torch.Tensor
    geometric_normal: torch.Tensor
    view_dir: torch.Tensor
    kd: torch.Tensor
    ks: torch.Tensor
    emissive: torch.Tensor | None
    alpha: torch.Tensor


def surface_points(gb: GBuffer, surface: Surface, camera: Camera) -> SurfacePoints:
    """The light-independent shading inputs of the G-buffer's pixels (see ``SurfacePoints``)."""
    view_dir, front = facing_viewer(gb, camera)
    facing = torch.where(front, 1.0, -1.0).to(view_dir)
    normal = shading_normal(gb.normal, *_normal_map_inputs(gb, surface), gb.geometric_normal, view_dir, facing[:, 0])
    return SurfacePoints(view=gb.view, position=gb.position, normal=normal, geometric_normal=gb.geometric_normal * facing,
                         view_dir=view_dir, kd=surface.kd[:, :3], ks=surface.ks, emissive=surface.emissive,
                         alpha=visible_alpha(surface, front))


def facing_viewer(gb: GBuffer, camera: Camera) -> tuple[torch.Tensor, torch.Tensor]:
    """``(view_dir [N, 3], front [N, 1] bool)``: the unit direction from each pixel's point to
    its camera, and whether the point's face is turned towards it."""
    view_dir = safe_normalize(camera.position.to(gb.position)[gb.view] - gb.position)
    return view_dir, _dot(gb.geometric_normal, view_dir) >= 0


def visible_alpha(surface: Surface, front: torch.Tensor) -> torch.Tensor:
    """``[N, 1]`` coverage: the material's alpha, 0 on the back faces of single-sided materials."""
    return surface.alpha * (front | surface.double_sided[:, None]).to(surface.alpha)


def _normal_map_inputs(gb: GBuffer, surface: Surface) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """``(tangent [N, 4], tangent_space [N, 3], mapped [N] bool)`` for ``shading_normal``: each
    pixel's tangent frame of the UV set its normal map uses, and its normal-map value."""
    mapped = torch.zeros(gb.position.shape[0], dtype=torch.bool, device=gb.position.device)
    if surface.normal_map is None or not gb.tangent:
        return gb.position.new_zeros(mapped.shape[0], 4), gb.position.new_zeros(mapped.shape[0], 3), mapped
    tangent = None
    for uv_set, frame in gb.tangent.items():
        rows = surface.normal_uv_set == uv_set
        tangent = frame if tangent is None else torch.where(rows[:, None], frame, tangent)
        mapped = mapped | rows
    return tangent, surface.normal_map, mapped


def light_points(points: SurfacePoints, light: PointLight) -> torch.Tensor:
    """Straight-alpha colour ``[N, 4]`` (linear radiance, coverage) of ``points`` under
    ``light``: ``lit_radiance`` (``bsdf.shade(kd, ks, n, v, l) * irradiance``, compiled) +
    emissive, no light where the view's horizon test finds the light below the geometric surface."""
    radiance = lit_radiance(points.kd, points.ks, points.normal, points.view_dir, points.position,
                            points.geometric_normal, points.view, light)
    if points.emissive is not None:
        radiance = radiance + points.emissive
    return torch.cat([radiance, points.alpha], dim=-1)


@dataclass
class Frame:
    """What every layer of one ``render`` call shares: the asset, its per-render vertex
    buffers, the views and lights, and the texture sampler (mip pyramids built once per
    render, or once for all renders of a ``FixedAsset``)."""

    asset: object
    buffers: MeshBuffers
    camera: Camera
    light: PointLight
    sampler: TextureSampler = field(default_factory=TextureSampler)


def layer_gbuffer(frame: Frame, rast: torch.Tensor, rast_db: torch.Tensor, needed: torch.Tensor, factor: int,
                  window: Window) -> tuple[GBuffer, tuple[int, int, int]]:
    """The points of one rasterized layer (``rast``, ``rast_db [B, H, W, 4]``, the ``window``
    of the frame) to shade, where ``needed [B, H, W]`` (bool) and covered: every sample
    (``factor`` 1), or one random covered sample per ``factor x factor`` pixel (stochastic
    MSAA, see the module docstring). Returns the G-buffer and the shape ``(B, h, w)`` of the
    image its ``pixel`` indices point into (the samples', or the pixels')."""
    if factor == 1:
        return GBuffer.build(frame.buffers, rast, rast_db, needed), tuple(rast.shape[:3])
    low_rast, low_db = random_covered_samples(rast, rast_db, factor, window)
    batch, high, wide = needed.shape
    low_needed = needed.reshape(batch, high // factor, factor, wide // factor, factor).any(dim=4).any(dim=2)
    return GBuffer.build(frame.buffers, low_rast, low_db, low_needed), tuple(low_rast.shape[:3])


def shade_points(frame: Frame, gbuffers: list[GBuffer]) -> list[torch.Tensor]:
    """Straight-alpha colour ``[N_i, 4]`` of the points of each of ``gbuffers`` (the layers of
    one render), shaded together: one material lookup for all, because the backward pass of each
    lookup costs a pass over the whole stacked mip pyramid however few points it has."""
    gb = GBuffer.concatenate(gbuffers)
    colour = light_points(surface_points(gb, frame_surface(frame, gb), frame.camera), frame.light)
    return list(torch.split(colour, [part.pixel.shape[0] for part in gbuffers]))


@torch.no_grad()
def points_alpha(frame: Frame, gb: GBuffer) -> torch.Tensor:
    """``[N, 1]`` coverage of the points of ``gb`` (no gradient): what ``shade_points`` gives as
    alpha, without the lighting, to know what the layers behind will show."""
    return visible_alpha(frame_surface(frame, gb), facing_viewer(gb, frame.camera)[1])


def frame_surface(frame: Frame, gb: GBuffer) -> Surface:
    """The material parameters of ``frame``'s asset at the points of ``gb``."""
    asset = frame.asset
    return sample_surface(asset.materials, asset.mesh.t_mat_idx, gb, frame.sampler, getattr(asset, "source", None))


def points_image(gb: GBuffer, values: torch.Tensor, shape: tuple[int, int, int]) -> torch.Tensor:
    """``[B, h, w, C]``: ``values [N, C]`` of the points of ``gb`` at their pixels of an image
    shaped ``shape = (B, h, w)``, zero elsewhere."""
    image = values.new_zeros(shape[0] * shape[1] * shape[2], values.shape[1])
    return image.index_put((gb.pixel,), values).reshape(*shape, values.shape[1])


def random_covered_samples(rast: torch.Tensor, rast_db: torch.Tensor, factor: int, window: Window):
    """One sample per ``factor x factor`` block for stochastic MSAA shading: a covered sample
    of the block drawn uniformly at random (any of its samples where none is covered), with
    ``torch``'s global generator.

    Args:
        rast, rast_db: ``[B, H*factor, W*factor, 4]``, the ``window`` of the frame (bounds on
            multiples of ``factor``).
    Returns:
        ``(rast [B, H, W, 4], rast_db [B, H, W, 4])``; the derivatives stay the sample's own
        (its texture footprint is the sample spacing, as when every sample is shaded). The
        random numbers are drawn for the whole frame and cropped, so a pixel's draw does not
        depend on the window.
    """
    pixels = window.coarse(factor)
    u = torch.rand(rast.shape[0], pixels.frame_height, pixels.frame_width, dtype=rast.dtype, device=rast.device)
    index = covered_sample_index(rast[..., 3], pixels.crop(u).contiguous(), factor)
    return pick_samples(rast, index), pick_samples(rast_db, index)


def layer_over(colour: torch.Tensor, rast: torch.Tensor, factor: int) -> Callable[[torch.Tensor], torch.Tensor]:
    """``accum [B, H, W, 4] -> [B, H, W, 4]``: one layer's straight-alpha ``colour`` (per sample,
    or per ``factor x factor`` pixel where ``factor`` > 1) composited over ``accum`` at the
    samples of ``rast [B, H, W, 4]``."""
    if factor == 1:
        return partial(composite_over, colour=colour)
    return partial(upsample_over, colour=colour, ids=rast[..., 3], factor=factor)


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


@dataclass
class LayerCount:
    """How deep a caller's renders peeled, for reports: pass one to ``render`` calls and read
    it after. A layer counts as used when it had a sample to shade (peeling stops at the first
    that has none, or at ``layers``).

    Attributes:
        renders: ``render`` calls counted; layers: layers used, summed over them; deepest:
            the most layers one of them used.
    """

    renders: int = 0
    layers: int = 0
    deepest: int = 0

    def add(self, used: int) -> None:
        """Count one render that used ``used`` layers."""
        self.renders += 1
        self.layers += used
        self.deepest = max(self.deepest, used)

    @property
    def mean(self) -> float:
        """Layers used per render (0 before any)."""
        return self.layers / self.renders if self.renders else 0.0


@dataclass
class ShadedLayer:
    """One peeled layer, shaded: the ``window`` of the frame where it has fragments (with a
    margin), its ``rast [B, h, w, 4]`` there, and ``over(accum [B, h, w, 4])``, which
    composites it over what lies behind within the window."""

    window: Window
    rast: torch.Tensor
    over: Callable[[torch.Tensor], torch.Tensor]


def render(asset, camera: Camera, light: PointLight, resolution, spp: int = 1, layers: int = 1,
           background=None, msaa: bool = False, layer_count: LayerCount | None = None) -> torch.Tensor:
    """Render B views of an asset.

    Args:
        asset: an ``Asset`` or anything with ``.mesh`` (``Mesh``) and ``.materials``.
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
    Returns:
        ``[B, H, W, 4]`` linear RGB radiance and alpha, row 0 = top of the picture. RGB is
        composited over the background; with none, over black (so RGB is premultiplied by
        alpha).

    Each layer is shaded, composited and antialiased only within the window that holds its
    fragments (``lookalike.render.window.covered_window``), the same pixels' values as over the whole frame: a deep
    layer of foliage covers a small part of it.
    """
    height, width = image_size(resolution)
    buffers = mesh_buffers(asset, camera)
    frame = Frame(asset, buffers, camera, light, texture_sampler(asset))
    shaded = peel_and_shade(frame, (height * spp, width * spp), spp, layers, msaa and spp > 1)
    if layer_count is not None:
        layer_count.add(len(shaded))
    accum = background_image(background, camera.batch_size, height, width, spp, buffers.clip)
    accum = composite_layers(shaded, accum, buffers, edge_topology(asset, buffers))
    return box_downsample(accum, spp).flip(1)


K_BUFFER_BYTES = 1 << 30
"""The most memory the one-pass k-buffer of a render takes (``one_pass_layers``)."""


def one_pass_layers(layers: int, samples: int) -> int:
    """How many of ``layers`` a render of ``samples`` samples (all views) finds in one pass
    (``dr.DepthPeeler``'s k-buffer, 8 bytes per layer and sample): all of them where they fit
    in ``K_BUFFER_BYTES``, else as many as fit (at least one); the rest are peeled a pass each,
    each a full pass over the triangles."""
    return max(1, min(layers, K_BUFFER_BYTES // (8 * samples)))


def peel_and_shade(frame: Frame, full: tuple[int, int], spp: int, layers: int, sampled: bool) -> list[ShadedLayer]:
    """The shaded layers of ``frame`` at ``full = (H, W)`` samples, nearest first: at most
    ``layers``, stopping at the first with no sample to shade (none covered, or all behind
    opaque nearer layers). ``sampled``: stochastic MSAA at ``spp x spp`` samples per pixel.

    The layers are found in one pass where they fit (``one_pass_layers``). With
    gradients, all are shaded together (``shade_points``) after peeling, each layer's coverage
    taken first without them (``points_alpha``) to know which samples behind it can show;
    without, each layer is shaded as it is peeled and its own alpha serves. The images are the
    same either way."""
    buffers = frame.buffers
    factor = spp if sampled else 1
    together = torch.is_grad_enabled()  # one lookup for all layers pays off in the backward pass only
    peeled, colours = [], []
    outer = Window.whole(*full)
    transmittance = buffers.clip.new_ones(frame.camera.batch_size, *full)  # of the samples in ``outer``
    with dr.DepthPeeler(dr.RasterizeContext(), buffers.clip, buffers.tri, full,
                        layers=one_pass_layers(layers, frame.camera.batch_size * full[0] * full[1])) as peeler:
        for layer in range(layers):
            window, rast, rast_db = peeler.rasterize_next_window(spp)
            if window is None:
                break
            transmittance = window.crop(transmittance, within=outer)
            needed = (rast[..., 3] > 0) & (transmittance > 0)
            if not needed.any():
                break
            gb, shape = layer_gbuffer(frame, rast, rast_db, needed, factor, window)
            peeled.append((window, rast, gb, shape))
            if not together:
                colours.append(shade_points(frame, [gb])[0])
            if layer + 1 < layers:
                with torch.no_grad():  # the samples' alpha: the pixels' spread over their covered samples
                    alpha = points_alpha(frame, gb) if together else colours[-1][:, 3:]
                    alpha = points_image(gb, F.pad(alpha, (3, 0)), shape)
                    transmittance = transmittance * (1.0 - layer_over(alpha, rast, factor)(torch.zeros_like(rast))[..., 3])
            outer = window
    if together and peeled:
        colours = shade_points(frame, [gb for _, _, gb, _ in peeled])
    return [ShadedLayer(window, rast, layer_over(points_image(gb, colour, shape), rast, factor))
            for (window, rast, gb, shape), colour in zip(peeled, colours)]


def composite_layers(shaded: list[ShadedLayer], background: torch.Tensor, buffers: MeshBuffers,
                     topology: dr.EdgeTopology) -> torch.Tensor:
    """``[B, H, W, 4]``: the ``shaded`` layers (nearest first) composited back to front over
    ``background [B, H, W, 4]``, each antialiased after it is composited. Each works in its
    window, which holds the deeper layers' (a sample covered in a layer is covered in every
    nearer one): the image behind it is pasted into the background's window around it."""
    accum = shaded[-1].window.crop(background) if shaded else background
    for index in range(len(shaded) - 1, -1, -1):
        layer = shaded[index]
        accum = dr.antialias(layer.over(accum).contiguous(), layer.rast, buffers.clip, buffers.tri,
                             topology_hash=topology, window=layer.window)
        outer = shaded[index - 1].window if index > 0 else None
        accum = layer.window.paste(accum, outer.crop(background) if outer else background, within=outer)
    return accum


def mesh_buffers(asset, camera: Camera) -> MeshBuffers:
    """``MeshBuffers`` of ``asset.mesh`` for ``camera``, with tangent frames for the UV sets its
    materials' normal maps use (those of a ``FixedAsset`` computed once)."""
    if isinstance(asset, FixedAsset):
        return asset.buffers.with_camera(camera)
    return MeshBuffers.build(asset.mesh, camera, tangent_uv_sets(asset))


def tangent_uv_sets(asset) -> set[int]:
    """The UV sets of ``asset.mesh`` that its materials' normal maps use."""
    return {m.normal.uv_set for m in asset.materials if m.normal is not None and m.normal.uv_set < len(asset.mesh.uv)}


def texture_sampler(asset) -> TextureSampler:
    """The sampler for one render of ``asset``: a ``FixedAsset``'s shared one where it keeps
    one, else a new one (whose stacks and pyramids serve that render's layers and views)."""
    shared = asset.sampler if isinstance(asset, FixedAsset) else None
    return shared if shared is not None else TextureSampler()


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


def composite_over(accum: torch.Tensor, colour: torch.Tensor) -> torch.Tensor:
    """Straight-alpha ``colour [..., 4]`` over the opaque-or-empty ``accum [..., 4]`` ("over"):
    ``lerp(accum, (rgb, 1), alpha)``."""
    opaque = torch.cat([colour[..., :3], torch.ones_like(colour[..., 3:])], dim=-1)
    return torch.lerp(accum, opaque, colour[..., 3:])
