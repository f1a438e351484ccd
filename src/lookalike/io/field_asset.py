"""An implicit surface as the asset a run reads: its marching-cubes mesh, coloured at the
vertices, with the surface itself attached (``Asset.field``) for the reference to draw."""

from __future__ import annotations

from pathlib import Path

import torch

from ..asset import Asset, Material, Mesh, Texture
from ..asset.implicit import ImplicitSurface, field_mesh
from ..errors import AssetError

FIELD_CELLS = 160
"""Marching-cubes cubes along the bounds' longest side: the asset's mesh resolves detail down to
about 1/160 of the object (a start is decimated from a finer one: ``finer_field_mesh``)."""

PALETTE_LIMIT = 32
"""A mesh holds colour per vertex, not roughness: its triangles take roughness and metalness
from a palette of at most this many materials (``palette_materials``)..."""

PALETTE_STEPS = 64
"""... the field's own pairs where that many suffice, else pairs rounded to multiples of 1 / this,
and coarser, halving the steps, until they do."""


def palette_materials(surface: ImplicitSurface, mesh) -> tuple[list[Material], torch.Tensor]:
    """One material per (roughness, metalness) pair of ``mesh``'s triangles (the field's at
    each triangle's centroid: exactly, where at most ``PALETTE_LIMIT`` pairs occur, as on a field
    painted in a few materials; else rounded to ``PALETTE_STEPS``, coarser until at most
    ``PALETTE_LIMIT`` remain), white base colour (the vertex colours give it), and each
    triangle's material index ``[T]``. Why exact: a roughness of 0.3 rounded to 19/64 draws a
    metal's highlight a few per cent brighter, which perceptual error sees on every shiny face."""
    _, ks = surface.channels(mesh.v_pos[mesh.t_pos_idx].mean(dim=1))
    pairs, index = torch.unique(ks[:, 1:], dim=0, return_inverse=True)
    steps = PALETTE_STEPS
    while pairs.shape[0] > PALETTE_LIMIT and steps >= 1:
        levels, index = torch.unique(torch.round(ks[:, 1:] * steps).long(), dim=0, return_inverse=True)
        pairs, steps = levels.float() / steps, steps // 2
    materials = [Material(kd=Texture.constant([1.0, 1.0, 1.0, 1.0]), ks=Texture.constant([0.0, *pair.tolist()]))
                 for pair in pairs]
    return materials, index


def field_asset(surface: ImplicitSurface, path: Path, cells: int = FIELD_CELLS, block: int = 0) -> Asset:
    """``surface`` (read from ``path``) as an ``Asset``: ``field_mesh`` at ``cells`` (evaluated
    near the surface only, in blocks of ``block`` cubes, where given) with its
    base colour at the vertices, its roughness and metalness as a palette of materials
    (``palette_materials``), and ``field = surface``. ``AssetError`` where the field has no
    surface in its bounds."""
    try:
        mesh = field_mesh(surface, cells, block)
    except ValueError as e:
        raise AssetError(path, f"the field is {e}") from None
    materials, mesh.t_mat_idx = palette_materials(surface, mesh)
    return Asset(mesh=mesh, materials=materials, field=surface)


def finer_field_mesh(asset: Asset, cells: int, block: int) -> Mesh:
    """The field of ``asset`` (read by ``field_asset``) meshed again at ``cells`` cubes
    (``field_mesh``, evaluated near the surface in blocks of ``block``), each triangle given the
    material of the asset's palette closest to the field's (roughness, metalness) at its
    centroid: the asset's materials serve both meshes."""
    mesh = field_mesh(asset.field, cells, block)
    _, ks = asset.field.channels(mesh.v_pos[mesh.t_pos_idx].mean(dim=1))
    palette = torch.stack([m.ks.data.reshape(-1)[1:3] for m in asset.materials])
    mesh.t_mat_idx = torch.cdist(ks[:, 1:3], palette).argmin(dim=1)
    return mesh


def checked_distances(values, points: torch.Tensor, path: Path) -> torch.Tensor:
    """A field's ``values`` at ``points [N, 3]`` as ``[N]`` float32; ``AssetError`` naming
    ``path`` where there is not one per point or one is not finite (with where it is)."""
    values = torch.as_tensor(values).detach().float()
    if values.numel() != points.shape[0]:
        raise AssetError(path, f"sdf(p) returned shape {tuple(values.shape)} for {points.shape[0]} points; "
                         "it must return one distance per point, [N]")
    values = values.reshape(-1)
    bad = torch.nonzero(~torch.isfinite(values))
    if bad.numel():
        x, y, z = points[bad[0, 0]].tolist()
        raise AssetError(path, f"the field is {values[bad[0, 0]].item()} at ({x:.4g}, {y:.4g}, {z:.4g})")
    return values


def parse_bounds(values, path: Path) -> tuple[torch.Tensor, torch.Tensor]:
    """``((xmin, ymin, zmin), (xmax, ymax, zmax))`` as two ``[3]`` float32 tensors; ``AssetError``
    unless it is two triples with every minimum below its maximum."""
    try:
        lo, hi = (torch.tensor([float(x) for x in corner], dtype=torch.float32) for corner in values)
    except (TypeError, ValueError):
        lo = hi = None
    if lo is None or lo.shape != (3,) or hi.shape != (3,):
        raise AssetError(path, f"bounds must be ((xmin, ymin, zmin), (xmax, ymax, zmax)), not {values!r}")
    if not bool((lo < hi).all()) or not bool(torch.isfinite(lo).all() and torch.isfinite(hi).all()):
        raise AssetError(path, f"bounds must have each minimum below its maximum, not {values!r}")
    return lo, hi
