"""The initial guess (paper Sec. 4) and the baselines it is compared with.

An initial guess is an ``Asset``: a low-poly mesh with its UV atlas in UV set 0 and one
material with base colour (+ alpha), specular and normal textures. It starts from a low-poly
mesh, ours (quadric decimation, ``lookalike.init.decimate``) or the user's own
(``--init-mesh``), and its textures come from:

- ``"bake"`` (the default): a fresh atlas and the classic projection bake of the input
  (``lookalike.init.projection_bake``); the bake is also a baseline of its own;
- ``"source"``: the low-poly mesh's UVs with the input's own textures, resampled (where the
  input has one material and the low-poly mesh carries its UVs; else as ``"average"``);
- ``"average"``: a fresh atlas holding the input's mean material; ``"random"``: a fresh atlas
  with uniform noise, as in the paper. Fresh normal maps start flat.

Where the input emits, the start carries an emission map (baked, resampled, the mean, or noise
up to the input's brightest emission); where it has an ambient occlusion map, an occlusion map
(baked, resampled, or the mean), which the fit keeps as it is.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
import torch

from ..asset import Asset, Material, Mesh, Texture
from ..asset.normals import crease_normal_index, face_normals
from ..asset.uv_raster import rasterize_uv
from ..errors import ConfigError
from ..io.glb_bytes import from_glb_bytes, to_glb_bytes
from ..io.normal_frames import on_crease_normals
from ..phases import phase
from .projection_bake import BakeResult, bake
from .conform import CONFORM_ROUNDS, SETTLE_ROUNDS, UNFOLD_PASSES, conform_to_surface, reattach_detached_parts
from .decimate import GUARD, check_triangle_target, feature_size, repair_shards
from .surface_distance import SurfaceGauge
from .transfer import corner_materials
from .triangle_kernels import triangle_areas
from .trunk_and_cards import triangle_subset
from .unwrap import unwrap

UV_OVERLAP_LIMIT = 0.05
"""A user's low-poly mesh keeps its UVs only if at most this share of the texels its triangles
cover are covered more than once (an atlas; mirrored or scrambled UVs are not)."""

UV_CHECK_SIZE = 512
"""Side of the grid on which that share is measured."""
UV_CHECK_TEXELS = 1 << 20
"""Most texels ``uv_overlap`` rasterizes: where the triangles' UV areas add up to more, the grid
is coarser, because scrambled UVs cover the square hundreds of times over and rasterizing them
at full size takes far longer than the check is worth (their overlap is plain at any grid)."""


@dataclass
class Ranges:
    """The valid ranges of the textures: base colour (and alpha), and the three specular
    channels (gamma, roughness, metalness)."""

    kd: tuple[float, float] = (0.0, 1.0)
    ks: tuple[tuple[float, float], tuple[float, float], tuple[float, float]] = ((0.0, 1.0), (0.0, 1.0), (0.0, 1.0))


@dataclass
class InitialGuess:
    """Where the optimisation starts, and what it is compared with.

    Attributes:
        start: the initial guess (one material, atlas in UV set 0; or a start that keeps the
            input's materials, ``lookalike.init.leaf_texture_cards``).
        baseline: the low-poly model as users know it: plain decimation with the input's
            materials (``decimation_baseline``), or the user's mesh as given.
        bake: the classic bake onto ``start``'s mesh (material and how the projection went)
            where the start is a bake, else ``None``.
        notes: remarks for the report (e.g. why the user's UVs were replaced).
        comparisons: further models scored beside the baselines, as ``(key, label, asset)``
            (e.g. the classic bake at each triangle count a displaced model is drawn at).
        alternatives: other starts, as ``(label, asset)``, which the run takes instead of
            ``start`` where one scores higher on its validation views (``take_start``).
        start_distance: how far the start's mesh strays from the input, where it was measured
            (``metrics.json``'s ``start_distance``): the sampled two-sided surface distance
            (``lookalike.init.surface_distance``) of our decimation
            (``DecimationReport.as_dict``), of a low-poly mesh fitted onto the surface
            (``fitted_distance``) or of a kept trunk beside cards; ``"of"`` says which. ``None``
            where the start holds no such mesh (a sphere, cards alone).
        alternative_distances: ``start_distance`` of each alternative, by its label.
        start_label: the report's label of the start where an alternative was taken
            (``take_start``), else ``None`` (the application's own).
        own_label: how notes name ``start`` beside its alternatives where neither "the classic
            bake" nor the application's usual start says what it is (a user's mesh fitted onto
            the surface), else ``None``.
    """

    start: Asset
    baseline: Asset
    bake: BakeResult | None
    notes: list[str]
    comparisons: list[tuple[str, str, Asset]] = field(default_factory=list)
    alternatives: list[tuple[str, Asset]] = field(default_factory=list)
    start_distance: dict | None = None
    alternative_distances: dict[str, dict] = field(default_factory=dict)
    start_label: str | None = None
    own_label: str | None = None

    def take_start(self, label: str, start: Asset, usual: str | None = None) -> None:
        """Start from ``start`` (``label``: what it is, also its label in the report) instead,
        with no alternatives left; a classic bake the start was stays scored, as the comparison
        ``"baked"``, and so does a start of another kind, called ``usual``, as
        ``"usual_start"``; the start's distance becomes the alternative's."""
        replaced = self.own_start(usual)
        if self.bake is not None:
            self.comparisons.append(("baked", "Classic bake", self.baked))
        elif usual is not None:
            self.comparisons.append(("usual_start", usual, self.start))
        self.start, self.bake, self.alternatives = start, None, []
        self.start_label = label[:1].upper() + label[1:]
        self.start_distance = self.alternative_distances.get(label)
        self.notes.append(f"started from {label}: it scored higher on the validation views than {replaced}")

    def own_start(self, usual: str | None = None) -> str:
        """How a note names the application's own start, called ``usual``: ``own_label`` where
        set, else the classic bake where it is one."""
        if self.own_label is not None:
            return self.own_label
        return "the classic bake" if self.bake is not None else usual_start(usual)

    def __getstate__(self) -> dict:
        """Pickled (in checkpoints) with the comparisons as ``.glb`` bytes, as a user receives
        them: as float arrays their maps would make most of a checkpoint's size."""
        return {**self.__dict__, "comparisons": [(key, label, to_glb_bytes(model))
                                                 for key, label, model in self.comparisons]}

    def __setstate__(self, state: dict) -> None:
        comparisons = [(key, label, from_glb_bytes(data)) for key, label, data in state.get("comparisons", [])]
        self.__dict__.update({"start_distance": None, "alternative_distances": {}, "start_label": None,
                              "own_label": None, **state,
                              "comparisons": comparisons})

    @property
    def baked(self) -> Asset | None:
        """The classic bake as an asset of its own (``start``'s mesh and skin, the baked
        material), or ``None``."""
        if self.bake is None:
            return None
        return Asset(mesh=self.start.mesh, materials=[self.bake.material], skin=self.start.skin,
                     animations=self.start.animations, source=self.start.source)


def usual_start(label: str | None) -> str:
    """How a note names the application's own start called ``label`` (``None``: unnamed)."""
    return f"the {label[:1].lower()}{label[1:]}" if label else "the usual start"


def target_triangle_count(triangles: int | None, ratio: float, input_triangles: int) -> int:
    """The triangle count to decimate to: ``triangles``, else ``ratio`` times
    ``input_triangles``, rounded. Raises ``ConfigError`` when it is not positive or not below
    the input's count."""
    if triangles is not None:
        return check_triangle_target(triangles, input_triangles)
    count = int(round(ratio * input_triangles))
    if count <= 0:
        raise ConfigError(f"a ratio of {ratio} leaves no triangles of the input's {input_triangles}")
    return check_triangle_target(count, input_triangles)


def surface_mean_material(asset: Asset) -> tuple[torch.Tensor, torch.Tensor]:
    """Mean base colour + alpha ``[4]`` and specular ``[3]`` over the surface: each material's
    mean texel, weighted by the area of the triangles that use it."""
    mesh = asset.mesh
    area = face_normals(mesh.v_pos.double(), mesh.t_pos_idx).norm(dim=-1)
    weight = torch.zeros(len(asset.materials), dtype=torch.float64).index_add_(0, mesh.t_mat_idx, area)
    weight = weight / weight.sum().clamp(min=1e-30)
    kd = sum(w * m.kd.data.double().reshape(-1, 4).mean(dim=0) for w, m in zip(weight, asset.materials))
    ks = sum(w * m.ks.data.double().reshape(-1, 3).mean(dim=0) for w, m in zip(weight, asset.materials))
    return kd.float(), ks.float()


def surface_mean_channel(asset: Asset, name: str, channels: int, default) -> torch.Tensor | None:
    """Area-weighted mean ``[channels]`` of material channel ``name`` (``"emissive"`` or
    ``"occlusion"``) over the surface, ``default`` for materials without it; ``None`` when no
    material has it."""
    if all(getattr(m, name) is None for m in asset.materials):
        return None
    mesh = asset.mesh
    area = face_normals(mesh.v_pos.double(), mesh.t_pos_idx).norm(dim=-1)
    weight = torch.zeros(len(asset.materials), dtype=torch.float64).index_add_(0, mesh.t_mat_idx, area)
    weight = weight / weight.sum().clamp(min=1e-30)
    means = [torch.tensor(default, dtype=torch.float64) if getattr(m, name) is None
             else getattr(m, name).data.detach().double().reshape(-1, channels).mean(dim=0) for m in asset.materials]
    return sum(w * value for w, value in zip(weight, means)).float()


def initial_extras(asset: Asset, size: int, init: str,
                   rng: np.random.Generator) -> tuple[torch.Tensor | None, torch.Tensor | None]:
    """``(emissive [S, S, 3], occlusion [1, 1, 1])`` starting maps of a fresh atlas, each
    ``None`` where no material of the input has it: ``"average"`` the surface means,
    ``"random"`` uniform emission noise up to the input's brightest texel of each channel (and
    the mean occlusion, which the fit cannot see)."""
    emissive = surface_mean_channel(asset, "emissive", 3, (0.0, 0.0, 0.0))
    occlusion = surface_mean_channel(asset, "occlusion", 1, (1.0,))
    if emissive is not None:
        if init == "random":
            peak = torch.stack([m.emissive.data.detach().reshape(-1, 3).max(dim=0).values
                                for m in asset.materials if m.emissive is not None]).max(dim=0).values
            emissive = torch.from_numpy(rng.uniform(0.0, peak.double().numpy(), size=(size, size, 3))).float()
        else:
            emissive = emissive.expand(size, size, 3).clone()
    return emissive, None if occlusion is None else occlusion.reshape(1, 1, 1)


def uses_alpha(asset: Asset) -> bool:
    """Whether any material of ``asset`` is not opaque (then the latent trains alpha)."""
    return any(m.uses_alpha for m in asset.materials)


def initial_textures(asset: Asset, size: int, init: str, ranges: Ranges,
                     rng: np.random.Generator) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """``(kd [S, S, 4], ks [S, S, 3], normal [S, S, 3])`` float32 starting textures.

    ``"average"``: every texel holds ``surface_mean_material(asset)``; ``"random"``: uniform
    noise within ``ranges`` (alpha starts at the mean alpha either way). The normal map is
    flat, (0, 0, 1).
    """
    kd_mean, ks_mean = surface_mean_material(asset)
    if init == "average":
        kd = kd_mean.expand(size, size, 4).clone()
        ks = ks_mean.expand(size, size, 3).clone()
    elif init == "random":
        channels = 4 if uses_alpha(asset) else 3
        lo = [ranges.kd[0]] * 3 + [float(kd_mean[3])]
        hi = [ranges.kd[1]] * 3 + [float(kd_mean[3])]
        kd = torch.from_numpy(rng.uniform(lo[:channels], hi[:channels], size=(size, size, channels)))
        if channels == 3:
            kd = torch.cat([kd, kd_mean[3].double().expand(size, size, 1)], dim=-1)
        ks = torch.from_numpy(rng.uniform([r[0] for r in ranges.ks], [r[1] for r in ranges.ks], size=(size, size, 3)))
    else:
        raise ConfigError(f"unknown texture initialisation {init!r}")
    normal = torch.tensor([0.0, 0.0, 1.0]).expand(size, size, 3).clone()
    return kd.float(), ks.float(), normal


def reusable_source_material(asset: Asset, low_poly: Mesh) -> Material | None:
    """The input's material if the latent can start from its own textures and UVs: exactly one
    material, all its textures in UV set 0 without a texture transform, and UVs carried over
    to ``low_poly``; else ``None``."""
    if len(asset.materials) != 1 or not low_poly.uv:
        return None
    material = asset.materials[0]
    if any(t.uv_set != 0 or t.transform is not None for t in material.textures):
        return None
    return material


def resample(texture: torch.Tensor, size: int) -> torch.Tensor:
    """``texture [H, W, C]`` resampled to ``[size, size, C]`` (bilinear, antialiased when shrinking)."""
    image = texture.detach().float().permute(2, 0, 1)[None]
    resized = torch.nn.functional.interpolate(image, size=(size, size), mode="bilinear", align_corners=False,
                                              antialias=True)
    return resized[0].permute(1, 2, 0).contiguous()


def uv_overlap(mesh: Mesh, size: int = UV_CHECK_SIZE) -> float:
    """The share of the texels covered by ``mesh``'s triangles in UV set 0 (``size`` x ``size``
    grid, UVs wrapped) that more than one triangle covers; 1 where the triangles cover none.
    The grid is coarser where the triangles' UV areas ``A`` (in unit squares) add up to more
    than ``UV_CHECK_TEXELS`` texels: side ``sqrt(UV_CHECK_TEXELS / A)``."""
    v_tex, t_tex_idx = mesh.uv[0]
    corners = v_tex[t_tex_idx].double().numpy()
    e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    area = 0.5 * float(np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum())
    if area * size * size > UV_CHECK_TEXELS:
        size = max(1, int(np.sqrt(UV_CHECK_TEXELS / area)))
    rows, cols, _, _ = rasterize_uv(corners, size, size)
    if len(rows) == 0:
        return 1.0
    distinct = len(np.unique(rows * size + cols))
    return 1.0 - distinct / len(rows)


def _material(kd: torch.Tensor, ks: torch.Tensor, normal: torch.Tensor, like: Asset, wrap: str = "clamp",
              emissive: torch.Tensor | None = None, occlusion: torch.Tensor | None = None) -> Material:
    """One material with these textures (emission and occlusion where given), alpha mode and
    sidedness following the input ``like``: ``"BLEND"`` if any of its materials blends, else
    ``"MASK"`` if any uses alpha, else opaque."""
    if not uses_alpha(like):
        mode = "OPAQUE"
    else:
        mode = "BLEND" if any(m.alpha_mode == "BLEND" for m in like.materials) else "MASK"
    return Material(name="lookalike", kd=Texture(kd, wrap=wrap), ks=Texture(ks, wrap=wrap),
                    normal=Texture(normal, wrap=wrap), alpha_mode=mode,
                    double_sided=any(m.double_sided for m in like.materials),
                    emissive=None if emissive is None else Texture(emissive, wrap=wrap),
                    occlusion=None if occlusion is None else Texture(occlusion, wrap=wrap))


def start_mesh(low_poly: Mesh) -> Mesh:
    """The start's mesh: positions, triangles and UV set 0 of ``low_poly``, and its normal slots
    (split at creases, ``crease_normal_index``, where it has none) without authored values, since
    the fit moves the positions and the normals follow them."""
    t_nrm_idx = low_poly.t_nrm_idx
    if t_nrm_idx is None:
        t_nrm_idx = crease_normal_index(low_poly.v_pos, low_poly.t_pos_idx)
    return Mesh(v_pos=low_poly.v_pos, t_pos_idx=low_poly.t_pos_idx, uv=[low_poly.uv[0]], t_nrm_idx=t_nrm_idx)


def initial_guess(asset: Asset, low_poly: Mesh, init: str, size: int, ranges: Ranges,
                  rng: np.random.Generator, keep_uvs: bool = False, cage: float | None = None) -> InitialGuess:
    """The initial guess on ``low_poly`` for the input ``asset`` (see the module docstring).

    Args:
        asset: the input.
        low_poly: the low-poly mesh (our decimation, with the input's UVs carried over where
            it has them, or the user's own mesh).
        init: ``"bake"``, ``"source"``, ``"average"`` or ``"random"``.
        size: side of the square textures.
        ranges: the valid ranges of random textures.
        rng: draws random textures.
        keep_uvs: bake onto ``low_poly``'s own UVs (a user's atlas) instead of a fresh atlas.
        cage: the bake's ray reach (default: ``lookalike.init.projection_bake``'s).
    """
    source = reusable_source_material(asset, low_poly) if init == "source" else None
    baked = None
    if source is not None:
        mesh = start_mesh(low_poly)
        normal = (torch.nn.functional.normalize(resample(source.normal.data, size), dim=-1)
                  if source.normal is not None else torch.tensor([0.0, 0.0, 1.0]).expand(size, size, 3))
        material = _material(resample(source.kd.data, size), resample(source.ks.data, size), normal, asset,
                             wrap=source.kd.wrap,
                             emissive=None if source.emissive is None else resample(source.emissive.data, size),
                             occlusion=None if source.occlusion is None else resample(source.occlusion.data, size))
        start = Asset(mesh=mesh, materials=[material], source=asset.source)
    elif init == "bake":
        with phase("unwrap"):
            atlas = low_poly if keep_uvs else unwrap(low_poly, texture_size=size)
        start, baked = baked_onto(asset, atlas, size, cage)
    else:
        mesh = low_poly if keep_uvs else unwrap(low_poly, texture_size=size)
        mesh = start_mesh(mesh)
        kd, ks, normal = initial_textures(asset, size, "average" if init == "source" else init, ranges, rng)
        emissive, occlusion = initial_extras(asset, size, "average" if init == "source" else init, rng)
        start = Asset(mesh=mesh, materials=[_material(kd, ks, normal, asset, emissive=emissive, occlusion=occlusion)],
                      source=asset.source)
    return InitialGuess(start=start, baseline=decimation_baseline(asset, low_poly), bake=baked, notes=[])


def smooth_shaded(asset: Asset, start: Asset, size: int) -> Asset:
    """``start``'s mesh and atlas shaded smooth (one normal slot per position, as Blender's
    decimate + bake writes a model), with the classic bake of ``asset`` onto it: at a hard edge
    the normal map, not the slots, turns the normal, so the turn lies where the surface's own
    edge does, not on the low-poly edge (which decimation places a little beside it)."""
    return baked_onto(asset, dataclasses.replace(start.mesh, t_nrm_idx=start.mesh.t_pos_idx.clone()), size)[0]


def baked_onto(asset: Asset, atlas: Mesh, size: int, cage: float | None = None) -> tuple[Asset, BakeResult]:
    """The classic bake of ``asset`` onto ``atlas`` as it is (its positions, triangles, UV set 0
    and normal slots, ``start_mesh``) with ``size``-texel maps, made for the mesh's own shading
    frames, and the bake's result."""
    mesh = start_mesh(atlas)
    with phase("bake"):
        baked = bake(asset, mesh, texture_size=size, cage=cage)
    made = baked.material
    material = _material(made.kd.data, made.ks.data, made.normal.data, asset,
                         emissive=None if made.emissive is None else made.emissive.data,
                         occlusion=None if made.occlusion is None else made.occlusion.data)
    return Asset(mesh=mesh, materials=[material], source=asset.source), baked


def initial_guess_from_mesh(asset: Asset, lod: Asset, lod_name: str, size: int,
                            on_surface: bool = False) -> InitialGuess:
    """The initial guess on a user's low-poly mesh ``lod`` (``--init-mesh``), first put back on
    the input's surface (``lookalike.init.conform``: parts cut off and moved are welded back,
    then the mesh is fitted to the surface, so that a shrunk, inflated or broken LOD starts
    where the fit's small steps can refine it): its own UVs and textures where it has one
    textured material and its UV set 0 is an atlas (``uv_overlap`` at most
    ``UV_OVERLAP_LIMIT``), resampled to ``size``; else the classic bake of ``asset``, onto its
    UVs where they are an atlas, else onto a fresh one. The baseline is ``lod`` as given.

    Shading normals: a kept normal map was made on ``lod``'s own normals (Blender bakes on its
    smooth ones), and read on other frames it tilts every texel, so it is first re-expressed onto
    ``lod``'s slots split at its creases (``io.normal_frames.on_crease_normals``), which the start
    keeps; a bake's normals are split at the creases of the fitted shape, as our decimation's
    are (``start_mesh``). The fit onto the surface also pulls a good LOD into the small holes it
    left out, moving its texels against the geometry they were painted for, and a bake onto it
    sees those holes too, so ``lod`` on its own positions, with its maps or baked the same way,
    is offered as an alternative start (``alternatives``: the run takes whichever scores higher
    on its validation views).

    ``on_surface``: ``lod`` is a model fitted to this input, decimated, so ``SETTLE_ROUNDS``
    rounds without unfolding put it back (a chain's level starting from the level above, where
    the full fit would take most of a small level's budget); no alternative is offered. Either
    way the fitted mesh then passes the decimation's guard against shards (``guarded_fit``), and
    its distance from the input is the guess's ``start_distance``."""
    rounds, unfold = (SETTLE_ROUNDS, 0) if on_surface else (CONFORM_ROUNDS, UNFOLD_PASSES)
    overlap = uv_overlap(lod.mesh) if lod.mesh.uv else None
    atlas = overlap is not None and overlap <= UV_OVERLAP_LIMIT
    kept = atlas and reusable_source_material(lod, lod.mesh) is not None and lod.materials[0].kd.data.shape[0] > 1
    source = on_crease_normals(lod) if kept else None
    own_mesh = lod.mesh if source is None else source.mesh
    with phase("fit onto the surface"):
        mesh, welded = reattach_detached_parts(own_mesh)
        mesh = conform_to_surface(mesh, asset.mesh, rounds=rounds, unfold_passes=unfold)
        if not kept:
            mesh = dataclasses.replace(mesh, t_nrm_idx=None)
        mesh, distance = guarded_fit(mesh, asset.mesh, f"{lod_name}, fitted onto the input's surface")
    fitted = (f"{lod_name} fitted onto the input's surface"
              + (f" after welding {welded} detached part{'s' if welded > 1 else ''} back" if welded else ""))
    notes = [f"started from the low-poly mesh {lod_name} instead of our decimation"
             + (f": {fitted}" if on_surface else "")]
    if overlap is not None and not atlas:
        notes.append(f"{lod_name}: {overlap:.0%} of its UV texels are covered more than once, "
                     "so a fresh atlas was unwrapped and baked")
    if kept:
        notes.append(f"kept {lod_name}'s UVs and textures")
    start, baked = _start_on(mesh, asset, source, size, atlas)
    guess = InitialGuess(start=start, baseline=lod, bake=baked, notes=notes, start_distance=distance, own_label=fitted)
    if not on_surface:
        as_given = own_mesh if kept else dataclasses.replace(own_mesh, v_nrm=None, t_nrm_idx=None)
        given, given_distance = guarded_fit(as_given, asset.mesh, f"{lod_name} as given")
        label = f"{lod_name} on its own positions"
        guess.alternatives.append((label, _start_on(given, asset, source, size, atlas)[0]))
        guess.alternative_distances[label] = given_distance
    return guess


def _start_on(mesh: Mesh, asset: Asset, kept: Asset | None, size: int, atlas: bool) -> tuple[Asset, BakeResult | None]:
    """A user's mesh's start on ``mesh`` (its positions, fitted or not) and its bake: the maps
    of ``kept`` (the user's model) resampled to ``size`` on its UVs, else the classic bake of
    ``asset`` onto its UVs where they are an ``atlas``, else onto a fresh one."""
    if kept is not None:
        return initial_guess(dataclasses.replace(kept, mesh=mesh), mesh, "source", size, Ranges(),
                             np.random.default_rng(0)).start, None
    made = initial_guess(asset, mesh, "bake", size, Ranges(), np.random.default_rng(0), keep_uvs=atlas)
    return made.start, made.bake


def guarded_fit(mesh: Mesh, surface: Mesh, of: str) -> tuple[Mesh, dict]:
    """``mesh``, fitted onto ``surface``, through the decimation's guard
    (``lookalike.init.decimate.repair_shards``): the corners of triangles farther from the
    surface than ``GUARD`` feature sizes of its count moved to their closest points on it, and
    triangles still beyond that removed (with the rows only they used). Returns the mesh and its
    distance from the surface as ``InitialGuess.start_distance`` holds it (``of``: what it is;
    the guard's bound in bounding radii, the corners moved and the triangles removed)."""
    surface_pos, surface_idx = surface.v_pos.detach().double().numpy(), surface.t_pos_idx.numpy()
    gauge = SurfaceGauge(surface_pos, surface_idx)
    bound = GUARD * feature_size(float(triangle_areas(surface_pos, surface_idx).sum()), mesh.num_triangles)
    v_pos, keep, snapped = repair_shards(gauge, mesh.v_pos.detach().double().numpy(), mesh.t_pos_idx.numpy(), bound)
    if snapped:
        mesh = mesh.with_positions(torch.from_numpy(v_pos).to(mesh.v_pos.dtype))
    if not keep.all():
        mesh = triangle_subset(Asset(mesh=mesh), keep).mesh
    distance = gauge.measure(mesh.v_pos.detach().double().numpy(), mesh.t_pos_idx.numpy())
    guard = {"bound": bound / max(gauge.radius, 1e-300), "snapped": snapped, "removed": int((~keep).sum())}
    return mesh, {"of": of, "triangles": mesh.num_triangles, **distance.as_dict(), "guard": guard}


def decimation_baseline(asset: Asset, decimated: Mesh) -> Asset:
    """Plain decimation as users know it: the ``decimated`` mesh with the input's own materials
    (through its carried-over UVs where the input has them) and no normal maps. Where the input's
    colours are at its vertices and it has several materials (a field's palette), each triangle
    takes the material of its corners (``lookalike.init.transfer.corner_materials``), whose
    colours it draws."""
    materials = [dataclasses.replace(m, normal=None) for m in asset.materials]
    if asset.mesh.v_color is not None and len(asset.materials) > 1:
        decimated = dataclasses.replace(decimated, t_mat_idx=corner_materials(asset.mesh, decimated))
    return Asset(mesh=decimated, materials=materials, source=asset.source)
