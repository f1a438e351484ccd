"""The classic projection bake: a low-poly mesh with a UV atlas gets textures copied from a
high-poly reference (what Simplygon, Substance, Marmoset or Blender's "selected to active" do).

For every atlas sample (``SAMPLES_PER_AXIS``^2 sub-texels per texel of UV set 0 of the low-poly
mesh; ``lookalike.asset.uv_raster``) the low-poly surface point ``p``, its interpolated unit shading
normal ``n`` (our tangent frame ``t, b, n``, ``lookalike.asset.frames``, on the low-poly mesh's
split normals: the frame the renderer decodes the map in) and its smooth normal ``c`` (the
positions' angle-weighted normals interpolated, whatever splits the shading normals:
``smooth_normals``) are found. Each of the two lines through ``p``, along ``c`` and along ``n``,
casts two rays: along ``+d`` and along ``-d``, each reaching ``cage`` (default
``DEFAULT_CAGE_FRACTION`` of the reference's bounding-box diagonal). Each starts
``START_OFFSET * cage`` behind ``p``, so a reference surface through ``p`` itself is found. Only
surfaces seen from outside count, as a viewer looking down ``-d`` would see them: a ray passes
through the back of a triangle (face normal ``. d <= 0``) whose material is one-sided, since
the renderer culls it (``first_seen``). On each line the hit closest to ``p`` (smallest
``|signed distance|``) wins, on a tie the outward one; of the two lines the closer hit wins, on
a tie ``c``'s. Rays along ``c`` fan continuously across a hard edge of the low-poly mesh, so the
texels beside it read the reference under them, as Blender's bake of a smooth-shaded mesh does;
along each side's own ``n`` alone they read the neighbouring face's normal there, a seam of
highlights along every hard edge. The line along ``n`` keeps a texel on its own part where
``c`` leans off into another (thin or overlapping parts). Texels whose rays all miss take the
closest point of the reference (``lookalike.init.closest_point``).

At that point the reference's material and shading normal ``s`` (``ReferenceSurface``; for an
implicit surface's marching-cubes mesh, the field's own, ``FieldSurface``) are read;
where the point's triangle faces away from the winning line's direction (a double-sided surface
seen from behind, or a closest point) ``s`` is flipped, as the renderer flips it. The baked normal map holds
``normalize(s.t, s.b, s.n)``, so that our renderer's
``normalize(x t + y b + z n)`` gives back ``s``; base colour + alpha, (gamma, roughness,
metalness), emission and ambient occlusion are copied. Each texel stands for a patch of the low-poly surface
``sqrt(A_world / (A_uv S^2))`` across (its triangle's world area over its texel area), which sets
the mip level the reference's textures are read at. A texel holds the mean of its samples (the
normal renormalised), over those of them that some triangle covers. Finally every texel no triangle covers
takes the value of its nearest covered texel (Euclidean distance in texels), so neither bilinear
filtering at chart borders nor any mip level pulls in background. (One exact distance transform
does this for the whole atlas; the neighbour-mean dilation of ``lookalike.asset.uv_raster.dilate``
costs one pass per texel of depth, seconds at 1024^2.)
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import torch
from scipy.ndimage import distance_transform_edt

from ..asset.asset import Asset
from ..asset.frames import our_corner_frame, texel_frames
from ..asset.material import Material, Texture
from ..asset.mesh import Mesh
from ..asset.normals import angle_weighted_normals, face_normals, safe_normalize
from ..asset.parts import welded_corners
from ..asset.uv_raster import rasterize_uv
from ..errors import ConfigError
from .atlas import merged_modes
from .closest_point import SurfaceQuery
from .field_surface import FieldSurface
from .raycast import RayCaster, RayHits
from .reference_surface import ReferenceSurface

DEFAULT_CAGE_FRACTION = 0.02
"""Default ray length on each side of the low-poly surface, as a fraction of the reference's
bounding-box diagonal."""

START_OFFSET = 1e-4
"""Rays start this fraction of the cage behind the texel's point (see the module docstring)."""

MAX_PASSES = 8
"""Hits on back faces of one-sided triangles a ray passes through before it gives up."""

PASS_THROUGH_STEP = 1e-5
"""How far past a hidden hit a ray continues, as a fraction of its reach."""

