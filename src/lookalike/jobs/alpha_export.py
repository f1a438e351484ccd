"""How a model whose alpha was trained is written (``latent.alpha_mode``).

- Training: ``"auto"`` trains the start's own mode (the input's: ``MASK`` with a
  straight-through gradient, ``lookalike.shading.surface``); ``"blend"`` trains blended, soft
  alpha, because a straight-through mask learns little from a billboard cloud's projected
  alpha where the same run blended improves (``docs/benchmarks.md``): coverage that the cards
  must move lives in partial alpha. ``"mask"`` starts the same way, as a ramp of coverage
  around the cutoff as wide as blending, and narrows it to the hard test over
  ``latent.mask_anneal`` of the run (``Material.coverage_ramp``), so that the model is fitted
  as it will be drawn; with ``mask_anneal`` 0 it trains blended and is thresholded at the end.
- The alpha of a ``MASK`` model: the cutoff of ``CUTOFFS`` (or the model's own) whose model
  scores the best PSNR on the run's validation views; ``"mask"`` turns the soft model into an
  alpha-tested one that way, or by an ordered dither of its soft alpha (a screen door that keeps
  partial coverage), whichever scores best.
- Blended materials split: the triangles of a ``BLEND`` material whose texels are all opaque go
  to an ``OPAQUE`` copy of it (``split_opaque``). Engines draw a blended material without
  writing depth (three.js, Babylon.js, Unity's glTFast), so a blended mesh shows its own
  triangles in index order, back over front; drawn opaque, the solid parts keep their depth,
  and only what is translucent is left to blend. Our renderer draws both alike.
- Colour under texels no sample can see: each RGB texel whose 3 x 3 neighbourhood is all
  invisible (alpha below the cutoff, or zero when blending) takes the colour of the nearest
  visible texel, so that the mip levels engines build from the texture do not bleed the dark
  fringes of unseen texels into the leaves' edges. Texels next to a visible one keep their
  trained colour: bilinear lookups at full resolution render as they did in the fit.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch
from scipy.ndimage import binary_dilation, distance_transform_edt

from ..asset import Asset
from ..io.image_files import tiled_thresholds

CUTOFFS = (0.3, 0.4, 0.5, 0.6, 0.7)
"""The alpha cutoffs tried on the validation views."""

ALPHA_CANDIDATES = len(CUTOFFS) + 2
"""At most this many models are scored on the validation views to choose the alpha (the
cutoffs, the model's own, the dither)."""


def training_start(asset: Asset, mode: str, mask_anneal: float) -> Asset:
    """``asset`` as the fit trains it for ``latent.alpha_mode`` ``mode``: its alpha-using
    materials alpha-tested at 0.5 with a coverage ramp of width 1 (as blended at first; the fit
    narrows it, ``latent.mask_anneal``) for ``"mask"``, or blended for ``"mask"`` without
    annealing and for ``"blend"``; as it is for ``"auto"``. Opaque materials stay opaque."""
    if mode == "auto":
        return asset
    if mode == "mask" and mask_anneal > 0:
        return with_alpha_mode(asset, "MASK", alpha_cutoff=0.5, coverage_ramp=1.0)
    return with_alpha_mode(asset, "BLEND")


def with_alpha_mode(asset: Asset, mode: str, **fields) -> Asset:
    """``asset`` with its alpha-using materials set to glTF alpha mode ``mode`` (``"MASK"``,
    ``"BLEND"``) and the other ``Material`` ``fields`` given; opaque materials stay opaque."""
    if not any(m.uses_alpha for m in asset.materials):
        return asset
    materials = [dataclasses.replace(m, alpha_mode=mode, **fields) if m.uses_alpha else m for m in asset.materials]
    return dataclasses.replace(asset, materials=materials)


def annealed_alpha(asset: Asset) -> bool:
    """Whether a fit from ``asset`` (as ``training_start`` gives it) trains its alpha test in:
    an alpha-tested material with a coverage ramp."""
    return any(m.alpha_mode == "MASK" and m.coverage_ramp > 0 for m in asset.materials)


@dataclass(frozen=True)
class AlphaChoice:
    """How the alpha of a ``MASK`` model is written: at ``cutoff`` (``None``: its own), or
    ``dither``ed (``dithered_alpha``, cutoff 0.5)."""

    cutoff: float | None = None
    dither: bool = False


def alpha_choices(model: Asset, mode: str) -> list[AlphaChoice]:
    """The ways ``model`` may be written for ``latent.alpha_mode`` ``mode``: its own cutoff
    first, then ``CUTOFFS``, then (for ``"mask"``) the dither; one (as it is) where nothing is
    alpha-tested."""
    masked = mode == "mask" or any(m.alpha_mode == "MASK" for m in model.materials)
    if not masked or not any(m.uses_alpha for m in model.materials):
        return [AlphaChoice()]
    own = model.materials[0].alpha_cutoff
    choices = [AlphaChoice(c) for c in sorted({own, *CUTOFFS}, key=lambda c: (c != own, c))]
    return choices + ([AlphaChoice(dither=True)] if mode == "mask" else [])


def written_alpha(model: Asset, mode: str, choice: AlphaChoice) -> Asset:
    """``model`` as written for ``latent.alpha_mode`` ``mode`` with ``choice``: alpha-tested
    for ``"mask"``, at the chosen cutoff or dithered, the test hard (``coverage_ramp`` 0, as
    glTF draws it); every alpha-using material's colour filled under unseen texels
    (``filled_colour``). Opaque models are returned as they are."""
    if not any(m.uses_alpha for m in model.materials):
        return model
    if mode == "mask":
        model = with_alpha_mode(model, "MASK")
    if choice.dither:
        model = _dithered(model)
    elif choice.cutoff is not None:
        model = _at_cutoff(model, choice.cutoff)
    materials = [dataclasses.replace(m, kd=dataclasses.replace(m.kd, data=filled_colour(m.kd.data, _seen_from(m))),
                                     coverage_ramp=0.0)
                 if m.uses_alpha else m for m in model.materials]
    return split_opaque(dataclasses.replace(model, materials=materials))


OPAQUE_ALPHA = 0.9
"""Alpha from which a texel counts as opaque. A fit lets the alpha of solid surfaces drift to
0.9-0.99 (at small sizes most of them); drawn opaque they lose a tenth of what is behind at
most, and the model scores within a few hundredths of a dB of the blended one in our renderer,
where engines would show its inside through it."""


def opaque_triangles(model: Asset, material: int) -> torch.Tensor:
    """``[T]`` bool: the triangles of ``material`` that show nothing behind them: every texel
    whose centre their UVs cover, and the texel under their centroid, has alpha >=
    ``OPAQUE_ALPHA``. (Texels beyond a chart's edge, which bilinear lookups and coarse mips
    blend in at the edge, are not asked: an opaque material draws the edge solid, as the fit's
    surface is.) Other triangles are False."""
    from ..asset.uv_raster import rasterize_uv

    mesh, kd = model.mesh, model.materials[material].kd
    alpha = kd.data[..., 3].detach().numpy() if kd.channels == 4 else np.ones(kd.data.shape[:2], np.float32)
    mine = (mesh.t_mat_idx == material).numpy()
    if alpha.size == 1 or not mesh.uv:
        return torch.from_numpy(mine & bool(alpha.min() >= OPAQUE_ALPHA))
    solid = alpha >= OPAQUE_ALPHA
    v_tex, t_tex = mesh.uv[min(kd.uv_set, len(mesh.uv) - 1)]
    uv = v_tex[t_tex].double().numpy()
    if kd.transform is not None:
        uv = uv @ kd.transform[:2, :2].double().numpy().T + kd.transform[:2, 2].double().numpy()
    height, width = alpha.shape
    rows, cols, tri, _ = rasterize_uv(uv, height, width)
    clear = np.zeros(len(uv), bool)
    np.logical_or.at(clear, tri, ~solid[rows, cols])
    centre = np.floor(uv.mean(axis=1) * [width, height]).astype(np.int64)
    clear |= ~solid[centre[:, 1] % height, centre[:, 0] % width]
    return torch.from_numpy(mine & ~clear)


def split_opaque(model: Asset) -> Asset:
    """``model`` with the opaque triangles (``opaque_triangles``) of each ``BLEND`` material
    moved to an ``OPAQUE`` copy of it (same textures, named ``NAME_opaque``), appended after the
    materials; a blended material all of whose triangles are opaque becomes opaque itself."""
    materials, t_mat_idx = list(model.materials), model.mesh.t_mat_idx.clone()
    for k, material in enumerate(model.materials):
        if material.alpha_mode != "BLEND":
            continue
        opaque = opaque_triangles(model, k)
        if not opaque.any():
            continue
        solid = dataclasses.replace(material, alpha_mode="OPAQUE", name=f"{material.name}_opaque")
        if bool(opaque.sum() == (model.mesh.t_mat_idx == k).sum()):
            materials[k] = solid
            continue
        materials.append(solid)
        t_mat_idx[opaque] = len(materials) - 1
    if len(materials) == len(model.materials) and all(a is b for a, b in zip(materials, model.materials)):
        return model
    mesh = dataclasses.replace(model.mesh, t_mat_idx=t_mat_idx)
    return dataclasses.replace(model, mesh=mesh, materials=materials)


def merged_opaque(model: Asset) -> Asset:
    """``split_opaque`` undone: the triangles of each ``OPAQUE`` copy ``NAME_opaque`` back on its
    blended material ``NAME``, the copies dropped (a written model read back as the one material
    its fit held)."""
    names = {material.name: k for k, material in enumerate(model.materials)}
    target = torch.arange(len(model.materials))
    for k, material in enumerate(model.materials):
        base = names.get(material.name.removesuffix("_opaque"), k)
        if material.alpha_mode == "OPAQUE" and material.name.endswith("_opaque") and base != k:
            target[k] = base
    kept = target == torch.arange(len(model.materials))
    if bool(kept.all()):
        return model
    renumbered = torch.cumsum(kept.long(), 0) - 1
    mesh = dataclasses.replace(model.mesh, t_mat_idx=renumbered[target[model.mesh.t_mat_idx]])
    return dataclasses.replace(model, mesh=mesh, materials=[m for m, keep in zip(model.materials, kept) if keep])


def alpha_label(model: Asset, mode: str, choice: AlphaChoice) -> str | None:
    """How ``written_alpha(model, mode, choice)`` writes the alpha, for reports: ``"blended"``,
    ``"dithered"`` or ``"cutoff C"``; ``None`` where no material uses alpha."""
    used = [m for m in model.materials if m.uses_alpha]
    if not used:
        return None
    if mode != "mask" and used[0].alpha_mode == "BLEND":
        return "blended"
    if choice.dither:
        return "dithered"
    return f"cutoff {used[0].alpha_cutoff if choice.cutoff is None else choice.cutoff:g}"


def chosen_alpha(model: Asset, mode: str, score: Callable[[Asset], float] | None) -> AlphaChoice:
    """The choice of ``alpha_choices`` whose written model ``score`` (e.g. validation PSNR;
    higher is better) rates best, ties to the earlier (the model's own cutoff first); the first
    where ``score`` is ``None``."""
    choices = alpha_choices(model, mode)
    if score is None or len(choices) == 1:
        return choices[0]
    scored = [(score(written_alpha(model, mode, choice)), -i) for i, choice in enumerate(choices)]
    return choices[-max(scored)[1]]


def finished_alpha(model: Asset, mode: str, score: Callable[[Asset], float] | None) -> Asset:
    """``model`` as written with the alpha choice ``score`` rates best (``chosen_alpha``)."""
    return written_alpha(model, mode, chosen_alpha(model, mode, score))


def dithered_alpha(alpha: torch.Tensor) -> torch.Tensor:
    """``alpha [H, W]`` in [0, 1] as 0 or 1 by ordered dithering: 1 where it exceeds the Bayer
    threshold tiled over the texels (``io.image_files.tiled_thresholds``). Over each 8 x 8 block the share of
    ones is the mean alpha (to 1/64): an alpha-tested texture that keeps soft coverage as a
    screen door, where thresholding at one cutoff would round it all one way."""
    return (alpha > torch.from_numpy(tiled_thresholds(*alpha.shape)).to(alpha)).to(alpha)


def _dithered(model: Asset) -> Asset:
    """``model`` with the alpha of its ``MASK`` materials dithered (``dithered_alpha``), cutoff 0.5."""
    def dither(material):
        kd = material.kd.data.detach().clone()
        kd[..., 3] = dithered_alpha(kd[..., 3])
        return dataclasses.replace(material, kd=dataclasses.replace(material.kd, data=kd, mips=None), alpha_cutoff=0.5)

    return dataclasses.replace(model, materials=[dither(m) if m.alpha_mode == "MASK" else m for m in model.materials])


def _at_cutoff(model: Asset, cutoff: float) -> Asset:
    materials = [dataclasses.replace(m, alpha_cutoff=float(cutoff)) if m.alpha_mode == "MASK" else m
                 for m in model.materials]
    return dataclasses.replace(model, materials=materials)


def _seen_from(material) -> float:
    """The alpha from which a texel of ``material`` shows: its cutoff when masked, else just
    above zero."""
    return material.alpha_cutoff if material.alpha_mode == "MASK" else 1.0 / 255.0


def filled_colour(kd: torch.Tensor, visible_from: float) -> torch.Tensor:
    """``kd [H, W, 4]`` (RGB + alpha) with the RGB of every texel whose 3 x 3 neighbourhood has
    no texel of alpha >= ``visible_from`` replaced by that of the nearest such texel (Euclidean
    distance in texels); alpha unchanged. Returned as is where no texel is visible."""
    texels = kd.detach().numpy()
    visible = texels[..., 3] >= visible_from
    if not visible.any() or visible.all():
        return kd
    unseen = ~binary_dilation(visible, structure=np.ones((3, 3), bool))
    rows, cols = distance_transform_edt(~visible, return_distances=False, return_indices=True)
    filled = texels.copy()
    filled[unseen, :3] = texels[rows[unseen], cols[unseen], :3]
    return torch.from_numpy(filled)
