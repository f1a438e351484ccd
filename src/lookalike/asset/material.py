"""Materials in the paper's parameterisation.

Channels (all textures linear, ``[H, W, C]`` float32, row 0 at the top of the image,
sampled with glTF's UV convention: ``uv = (0, 0)`` is the top-left corner of the image):

- ``kd``     ``[H, W, 4]`` base colour RGB (linear) and alpha, factors already multiplied in.
- ``ks``     ``[H, W, 3]`` (gamma, roughness, metalness). ``gamma`` scales the specular lobe
             by ``(1 - gamma)`` (paper, Sec. 5.2); 0 means an ordinary glTF material.
- ``normal`` ``[H, W, 3]`` tangent-space unit normal (x right along the tangent, y along the
             bitangent, z out of the surface) in *our* tangent frame
             (``lookalike.asset.tangents.vertex_tangents``), or ``None`` for a flat map.
             File formats convert from and to MikkTSpace at the boundary.
- ``emissive`` ``[H, W, 3]`` linear emitted radiance (factor and strength multiplied in, so values
             may exceed 1), added to the shaded colour, or ``None``.
- ``displacement`` a ``Displacement``: heights ``[H, W, 1]`` that move the vertices of the
             mesh, tessellated, along their normals (``lookalike.asset.displacement``), or ``None``.
- ``occlusion`` ``[H, W, 1]`` ambient occlusion in [0, 1] (glTF ``occlusionTexture``'s R channel
             with its ``strength`` applied: ``1 + strength * (R - 1)``), or ``None``. Only
             engines' ambient light uses it; our point-light renderer does not.

A constant channel is a 1x1 texture. Colour is linear inside; sRGB only at file boundaries.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import torch

ALPHA_MODES = ("OPAQUE", "MASK", "BLEND")


@dataclass
class Texture:
    """One texture channel of a material.

    Attributes:
        data: ``[H, W, C]`` float32 texels (linear).
        uv_set: which UV set of the mesh it is sampled with (glTF ``texCoord``).
        transform: ``[3, 3]`` float32 affine map applied to ``(u, v, 1)`` before sampling
            (glTF KHR_texture_transform), or ``None`` for identity.
        wrap: boundary mode, ``"wrap"`` or ``"clamp"`` (nvdiffrast names).
        mips: optional ``[H/2^i, W/2^i, C]`` levels 1.. that are latent variables of their own
            (prefiltering); ``None`` builds mips from ``data``.
    """

    data: torch.Tensor
    uv_set: int = 0
    transform: torch.Tensor | None = None
    wrap: str = "wrap"
    mips: list[torch.Tensor] | None = None

    @property
    def channels(self) -> int:
        return int(self.data.shape[-1])

    @staticmethod
    def constant(values) -> "Texture":
        """A 1x1 texture holding ``values`` (length C)."""
        return Texture(torch.as_tensor(values, dtype=torch.float32).reshape(1, 1, -1).clone())


@dataclass
class Displacement:
    """A displacement map (paper Sec. 5.1): the mesh is drawn subdivided ``level`` times (edge
    midpoints, ``lookalike.asset.subdivide``) and each vertex moved along its normal by
    ``scale * (h - offset)``, ``h`` the map sampled bilinearly at the vertex's UV (Blender's
    Displace modifier's strength and midlevel).

    Attributes:
        heights: ``[S, S, 1]`` texture of heights in [0, 1].
        scale: world units per unit of height.
        offset: the height that leaves a vertex in place.
        level: the tessellation level it is drawn at.
        shading: ``"engine"``: a vertex moves along the base's interpolated normal, which is
            also its shading normal (the normal map in the base's interpolated frame), as
            hardware and Nanite tessellation draw it; ``"recomputed"``: it moves along the
            subdivided mesh's own vertex normal and shading follows the displaced geometry,
            as Blender's Displace modifier and Cycles' true displacement draw it
            (``lookalike.settings.SHADING_CONVENTIONS``).
        detail_level: ``None``: every level reads the map at its vertices alone (a
            tessellator's domain shader, Blender's Displace modifier); a level ``D``: each coarser
            level also rises by the mean of what the level-``D`` surface rises above its chords
            (``lookalike.asset.displacement.chord_rise``), so that it straddles the relief.
    """

    heights: Texture
    scale: float
    offset: float = 0.5
    level: int = 0
    shading: str = "engine"
    detail_level: int | None = None


@dataclass
class Material:
    """A PBR material (paper, Sec. 5.2; glTF metallic-roughness).

    Attributes:
        name: material name from the file.
        kd: base colour + alpha texture, 4 channels.
        ks: (gamma, roughness, metalness) texture, 3 channels.
        normal: tangent-space normal map, 3 channels, or ``None`` (flat).
        alpha_mode: ``"OPAQUE"``, ``"MASK"`` or ``"BLEND"``.
        alpha_cutoff: threshold for ``"MASK"``.
        coverage_ramp: ``"MASK"`` while a fit trains it: the width ``w`` of the ramp over
            which coverage rises around the cutoff ``c``, ``clamp((alpha - c) / w + 1/2, 0, 1)``
            (at ``w = 1``, ``c = 1/2`` it is alpha itself, as blended); 0, as glTF draws it
            and as every written model has it, is the hard test. A fit narrows it to 0 so that
            the alpha test is trained in, not imposed at the end (``lookalike.fit.textured_mesh``).
        double_sided: render back faces (with flipped normals).
        emissive: optional emission texture, 3 channels (linear), rendered additively.
        occlusion: optional ambient occlusion texture, 1 channel, strength applied; kept and
            written for engines (it darkens ambient light only, which we do not render).
        displacement: optional ``Displacement`` of the mesh drawn with this material.
        unlit: drawn without light (glTF ``KHR_materials_unlit``): its colour is its emission,
            ``kd``'s colour is black (its alpha still applies) and ``ks`` is ``(1, 1, 0)`` (no
            specular lobe), so that our renderer, which adds emission to the lit colour, draws
            it as unlit viewers do.
    """

    name: str = "material"
    kd: Texture = field(default_factory=lambda: Texture.constant([0.75, 0.72, 0.68, 1.0]))
    ks: Texture = field(default_factory=lambda: Texture.constant([0.0, 0.45, 0.0]))
    normal: Texture | None = None
    alpha_mode: str = "OPAQUE"
    alpha_cutoff: float = 0.5
    coverage_ramp: float = 0.0
    double_sided: bool = False
    emissive: Texture | None = None
    occlusion: Texture | None = None
    displacement: Displacement | None = None
    unlit: bool = False

    def __post_init__(self):
        if self.alpha_mode not in ALPHA_MODES:
            raise ValueError(f"alpha_mode must be one of {ALPHA_MODES}, not {self.alpha_mode!r}")

    @property
    def uses_alpha(self) -> bool:
        return self.alpha_mode != "OPAQUE"

    @property
    def textures(self) -> list[Texture]:
        """The material's textures that are present: base colour, specular, then the normal
        map, emission and occlusion where it has them."""
        return [t for t in (self.kd, self.ks, self.normal, self.emissive, self.occlusion) if t is not None]


def unlit_material(material: Material, colour: Texture | None) -> Material:
    """``material`` drawn unlit in ``colour`` (``[H, W, 3]`` linear, or ``None`` for black):
    ``Material.unlit``, with ``kd``'s alpha kept and no normal map."""
    kd = material.kd
    black = torch.cat([torch.zeros_like(kd.data[..., :3]), kd.data[..., 3:]], dim=-1)
    return dataclasses.replace(material, unlit=True, normal=None, emissive=colour,
                               ks=Texture.constant([1.0, 1.0, 0.0]), kd=dataclasses.replace(kd, data=black, mips=None))
