"""The latent model of ``simplify``: a low-poly mesh with one PBR material whose textures are
trainable (a :class:`~lookalike.fit.latent.Latent`).

Positions are stored in the unit frame of the reference's bounding sphere,
``world = centre + radius * v_pos``, so that learning rates mean the same on a model in
millimetres and one in metres; :meth:`TexturedMesh.export` returns world coordinates, i.e.
the input's own frame and units.

Regulariser (paper Sec. 6.3): the uniform Laplacian relative to the initial mesh,
``mean_i |delta_i - delta'_i|^2`` with ``delta = L v`` and ``delta'`` of the initial positions.
"""

from __future__ import annotations

import dataclasses
import math

import torch

from ..asset import Asset, Material, Mesh, Texture
from ..asset.field_planes import PlaneHold
from ..asset.laplacian import UniformLaplacian
from ..asset.pose import Poses
from ..asset.skinning import posed
from ..shading.camera import Camera
from ..shading.light import PointLight
from ..shading.peeled_layers import LayerCount
from ..shading.pipeline import render, render_coverage
from ..shading.shadow_maps import ShadowMapping
from ..shading.texturing import FOOTPRINT_SCALE
from ..settings import ClampConfig
from .position_steps import local_step_scale
from .slope_normals import normal_to_slopes, slopes_to_normal
from .fitted_mips import FittedMips
from .texture_pyramid import TexturePyramid