SAMPLES_PER_AXIS = 2
"""Bake samples per texel and axis: the atlas is baked at this many times the texture's side
and box-filtered down, so a texel holds the mean of the reference over its footprint (the
reference's detail finer than a texel averages out instead of aliasing into grain; normals
are renormalised after averaging)."""


@dataclass
class AtlasTexels:
    """The K texels of a ``size x size`` atlas that the low-poly triangles cover.

    Attributes:
        rows, cols: ``[K]`` int64 texel indices (each texel once).
        triangle: ``[K]`` int64 low-poly triangle covering it; barycentric ``[K, 3]`` float64.
        position: ``[K, 3]`` float64 surface point; tangent, bitangent, normal ``[K, 3]`` float64
            our orthonormal tangent frame there.
        smooth: ``[K, 3]`` float64 unit smooth normal there (``c`` of the module docstring).
        footprint: ``[K]`` float64 world-space size of the texel on the surface.
    """

    rows: np.ndarray
    cols: np.ndarray
    triangle: np.ndarray
    barycentric: np.ndarray
    position: np.ndarray
    tangent: np.ndarray
    bitangent: np.ndarray
    normal: np.ndarray
    smooth: np.ndarray
    footprint: np.ndarray


def atlas_texels(low: Mesh, size: int) -> AtlasTexels:
    """The covered texels of ``low``'s UV set 0 at ``size x size`` (where triangles share a texel
    the first in ``rasterize_uv``'s order keeps it)."""
    v_pos = low.v_pos.detach().double().numpy()
    t_pos_idx = low.t_pos_idx.numpy()
    v_tex, t_tex_idx = low.uv[0]
    corner_uv = v_tex.detach().double()[t_tex_idx].numpy()
    rows, cols, tri, bary = rasterize_uv(corner_uv, size, size)
    _, first = np.unique(rows * size + cols, return_index=True)
    rows, cols, tri, bary = rows[first], cols[first], tri[first], bary[first]
    corners = v_pos[t_pos_idx]
    world_area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=-1)
    e1, e2 = corner_uv[:, 1] - corner_uv[:, 0], corner_uv[:, 2] - corner_uv[:, 0]
    texel_area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) * size * size
    footprint = np.sqrt(world_area / np.maximum(texel_area, 1e-300))
    tangent, bitangent, normal = texel_frames(*our_corner_frame(low, 0), tri, bary)
    return AtlasTexels(rows=rows, cols=cols, triangle=tri, barycentric=bary,
                       position=np.einsum("kc,kcd->kd", bary, corners[tri]),
                       tangent=tangent, bitangent=bitangent, normal=normal,
                       smooth=smooth_normals(v_pos, t_pos_idx, tri, bary, normal), footprint=footprint[tri])


def smooth_normals(v_pos: np.ndarray, t_pos_idx: np.ndarray, tri: np.ndarray, bary: np.ndarray,
                   normal: np.ndarray) -> np.ndarray:
    """``[K, 3]`` unit smooth normals ``c`` of the mesh ``v_pos [V, 3]``, ``t_pos_idx [T, 3]`` at
    points ``tri [K]``, ``bary [K, 3]``: ``c = normalize(sum_k bary_k m_k)``, ``m`` the
    angle-weighted normals of the positions (``angle_weighted_normals``; coincident vertices
    merged, so neither a split of the shading normals nor a file's seam parts them); the points'
    shading normals ``normal [K, 3]`` where the sum vanishes or faces away from them."""
    welded, merged = welded_corners(v_pos, t_pos_idx)
    smooth = angle_weighted_normals(torch.from_numpy(welded), torch.from_numpy(merged)).numpy()
    interpolated = np.einsum("kc,kcd->kd", bary, smooth[merged[tri]])
    length = np.linalg.norm(interpolated, axis=-1, keepdims=True)
    usable = (length > 1e-6) & ((interpolated * normal).sum(-1, keepdims=True) > 0)
    return np.where(usable, interpolated / np.maximum(length, 1e-6), normal)


def default_cage(reference: Mesh) -> float:
    """``DEFAULT_CAGE_FRACTION`` of the bounding-box diagonal of ``reference``."""
    lo, hi = reference.bounds()
    return DEFAULT_CAGE_FRACTION * float((hi - lo).double().norm())


