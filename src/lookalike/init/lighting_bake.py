"""The classic bake of lighting: a low-poly mesh with a UV atlas gets a texture of the light that
leaves the high-poly reference, path traced under the run's lighting (what Blender's Cycles
*Bake: Combined* from selected to active, or a light-map baker, gives an artist for an unlit or
light-mapped asset).

Each atlas sample finds its reference point as the projection bake does
(``lookalike.init.projection_bake``: the nearer hit along the low-poly smooth and shading normals
within the cage, else the closest point), and holds the mean radiance leaving that point over
cosine-weighted directions about the reference triangle's outward normal
(``lookalike.shading.surface_radiance``: what a view from any side sees there, shadows, bounced
light and emission included); samples are box-filtered to texels and uncovered texels take their
nearest covered one's value. The result is sharp at the texel, not the view's pixel, and its noise
is ``1 / sqrt(S)`` of one sample's for ``S`` samples per texel, averaged over directions rather
than learnt from noisy pictures. The samples are a budget for the whole atlas (``SAMPLE_BUDGET``),
so a small atlas, whose texels each cover many pixels, gets more of them per texel; its cost is
then about the same at every texture size.
"""

from __future__ import annotations

import numpy as np

from ..asset.asset import Asset
from ..asset.material import Texture
from ..asset.mesh import Mesh
from ..asset.normals import face_normals, safe_normalize
from ..errors import ConfigError
from ..shading.path_tracing import TracedScene
from ..shading.surface_radiance import mean_outgoing_radiance
from .projection_bake import (SAMPLES_PER_AXIS, atlas_texels, box_filter, default_cage, locate_on_reference,
                              nearest_covered, texels_to_image)

SAMPLE_BUDGET = 1 << 26
"""Path-traced directions for the whole atlas, shared among its covered texels..."""

SAMPLES_PER_TEXEL = (64, 1024)
"""...within these bounds per texel (each texel's shared among its ``SAMPLES_PER_AXIS ** 2``
sub-texels)."""


def samples_per_texel(texels: int, budget: int = SAMPLE_BUDGET) -> int:
    """Directions per texel for ``texels`` covered texels: ``budget / texels`` within
    ``SAMPLES_PER_TEXEL``."""
    low, high = SAMPLES_PER_TEXEL
    return int(min(max(budget // max(int(texels), 1), low), high))


def bake_lighting(reference: Asset, low: Mesh, scene: TracedScene, texture_size: int = 1024,
                  samples: int | None = None, seed: int = 0, cage: float | None = None) -> Texture:
    """``[S, S, 3]`` linear radiance of ``reference`` (drawn as ``scene``, its
    ``lookalike.shading.path_tracing.mitsuba_scene``) baked onto UV set 0 of ``low`` at
    ``texture_size`` (see the module), ``samples`` directions per texel (default
    ``samples_per_texel``), seeded by ``seed``; ``cage`` as the projection bake's."""
    if not low.uv:
        raise ConfigError("the low-poly mesh to bake onto needs a UV atlas in UV set 0 (see lookalike.init.unwrap)")
    cage = default_cage(reference.mesh) if cage is None else float(cage)
    texels = atlas_texels(low, texture_size * SAMPLES_PER_AXIS)
    if len(texels.rows) == 0:
        raise ConfigError(f"the low-poly mesh's UV atlas covers no texel of a {texture_size}^2 texture")
    found = locate_on_reference(reference, texels, cage)
    mesh = reference.mesh
    corners = mesh.v_pos.detach().double().numpy()[mesh.t_pos_idx.numpy()[found.triangle]]
    points = np.einsum("kc,kcd->kd", found.barycentric, corners)
    outward = safe_normalize(face_normals(mesh.v_pos.detach().double(), mesh.t_pos_idx)).numpy()[found.triangle]
    outward *= np.where(found.back, -1.0, 1.0)[:, None]
    _, radius = mesh.bounding_sphere()
    if samples is None:
        samples = samples_per_texel(len(texels.rows) // SAMPLES_PER_AXIS ** 2)
    per_sample = max(1, -(-int(samples) // SAMPLES_PER_AXIS ** 2))
    radiance = mean_outgoing_radiance(scene, points, outward, per_sample, float(radius), seed)
    rows, cols, (mean,) = box_filter(texels.rows, texels.cols, SAMPLES_PER_AXIS, [radiance.astype(np.float64)])
    return Texture(texels_to_image(rows, cols, nearest_covered(rows, cols, texture_size), mean))