class TexturedMesh(torch.nn.Module):
    """Trainable mesh and textures.

    Parameters (float32), in groups ``"positions"`` (``v_pos``) and ``"textures"`` (the levels
    of the three texture pyramids):
        v_pos: ``[V, 3]`` positions in the unit frame, divided by ``position_steps`` where
            given (so that Adam steps each vertex by its own scale, ``lookalike.fit.position_steps``).
        kd: ``TexturePyramid`` of ``[S, S, 4]`` base colour + alpha when alpha is trained, else
            ``[S, S, 3]`` (alpha is then 1).
        ks: ``TexturePyramid`` of ``[S, S, 3]`` (gamma, roughness, metalness).
        normal: ``TexturePyramid`` of ``[S, S, 2]`` slopes (x, y) of the tangent-space normal,
            which is normalize(x, y, 1): always facing out of the surface, flat at (0, 0), and
            two parameters per texel instead of three with a unit-length constraint.
        kd_mips, ks_mips, normal_mips: with ``fitted_mips``, ``FittedMips`` of the three (their
            mip levels as variables of their own, ``lookalike.fit.fitted_mips``), else ``None``.
        emissive: ``TexturePyramid`` of ``[S, S, 3]`` linear emission divided by
            ``emissive_scale`` (``emission_scale``: the start's bright texels, at least 1), in its
            own group ``"emissive"``, where the start emits (else ``None``): Adam's steps are then
            relative to the map's range, which may exceed 1. It is clamped at 0 from below only.
    A channel given as a ``[1, 1, C]`` texture stays one constant (an untextured input's base
    colour: shading must not be painted into it).
    The ambient occlusion map ``occlusion`` ``[S, S, 1]`` (or ``None``) is a fixed buffer: the
    point-light views cannot see ambient light, so it is carried from the start to the export.
    ``layers_used`` (a ``LayerCount``, not part of the state) counts how deep its renders
    peeled, for the report.

    Buffers (fixed): ``t_pos_idx [T, 3]`` int64, ``t_nrm_idx [T, 3]`` int64 (the normal slots:
    smoothing groups, fixed at the start; the normals themselves are recomputed from the current
    positions at every render, ``lookalike.asset.normals.split_normals``), ``v_tex [VT, 2]``
    float32 and ``t_tex_idx [T, 3]`` int64 (the UV atlas), ``centre [3]`` and ``radius []`` float32, and
    ``rest_delta [V, 3]`` float32, the Laplacian differentials of the initial positions (zero
    with ``absolute_laplacian``: the paper's regulariser for a start that is not the shape, a
    sphere, which penalises the positions' roughness itself),
    ``position_steps [V, 1]`` float32 or ``None`` (every vertex steps alike).
    ``plane_hold`` (not part of the state: made again from the start) holds vertices on planes
    of the input after every step (``hold_on_planes``), or is ``None``.

    Args:
        mesh: the initial mesh in world coordinates, with its UV atlas in UV set 0 and its
            normal slots (none: smooth, one per position).
        kd, ks: initial textures as above (``[S, S, C]`` or ``[1, 1, C]``).
        normal: initial ``[S, S, 3]`` tangent-space normals (z > 0), converted to slopes.
        centre, radius: the unit frame.
        limits: the valid ranges the textures are projected onto (whenever they are read).
        msaa: visibility samples per axis when rendering (shading once per pixel).
        alpha_mode: the material's glTF alpha mode (``"OPAQUE"`` unless alpha is trained).
        double_sided: whether the material renders back faces.
        wrap: texture boundary mode, ``"clamp"`` for an atlas or the input's own mode when
            the latent reuses its UVs.
        texture_scales: the step scale of each texture level, finest first
            (``lookalike.fit.texture_pyramid``).
        emissive: initial ``[S, S, 3]`` linear emission, or ``None`` (no emission).
        occlusion: ``[S, S, 1]`` (or ``[1, 1, 1]``) ambient occlusion to carry, or ``None``.
        layers: depth-peeled layers its renders composite (``lookalike.shading.pipeline``).
        position_steps: ``[V, 1]`` step scale of each vertex, or ``None``.
        mask_anneal: the share of the run over which a ``"MASK"`` material's coverage ramp
            narrows from ``coverage_ramp`` to the hard test (``at_progress``); 0 keeps it.
        coverage_ramp: the ramp's width at the start (``Material.coverage_ramp``).
        fitted_mips: fit every mip level of kd, ks and normal as its own variable.
        footprint: scale of its texture lookups' footprint (``lookalike.shading.texturing``).
        shadows: how its renders draw its shadows on itself (``lookalike.shading.shadow_maps``),
            or ``None`` (no shadows).
    """

    def __init__(self, mesh: Mesh, kd: torch.Tensor, ks: torch.Tensor, normal: torch.Tensor,
                 centre: torch.Tensor, radius: float | torch.Tensor, limits: ClampConfig = ClampConfig(),
                 msaa: int = 1, alpha_mode: str = "OPAQUE", double_sided: bool = False, wrap: str = "clamp",
                 texture_scales: tuple[float, ...] = (1.0,), emissive: torch.Tensor | None = None,
                 occlusion: torch.Tensor | None = None, layers: int = 1,
                 position_steps: torch.Tensor | None = None, mask_anneal: float = 0.0, coverage_ramp: float = 0.0,
                 fitted_mips: bool = False, absolute_laplacian: bool = False, footprint: float = FOOTPRINT_SCALE,
                 shadows: ShadowMapping | None = None):
        super().__init__()
        centre = torch.as_tensor(centre, dtype=torch.float32, device=mesh.v_pos.device)
        radius = torch.as_tensor(radius, dtype=torch.float32, device=mesh.v_pos.device)
        self.register_buffer("centre", centre.clone())
        self.register_buffer("radius", radius.clone())
        self.register_buffer("t_pos_idx", mesh.t_pos_idx.clone())
        self.register_buffer("t_nrm_idx", (mesh.t_pos_idx if mesh.t_nrm_idx is None else mesh.t_nrm_idx).clone())
        self.register_buffer("v_tex", mesh.v_tex.clone())
        self.register_buffer("t_tex_idx", mesh.t_tex_idx.clone())
        self.register_buffer("position_steps", None if position_steps is None else position_steps.float().clone())
        unit = (mesh.v_pos.float() - centre) / radius
        self.v_pos = torch.nn.Parameter(unit if position_steps is None else unit / self.position_steps)
        self.kd = TexturePyramid(kd, texture_scales)
        self.ks = TexturePyramid(ks, texture_scales)
        self.normal = TexturePyramid(normal_to_slopes(normal.float()), texture_scales)
        self.kd_mips, self.ks_mips, self.normal_mips = (
            (FittedMips(*t.shape, texture_scales).to(mesh.v_pos.device) if fitted_mips else None) for t in (self.kd, self.ks, self.normal))
        self.laplacian = UniformLaplacian(self.t_pos_idx, self.v_pos.shape[0])
        rest = self.laplacian.differentials(unit)
        self.register_buffer("rest_delta", torch.zeros_like(rest) if absolute_laplacian else rest)
        self.absolute_laplacian = absolute_laplacian
        self.laplacian_scale = float((rest ** 2).sum(dim=-1).mean())
        self.limits = limits
        self.msaa = msaa
        self.alpha_mode = alpha_mode
        self.double_sided = double_sided
        self.wrap = wrap
        self.layers = layers
        self.footprint = footprint
        self.shadows = shadows
        self.mask_anneal = mask_anneal
        self.start_ramp = coverage_ramp
        self.coverage_ramp = coverage_ramp
        self.layers_used = LayerCount()
        self.emissive_scale = 1.0 if emissive is None else emission_scale(emissive)
        self.emissive = None if emissive is None else TexturePyramid(emissive.float() / self.emissive_scale,
                                                                       texture_scales)
        self.register_buffer("occlusion", None if occlusion is None else occlusion.float().clone())
        self.plane_hold: PlaneHold | None = None
        self._bound_textures()

    def _bound_textures(self) -> None:
        """Give each texture pyramid the ranges of ``limits`` (it projects itself onto them
        whenever it is read): kd into ``limits.kd``, each specular channel into its range, each
        normal slope into [-limits.normal_max_slope, limits.normal_max_slope], emission >= 0;
        their fitted mips (where there are) into the same ranges."""
        limits = self.limits
        ranges = torch.tensor([limits.gamma, limits.roughness, limits.metalness], dtype=torch.float32)
        bounds = {"kd": limits.kd, "ks": (ranges[:, 0], ranges[:, 1]),
                  "normal": (-limits.normal_max_slope, limits.normal_max_slope)}
        for name, (low, high) in bounds.items():
            getattr(self, name).set_bounds(low, high)
            if getattr(self, f"{name}_mips") is not None:
                getattr(self, f"{name}_mips").set_bounds(low, high)
        if self.emissive is not None:
            self.emissive.set_bounds(0.0, None)

    @classmethod
    def from_asset(cls, asset: Asset, centre: torch.Tensor, radius: float, limits: ClampConfig, msaa: int,
                   train_alpha: bool, constant: frozenset[str] = frozenset(),
                   texture_scales: tuple[float, ...] = (1.0,), layers: int = 1, position_steps: str = "uniform",
                   mask_anneal: float = 0.0, fitted_mips: bool = False, absolute_laplacian: bool = False,
                   footprint: float = FOOTPRINT_SCALE, shadows: ShadowMapping | None = None) -> TexturedMesh:
        """The latent starting from ``asset``: its mesh (UV set 0, normal slots) and its first material's
        base colour (alpha kept where ``train_alpha``), specular and normal textures (a flat
        normal map where it has none). The channels named in ``constant`` (``"kd"``, ``"ks"``)
        are held as one value, the mean of the start's texels (``"kd"`` never where its alpha
        is trained: the coverage varies). Normals are lifted to face out
        by at least ``1 / limits.normal_max_slope`` (a bake can see a few texels from behind),
        and every texel is clamped into ``limits``. ``layers``, ``mask_anneal``: see the class;
        ``position_steps``: ``"local"`` steps each vertex by its local size
        (``lookalike.fit.position_steps``), ``"uniform"`` all alike. A trained ``"MASK"``
        material's ``coverage_ramp`` is where the ramp starts; ``fitted_mips``,
        ``absolute_laplacian``, ``footprint``, ``shadows``: see the class."""
        material = asset.materials[0]
        kd = material.kd.data[..., :4 if train_alpha else 3]
        ks = material.ks.data
        size = max(kd.shape[:2], ks.shape[:2])
        normal = (material.normal.data if material.normal is not None
                  else torch.tensor([0.0, 0.0, 1.0]).expand(*size, 3))
        if train_alpha:  # coverage varies over the cards even where the colour does not
            constant = constant - {"kd"}
        kd, ks = (texels.reshape(-1, texels.shape[-1]).mean(dim=0).reshape(1, 1, -1) if name in constant else texels
                  for name, texels in (("kd", kd), ("ks", ks)))
        mesh = Mesh(v_pos=asset.mesh.v_pos, t_pos_idx=asset.mesh.t_pos_idx, uv=[asset.mesh.uv[0]],
                    t_nrm_idx=asset.mesh.t_nrm_idx)
        steps = local_step_scale(mesh.v_pos, mesh.t_pos_idx, float(radius)) if position_steps == "local" else None
        latent = cls(mesh, kd, ks, _facing_outwards(normal, limits), centre, radius, limits=limits,
                     msaa=msaa, alpha_mode=material.alpha_mode if train_alpha else "OPAQUE",
                     double_sided=material.double_sided, wrap=material.kd.wrap, texture_scales=texture_scales,
                     layers=layers, position_steps=steps, mask_anneal=mask_anneal,
                     coverage_ramp=material.coverage_ramp if train_alpha else 0.0, fitted_mips=fitted_mips,
                     absolute_laplacian=absolute_laplacian, footprint=footprint, shadows=shadows,
                     **_emission_and_occlusion(material, size))
        return latent

    def get_extra_state(self) -> dict:
        return {"alpha_mode": self.alpha_mode, "double_sided": self.double_sided, "wrap": self.wrap,
                "msaa": self.msaa, "layers": self.layers, "limits": dataclasses.asdict(self.limits),
                "mask_anneal": self.mask_anneal, "start_ramp": self.start_ramp, "coverage_ramp": self.coverage_ramp}

    def set_extra_state(self, state: dict) -> None:
        self.alpha_mode = state["alpha_mode"]
        self.double_sided = state["double_sided"]
        self.wrap = state["wrap"]
        self.msaa = state["msaa"]
        self.layers = state.get("layers", 1)
        self.mask_anneal = state.get("mask_anneal", 0.0)
        self.start_ramp = state.get("start_ramp", 0.0)
        self.coverage_ramp = state.get("coverage_ramp", 0.0)
        self.limits = ClampConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in state["limits"].items()})
        self._bound_textures()

    @property
    def trains_alpha(self) -> bool:
        return self.kd.shape[-1] == 4

    def parameter_groups(self) -> dict[str, list[torch.nn.Parameter]]:
        maps = (self.kd, self.ks, self.normal, self.kd_mips, self.ks_mips, self.normal_mips)
        groups = {"positions": [self.v_pos],
                  "textures": [p for texture in maps if texture is not None for p in texture.parameters()]}
        if self.emissive is not None:
            groups["emissive"] = list(self.emissive.parameters())
        return groups

    def unit_positions(self) -> torch.Tensor:
        """``[V, 3]`` positions in the unit frame: ``v_pos``, times ``position_steps`` where given."""
        return self.v_pos if self.position_steps is None else self.v_pos * self.position_steps

    def world_positions(self) -> torch.Tensor:
        """``[V, 3]`` positions in the input's frame: centre + radius * unit positions (differentiable)."""
        return self.centre + self.radius * self.unit_positions()

    def at_progress(self, fraction: float | None) -> None:
        """Follow the run's schedule at ``fraction`` of it (``None`` until its length is known,
        taken as 0): the coverage ramp ``w = start * max(0, 1 - fraction / mask_anneal)``."""
        if self.mask_anneal > 0:
            self.coverage_ramp = self.start_ramp * max(0.0, 1.0 - (fraction or 0.0) / self.mask_anneal)

    def base_color(self) -> Texture:
        """The ``[S, S, 4]`` base colour and alpha (alpha 1 where it is not trained), with its
        fitted mips where it has them."""
        kd = self.kd()
        levels = [kd, *_mips(self.kd_mips, kd)]
        if not self.trains_alpha:
            levels = [torch.cat([level, torch.ones_like(level[..., :1])], dim=-1) for level in levels]
        return Texture(levels[0], wrap=self.wrap, mips=levels[1:] or None)

    def emission(self) -> torch.Tensor | None:
        """``[S, S, 3]`` linear emission (``emissive * emissive_scale``), or ``None``."""
        return None if self.emissive is None else self.emissive() * self.emissive_scale

    def unit_normal(self) -> Texture:
        """The ``[S, S, 3]`` unit tangent-space normal map, normalize(x, y, 1), with its fitted
        mips (each level's slopes made unit normals) where it has them."""
        slopes = self.normal()
        levels = [slopes_to_normal(level) for level in (slopes, *_mips(self.normal_mips, slopes))]
        return Texture(levels[0], wrap=self.wrap, mips=levels[1:] or None)

    def specular(self) -> Texture:
        """The ``[S, S, 3]`` specular map (gamma, roughness, metalness) with its fitted mips
        where it has them."""
        ks = self.ks()
        return Texture(ks, wrap=self.wrap, mips=_mips(self.ks_mips, ks) or None)

    def as_asset(self, coverage_ramp: float | None = None) -> Asset:
        """The model as an ``Asset`` in world coordinates, differentiable with respect to the
        parameters (``export`` gives a detached one), its alpha test at ``coverage_ramp``
        (``None``: the schedule's current one)."""
        mesh = Mesh(v_pos=self.world_positions(), t_pos_idx=self.t_pos_idx, uv=[(self.v_tex, self.t_tex_idx)],
                    t_nrm_idx=self.t_nrm_idx)
        material = Material(
            name="lookalike",
            kd=self.base_color(),
            ks=self.specular(),
            normal=self.unit_normal(),
            alpha_mode=self.alpha_mode,
            coverage_ramp=self.coverage_ramp if coverage_ramp is None else coverage_ramp,
            double_sided=self.double_sided,
            emissive=None if self.emissive is None else Texture(self.emission(), wrap=self.wrap),
            occlusion=None if self.occlusion is None else Texture(self.occlusion, wrap=self.wrap),
        )
        return Asset(mesh=mesh, materials=[material])

    @torch.no_grad()
    def export(self) -> Asset:
        """The model as written: detached, its alpha test hard (as glTF draws it)."""
        return self.as_asset(coverage_ramp=0.0)

    def render(self, camera: Camera, light: PointLight, resolution: int, pose: Poses | None = None) -> torch.Tensor:
        """One shading sample per pixel, at a random one of its ``msaa`` x ``msaa``
        visibility samples (stochastic MSAA, ``lookalike.shading.pipeline``): ``[B, H, W, 4]``,
        differentiable; in expectation, ``render_asset``'s image. The mesh does not move:
        ``pose`` is ignored."""
        return self.draw(self.as_asset(), camera, light, resolution)

    def draw(self, asset: Asset, camera: Camera, light: PointLight, resolution: int) -> torch.Tensor:
        """``render`` of ``asset``, this model as ``as_asset`` gives it or in another shape (a
        pose of it): ``[B, H, W, 4]``, differentiable."""
        return render(asset, camera, light, (resolution, resolution), spp=self.msaa, layers=self.layers,
                      msaa=self.msaa > 1, layer_count=self.layers_used, footprint=self.footprint,
                      shadows=self.shadows)

    def coverage(self, camera: Camera, resolution: int, pose: Poses | None = None) -> torch.Tensor | None:
        """``[B, H, W]`` antialiased coverage with ``msaa`` x ``msaa`` samples; ``None`` where
        alpha is trained (coverage is then a texture's too). ``pose`` is ignored."""
        return self.coverage_at(self.world_positions(), camera, resolution)

    def coverage_at(self, v_pos: torch.Tensor, camera: Camera, resolution: int) -> torch.Tensor | None:
        """``coverage`` with the mesh at positions ``v_pos [V, 3]`` (world coordinates)."""
        if self.alpha_mode != "OPAQUE":
            return None
        return render_coverage(Mesh(v_pos=v_pos, t_pos_idx=self.t_pos_idx), camera, (resolution, resolution), self.msaa)

    def regularizers(self) -> dict[str, torch.Tensor]:
        return {"laplacian": self.laplacian.loss(self.unit_positions(), self.rest_delta)}

    def regularizer_scales(self) -> dict[str, float]:
        """``{"laplacian": mean_i |delta'_i|^2}``, the absolute Laplacian energy of the initial
        mesh (the relative term itself is zero at the start)."""
        return {"laplacian": self.laplacian_scale}

    def hold_on_planes(self, hold: PlaneHold) -> None:
        """Keep the vertices ``hold`` names (in the input's frame) on their planes from now on,
        after every step (``clamp_``), and move them there now."""
        self.plane_hold = hold.to(self.v_pos.device).in_frame(self.centre, self.radius)
        self.clamp_()
        if not self.absolute_laplacian:   # the relative Laplacian keeps the held start's shape
            self.rest_delta.copy_(self.laplacian.differentials(self.unit_positions().detach()))

    def clamp_(self) -> None:
        """Move the held vertices back onto their planes (``hold_on_planes``), where there are.
        Nothing else: the texture pyramids project themselves onto ``limits`` whenever they are
        read (``_bound_textures``), so each pyramid is summed once per step, by the render."""
        if self.plane_hold is None:
            return
        with torch.no_grad():
            held = self.plane_hold.apply(self.unit_positions())
            self.v_pos.copy_(held if self.position_steps is None else held / self.position_steps)