def first_seen(caster: RayCaster, origins: np.ndarray, directions: np.ndarray, t_max: float, view: np.ndarray,
               face_normal: np.ndarray, one_sided: np.ndarray) -> RayHits:
    """The nearest hit along each ray that a viewer looking down ``-view`` would see.

    A hit on the back of a one-sided triangle (``face_normal . view <= 0``) is invisible from
    there (the renderer culls it): the ray continues just past it, up to ``MAX_PASSES`` hits
    per ray (later ones count as misses).

    Args:
        caster: ray caster of the reference; origins, directions, view: ``[K, 3]`` float64.
        t_max: reach of the rays.
        face_normal: ``[T, 3]`` float64 unit face normals; one_sided: ``[T]`` bool.
    Returns:
        ``RayHits`` with ``t`` measured from ``origins``.
    """
    count = len(origins)
    out = RayHits(np.full(count, -1, np.int64), np.zeros((count, 3)), np.full(count, np.inf))
    travelled = np.zeros(count)
    active = np.arange(count)
    step = PASS_THROUGH_STEP * t_max
    for _ in range(MAX_PASSES):
        hits = caster.intersect(origins[active] + travelled[active, None] * directions[active], directions[active],
                                t_max - travelled[active])
        triangle = np.maximum(hits.triangle, 0)
        hidden = hits.hit & one_sided[triangle] & ((face_normal[triangle] * view[active]).sum(-1) <= 0)
        done = active[~hidden]
        out.triangle[done], out.barycentric[done] = hits.triangle[~hidden], hits.barycentric[~hidden]
        out.t[done] = travelled[done] + hits.t[~hidden]
        active = active[hidden]
        travelled[active] += hits.t[hidden] + step
        if len(active) == 0:
            break
    return out


def project_along_normals(caster: RayCaster, points: np.ndarray, normals: np.ndarray, cage: float,
                          face_normal: np.ndarray, one_sided: np.ndarray) -> tuple[RayHits, np.ndarray]:
    """The reference hit nearest to each point along its normal line, within ``cage``, that is
    seen from outside (``first_seen`` with ``view = normals``).

    Args:
        caster: ray caster of the reference.
        points, normals: ``[K, 3]`` float64 points and unit normals.
        cage: reach of the rays on each side.
        face_normal: ``[T, 3]`` float64 unit face normals of the reference; one_sided: ``[T]``
            bool, the triangle's material culls back faces.
    Returns:
        ``(hits, offset)``: ``RayHits`` of the winning rays (see the module docstring for the
        rule) and ``offset [K]`` float64 signed distance of the hit along ``+normal`` (inf
        where both rays miss).
    """
    start = START_OFFSET * cage
    outward = first_seen(caster, points - start * normals, normals, cage + start, normals, face_normal, one_sided)
    inward = first_seen(caster, points + start * normals, -normals, cage + start, normals, face_normal, one_sided)
    out_distance, in_distance = outward.t - start, inward.t - start
    take_in = np.abs(in_distance) < np.abs(out_distance)
    pick = take_in[:, None]
    hits = RayHits(np.where(take_in, inward.triangle, outward.triangle),
                   np.where(pick, inward.barycentric, outward.barycentric), np.where(take_in, inward.t, outward.t))
    return hits, np.where(take_in, -in_distance, out_distance)


@dataclass
class BakeResult:
    """A baked material and how the projection went.

    Attributes:
        material: kd ``[S, S, 4]``, ks ``[S, S, 3]``, normal ``[S, S, 3]`` (our tangent frame of
            the low-poly mesh's UV set 0), emissive where the reference emits, occlusion
            ``[S, S, 1]`` where it has an occlusion map.
        cage: ray reach used, in the asset's units.
        texels: number of atlas texels covered by the low-poly mesh.
        hit_fraction: fraction of those whose rays hit the reference (the rest took the
            closest point).
        mean_offset: mean absolute distance from the low-poly surface to the baked point.
        seconds: wall seconds the bake took.
    """

    material: Material
    cage: float
    texels: int
    hit_fraction: float
    mean_offset: float
    seconds: float


