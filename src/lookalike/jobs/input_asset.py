"""The input as a run sees it: a given material applied, and what to say about it."""

from __future__ import annotations

import dataclasses

import torch

from ..asset import Asset, Material
from ..asset.displacement import tessellated


def prepare_input(asset: Asset, material_override: Material | None, moving: bool = False) -> tuple[Asset, list[str]]:
    """``asset`` tessellated where it is displaced (``lookalike.asset.displacement``), with
    ``material_override`` applied (a copy; the input is not modified), and
    remarks about it for the report; ``moving``: it is fitted over its animations
    (``jobs.animated.is_animated``)."""
    notes = []
    if asset.materials and asset.materials[0].displacement is not None:
        level = asset.materials[0].displacement.level
        asset = tessellated(asset)
        notes.append(f"the input's displacement map was applied to its mesh subdivided {level} times")
    if material_override is not None:
        mesh = dataclasses.replace(asset.mesh, t_mat_idx=torch.zeros_like(asset.mesh.t_mat_idx))
        asset = dataclasses.replace(asset, mesh=mesh, materials=[material_override])
        notes.append("every triangle of the input rendered with one given material")
    if not asset.mesh.uv:
        notes.append("the input has no UVs: plain decimation shows its constant materials")
    if moving:
        clips = ", ".join(a.name for a in asset.animations)
        notes.append(f"the input is skinned: it was simplified over its {len(asset.animations)} animation clip"
                     f"{'s' if len(asset.animations) > 1 else ''} ({clips}) with its skinning weights; the output "
                     f"keeps its skeleton ({len(asset.skin.joints)} joints) and clips, and held-out views show "
                     "every clip")
    elif asset.skin is not None:
        notes.append("the input is skinned: it was simplified in its bind pose, and the output is static")
    return asset, notes