def _mips(mips: FittedMips | None, texture: torch.Tensor) -> list[torch.Tensor]:
    """The fitted mip levels of ``texture`` (``[]`` without ``mips``, or for a constant)."""
    return [] if mips is None else mips(texture)


def constant_channels(asset: Asset, tolerance: float = 1e-4) -> frozenset[str]:
    """The material channels (``"kd"``, ``"ks"``) that hold one value over the whole of
    ``asset``: every material's texture of that channel varies by at most ``tolerance`` and all
    materials agree (and, for ``"kd"``, the mesh has no vertex colours); for an implicit
    surface, those whose field's own values (``ImplicitSurface.channels``) at every vertex of
    its mesh (within a marching-cubes cube of the surface) vary by at most ``tolerance``: its
    mesh's materials are only a rounded palette of them."""

    def constant(textures: list[torch.Tensor]) -> bool:
        texels = torch.cat([t.detach().reshape(-1, t.shape[-1]) for t in textures])
        return bool((texels.max(dim=0).values - texels.min(dim=0).values).max() <= tolerance)

    if asset.field is not None:
        values = asset.field.channels(asset.mesh.v_pos.detach().float())
        return frozenset(name for name, value in zip(("kd", "ks"), values) if constant([value]))
    channels = set()
    if asset.mesh.v_color is None and constant([m.kd.data for m in asset.materials]):
        channels.add("kd")
    if constant([m.ks.data for m in asset.materials]):
        channels.add("ks")
    return frozenset(channels)


