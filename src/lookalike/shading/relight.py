"""A view whose light can change: one camera's G-buffer, rasterized and sampled once, lit again
under any point light.

The reference's geometry never changes during a fit, and for one camera everything the shader
needs but the light (positions, the normal-mapped shading normal, the view direction,
material samples, coverage, and the silhouette blend of ``render.antialias``) is fixed. A
``CapturedView`` keeps that, for the covered samples only, and ``light`` redoes what ``render``
does from there (``light_points``, "over" an empty background, the outline blend, the
supersampling box filter): the same image as ``render(asset, camera, light, resolution, spp)``
up to the storage precision, at a cost that does not depend on the asset's triangle count.

Storage per covered sample: position and shading normal float32 (highlights are sharp in the
normal), the view direction recomputed from the position, the geometric normal and the
material samples ``dtype`` (float16 by default: colours to about 1e-3), the pixel index int32:
48 bytes, 54 with emission.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import torch

import lookalike.render as dr

from ..asset.normals import safe_normalize
from .camera import Camera
from .gbuffer import GBuffer
from .light import PointLight
from .peeled_layers import composite_over
from .pipeline import box_downsample, edge_topology, image_size, mesh_buffers, texture_sampler
from .points import SurfacePoints, light_points, surface_points
from .surface import sample_surface


@dataclass
class CapturedView:
    """One camera's view of an asset, ready to be lit (see the module docstring).

    Attributes:
        points: the ``N`` covered samples' ``SurfacePoints`` (``view`` all 0), stored compactly
            (``view_dir`` is ``None``: it is recomputed from ``eye``).
        eye: ``[3]`` the camera's position.
        pixel: ``[N]`` int32 flat indices into the ``[H * spp, W * spp]`` sample grid.
        blend: the outline blend of the sample grid (weights without gradients).
        height, width: the picture's size; spp: samples per pixel per axis.
    """

    points: SurfacePoints
    eye: torch.Tensor
    pixel: torch.Tensor
    blend: dr.OutlineBlend
    height: int
    width: int
    spp: int

    @property
    def nbytes(self) -> int:
        """Bytes of memory held by the view's tensors."""
        tensors = [getattr(self.points, f.name) for f in fields(SurfacePoints)] + [self.eye, self.pixel] + \
            [getattr(self.blend, f.name) for f in fields(dr.OutlineBlend)]
        return sum(t.untyped_storage().nbytes() for t in tensors if t is not None)

    def light(self, light: PointLight) -> torch.Tensor:
        """``[1, H, W, 4]`` float32 linear RGB (weighted by coverage) and coverage under
        ``light`` (batch 1), row 0 at the top, as ``render`` draws it."""
        points = SurfacePoints(**{f.name: _widened(getattr(self.points, f.name)) for f in fields(SurfacePoints)})
        points.view_dir = safe_normalize(self.eye - points.position)
        colour = light_points(points, light)
        full = self.height * self.spp * self.width * self.spp
        image = colour.new_zeros(full, 4).index_put((self.pixel.long(),), colour)
        image = image.reshape(1, self.height * self.spp, self.width * self.spp, 4)
        return box_downsample(self.blend.apply(composite_over(torch.zeros_like(image), image)), self.spp).flip(1)


def _widened(x: torch.Tensor | None) -> torch.Tensor | None:
    """Stored floats back to float32 (indices unchanged)."""
    return x if x is None or not x.is_floating_point() else x.float()


@torch.no_grad()
def capture_view(asset, camera: Camera, resolution, spp: int = 1, dtype: torch.dtype = torch.float16) -> CapturedView:
    """The ``CapturedView`` of ``asset`` from ``camera`` (batch 1) at ``resolution`` with ``spp``
    x ``spp`` samples per pixel (one depth layer, as ``render``'s default); the geometric
    normal and material samples stored as ``dtype``."""
    if camera.batch_size != 1:
        raise ValueError(f"capture_view takes one camera, not {camera.batch_size}")
    height, width = image_size(resolution)
    buffers = mesh_buffers(asset, camera)
    with dr.DepthPeeler(dr.RasterizeContext(), buffers.clip, buffers.tri, (height * spp, width * spp)) as peeler:
        rast, rast_db = peeler.rasterize_next_layer()
    gb = GBuffer.build(buffers, rast, rast_db)
    surface = sample_surface(asset.materials, asset.mesh.t_mat_idx, gb, texture_sampler(asset), getattr(asset, "source", None))
    points = surface_points(gb, surface, camera)
    stored = {f.name: getattr(points, f.name) for f in fields(SurfacePoints)}
    stored = {name: value if value is None else value.to(torch.float32 if name in ("position", "normal") else dtype).clone()
              for name, value in stored.items() if name not in ("view", "view_dir")}
    stored["view"] = torch.zeros(1, dtype=torch.int64).expand(gb.pixel.shape[0])  # one view: no storage per sample
    stored["view_dir"] = None
    blend = dr.outline_blend(rast, buffers.clip, buffers.tri, edge_topology(asset, buffers))
    return CapturedView(points=SurfacePoints(**stored), eye=camera.position[0].detach().clone(), pixel=gb.pixel.to(torch.int32), blend=blend,
                        height=height, width=width, spp=spp)
