"""The layers of one render (``lookalike.shading.pipeline``): peeled nearest first, each
shaded at its covered samples (or one random covered sample per pixel, stochastic MSAA) in the
window of the frame that holds its fragments, then composited back to front and antialiased.

All layers are found in one pass where their k-buffer fits (``one_pass_layers``); with
gradients they are shaded together, in one material lookup (``shade_points``). Samples behind
an opaque nearer layer are never shaded, and peeling stops at the first layer with nothing
left to show (``LayerCount`` counts the layers used, for reports)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial

import torch
import torch.nn.functional as F

import lookalike.render as dr
from lookalike.render.msaa import covered_sample_index, pick_samples, upsample_over
from lookalike.render.window import Window

from .camera import Camera
from .gbuffer import GBuffer, MeshBuffers
from .light import PointLight
from .points import facing_viewer, light_points, surface_points, visible_alpha
from .shadow_maps import DeepShadowMap
from .surface import Surface, sample_surface
from .texturing import TextureSampler


@dataclass
class Frame:
    """What every layer of one ``render`` call shares: the asset, its per-render vertex
    buffers, the views and lights, the texture sampler (mip pyramids built once per
    render, or once for all renders of a ``FixedAsset``) and, where the render draws shadows,
    the lights' shadow maps (``None``: every point the light faces is lit)."""

    asset: object
    buffers: MeshBuffers
    camera: Camera
    light: PointLight
    sampler: TextureSampler = field(default_factory=TextureSampler)
    shadow: DeepShadowMap | None = None


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
    lookup costs a pass over the whole stacked mip pyramid however few points it has. The light
    reaching each point is scaled by its transmittance where ``frame`` has shadow maps."""
    gb = GBuffer.concatenate(gbuffers)
    points = surface_points(gb, frame_surface(frame, gb), frame.camera)
    transmittance = (None if frame.shadow is None
                     else frame.shadow.transmittance(points.position, points.view, points.geometric_normal))
    colour = light_points(points, frame.light, transmittance)
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


def composite_over(accum: torch.Tensor, colour: torch.Tensor) -> torch.Tensor:
    """Straight-alpha ``colour [..., 4]`` over the opaque-or-empty ``accum [..., 4]`` ("over"):
    ``lerp(accum, (rgb, 1), alpha)``; a sample of alpha 0 leaves ``accum`` as it is even where
    its ``rgb`` is not finite (a back face's shading). A finite ``rgb`` is kept at alpha 0: the
    gradient of a transparent texel's alpha, ``rgb - accum``, says what it would show."""
    rgb = colour[..., :3]
    rgb = torch.where((colour[..., 3:] > 0) | torch.isfinite(rgb), rgb, 0.0)
    opaque = torch.cat([rgb, torch.ones_like(colour[..., 3:])], dim=-1)
    return torch.lerp(accum, opaque, colour[..., 3:])