EMISSION_SCALE_SHARE = 0.99
"""``emission_scale`` reads the emission below which this share of the texels lie."""


def emission_scale(emission: torch.Tensor) -> float:
    """The unit of a trained emission map ``[S, S, 3]``: the brightest channel of the texel at
    ``EMISSION_SCALE_SHARE`` of them in brightness, at least 1. Adam steps each texel by about
    ``lr`` of this unit; a few glints far brighter than the rest (a sun in a baked lighting) must
    not make the steps of every other texel as coarse."""
    brightness = emission.detach().float().amax(dim=-1).reshape(-1)
    rank = max(1, math.ceil(EMISSION_SCALE_SHARE * brightness.numel()))
    return max(float(brightness.kthvalue(rank).values), 1.0)


def _emission_and_occlusion(material: Material, size) -> dict:
    """``TexturedMesh`` keyword arguments ``emissive`` (``[S, S, 3]``, a constant spread over the
    texture size ``size``) and ``occlusion`` of ``material``, ``None`` where it has none."""
    emissive = None
    if material.emissive is not None:
        emissive = material.emissive.data.detach().float()
        if emissive.shape[:2] == (1, 1):
            emissive = emissive.expand(*size, 3)
    occlusion = None if material.occlusion is None else material.occlusion.data.detach()[..., :1]
    return {"emissive": emissive, "occlusion": occlusion}