@dataclass
class BakePoints:
    """The reference point each of K texels bakes.

    Attributes:
        triangle: ``[K]`` int64 reference triangle; barycentric: ``[K, 3]`` float64 its weights.
        offset: ``[K]`` float64 signed distance along the texel's normal (for closest points,
            the unsigned distance).
        hit: ``[K]`` bool, a ray found the point (else it is the closest point).
        back: ``[K]`` bool, the point's triangle faces away from the texel's normal (seen from
            behind: its shading normal is flipped, as the renderer does for double-sided
            materials).
    """

    triangle: np.ndarray
    barycentric: np.ndarray
    offset: np.ndarray
    hit: np.ndarray
    back: np.ndarray


def locate_on_reference(reference: Asset, texels: AtlasTexels, cage: float) -> BakePoints:
    """The reference point each texel bakes: the nearest hit within ``cage`` that is seen from
    outside along its smooth normal's line or its shading normal's (``project_along_normals``;
    the smooth one on a tie), else the closest point."""
    mesh = reference.mesh
    v_pos = mesh.v_pos.detach().double().numpy()
    t_pos_idx = mesh.t_pos_idx.numpy()
    face_normal = safe_normalize(face_normals(mesh.v_pos.detach().double(), mesh.t_pos_idx)).numpy()
    double_sided = np.array([m.double_sided for m in reference.materials], bool)
    one_sided = ~double_sided[mesh.t_mat_idx.numpy()]
    caster = RayCaster(v_pos, t_pos_idx)
    smooth, offset = project_along_normals(caster, texels.position, texels.smooth, cage, face_normal, one_sided)
    own, own_offset = project_along_normals(caster, texels.position, texels.normal, cage, face_normal, one_sided)
    take_own = np.abs(own_offset) < np.abs(offset)
    triangle = np.where(take_own, own.triangle, smooth.triangle)
    bary = np.where(take_own[:, None], own.barycentric, smooth.barycentric)
    offset = np.where(take_own, own_offset, offset)
    direction = np.where(take_own[:, None], texels.normal, texels.smooth)
    hit = triangle >= 0
    if not hit.all():
        closest = SurfaceQuery(v_pos, t_pos_idx).closest(texels.position[~hit])
        triangle[~hit], bary[~hit], offset[~hit] = closest.triangle, closest.barycentric, closest.distance
    back = (face_normal[triangle] * direction).sum(-1) < 0
    return BakePoints(triangle, bary, offset, hit, back)


def to_tangent_space(normals: np.ndarray, texels: AtlasTexels) -> np.ndarray:
    """``[K, 3]`` unit normal-map values ``normalize(s.t, s.b, s.n)`` of world normals
    ``normals [K, 3]`` in the texels' frames (``(0, 0, 1)`` where ``s`` is zero)."""
    return to_unit_normal(np.stack([(normals * texels.tangent).sum(-1), (normals * texels.bitangent).sum(-1),
                                    (normals * texels.normal).sum(-1)], axis=-1))


def to_unit_normal(values: np.ndarray) -> np.ndarray:
    """``values [K, 3]`` normalised, ``(0, 0, 1)`` where a row is (nearly) zero."""
    length = np.linalg.norm(values, axis=-1, keepdims=True)
    return np.where(length > 1e-12, values / np.maximum(length, 1e-12), [0.0, 0.0, 1.0])