def render_asset(asset: Asset, camera: Camera, light: PointLight, pose: Poses | None = None, *, resolution: int,
                 msaa: int, layers: int = 1, footprint: float = FOOTPRINT_SCALE,
                 shadows: ShadowMapping | None = None) -> torch.Tensor:
    """How fitted models and the baselines they are compared with are scored: every one of
    ``msaa`` x ``msaa`` samples per pixel shaded, as the reference is, over ``layers``
    depth-peeled layers, texture lookups of ``footprint``, shadowed as ``shadows`` says
    (``None``: no shadows), ``[B, H, W, 4]``,
    differentiable (deterministic; what training's stochastic MSAA matches in expectation).
    A skinned asset is drawn in the poses ``pose`` (batch B) where given
    (``lookalike.asset.skinning.posed``); else as it is stored."""
    size = (resolution, resolution)
    if pose is None or asset.skin is None:
        return render(asset, camera, light, size, spp=msaa, layers=layers, footprint=footprint, shadows=shadows)
    return torch.cat([render(posed(asset, clip, time), camera[views], light[views], size, spp=msaa, layers=layers,
                             footprint=footprint, shadows=shadows)
                      for views, clip, time in pose.runs()])


def _facing_outwards(normal: torch.Tensor, limits: ClampConfig) -> torch.Tensor:
    """``normal [S, S, 3]`` with z raised to at least ``1 / normal_max_slope`` and renormalised:
    slopes (x / z, y / z) need z > 0."""
    lifted = normal.clone()
    lifted[..., 2].clamp_(min=1.0 / limits.normal_max_slope)
    return torch.nn.functional.normalize(lifted, dim=-1)