def nearest_covered(rows: np.ndarray, cols: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """For every texel of a ``size x size`` image, the (row, col) ``[size, size]`` int64 of the
    nearest of the covered texels ``(rows [K], cols [K])``, ``K >= 1`` (itself where covered)."""
    uncovered = np.ones((size, size), bool)
    uncovered[rows, cols] = False
    nearest = distance_transform_edt(uncovered, return_distances=False, return_indices=True)
    return nearest[0], nearest[1]


def texels_to_image(rows: np.ndarray, cols: np.ndarray, nearest: tuple[np.ndarray, np.ndarray],
                    values: np.ndarray) -> torch.Tensor:
    """``[S, S, C]`` float32 texture holding ``values [K, C]`` at the covered texels
    ``(rows [K], cols [K])`` and each uncovered texel the value of its ``nearest`` covered one."""
    size = nearest[0].shape[0]
    image = np.zeros((size, size, values.shape[1]), np.float32)
    image[rows, cols] = values
    return torch.from_numpy(np.ascontiguousarray(image[nearest]))


def box_filter(rows: np.ndarray, cols: np.ndarray, factor: int,
               values: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """Average samples taken at ``factor x factor`` sub-texels down to texels.

    Args:
        rows, cols: ``[K]`` int64 sub-texel indices (each once) of a ``S*factor`` image.
        values: arrays ``[K, C_i]`` of the samples' values.
    Returns:
        ``(rows [M], cols [M], means)``: the texels of the ``S`` image that hold at least one
        sample, and per array ``[M, C_i]`` the mean of the samples inside each.
    """
    keys, inverse = np.unique((rows // factor) * (1 << 32) + cols // factor, return_inverse=True)
    counts = np.bincount(inverse, minlength=len(keys)).astype(np.float64)[:, None]
    means = []
    for array in values:
        total = np.zeros((len(keys), array.shape[1]), np.float64)
        np.add.at(total, inverse, array)
        means.append(total / counts)
    return keys >> 32, keys & ((1 << 32) - 1), means


def bake(reference: Asset, low: Mesh, texture_size: int = 1024, cage: float | None = None,
         samples: int = SAMPLES_PER_AXIS) -> BakeResult:
    """Bake ``reference`` onto ``low`` (see the module docstring).

    Args:
        reference: the high-poly asset (its mesh as stored; a skinned mesh in its bind pose).
        low: the low-poly mesh, with its atlas in UV set 0 (``lookalike.init.unwrap``).
        texture_size: side S of the square baked textures.
        cage: ray reach on each side of the low-poly surface, in the asset's units (default
            ``default_cage(reference.mesh)``).
        samples: samples per texel and axis (``SAMPLES_PER_AXIS``).
    Returns:
        ``BakeResult``; ``Asset(low, [result.material])`` renders like the reference.
    Raises:
        ConfigError: ``low`` has no UVs, or ``cage``/``texture_size`` are not positive.
    """
    if not low.uv:
        raise ConfigError("the low-poly mesh to bake onto needs a UV atlas in UV set 0 (see lookalike.init.unwrap)")
    if isinstance(texture_size, bool) or not isinstance(texture_size, (int, np.integer)) or texture_size < 1:
        raise ConfigError(f"texture size must be a positive whole number, got {texture_size!r}")
    cage = default_cage(reference.mesh) if cage is None else float(cage)
    if not cage > 0:
        raise ConfigError(f"the bake cage distance must be positive, got {cage!r}")
    started = time.monotonic()
    texels = atlas_texels(low, texture_size * samples)
    if len(texels.rows) == 0:
        raise ConfigError(f"the low-poly mesh's UV atlas covers no texel of a {texture_size}^2 texture")
    points = locate_on_reference(reference, texels, cage)
    surface = FieldSurface(reference) if reference.field is not None else ReferenceSurface(reference)
    values = surface.sample(torch.from_numpy(points.triangle), torch.from_numpy(points.barycentric),
                                                torch.from_numpy(texels.footprint))
    seen = values.normal.double().numpy() * np.where(points.back, -1.0, 1.0)[:, None]
    channels = {"kd": values.kd.numpy(), "ks": values.ks.numpy(), "normal": to_tangent_space(seen, texels)}
    channels.update({name: getattr(values, name).numpy() for name in ("emissive", "occlusion")
                     if getattr(values, name) is not None})
    rows, cols, means = box_filter(texels.rows, texels.cols, samples, list(channels.values()))
    filtered = dict(zip(channels, means))
    filtered["normal"] = to_unit_normal(filtered["normal"])
    nearest = nearest_covered(rows, cols, texture_size)
    textures = {name: Texture(texels_to_image(rows, cols, nearest, value)) for name, value in filtered.items()}
    material = Material(name="baked", kd=textures["kd"], ks=textures["ks"], normal=textures["normal"],
                        emissive=textures.get("emissive"), occlusion=textures.get("occlusion"),
                        **merged_modes(reference.materials))
    return BakeResult(material=material, cage=cage, texels=len(rows), hit_fraction=float(points.hit.mean()),
                      mean_offset=float(np.abs(points.offset).mean()), seconds=time.monotonic() - started)
