"""Does the reference show the input? Its views' coverage against the input's own.

A reference that shows nothing (a path tracer that hides the asset, a field traced outside its
surface, cameras that miss it) gives a fit with nothing to match, and scores that mean nothing.
So before any fitting, each held-out and validation view's coverage by the reference,
``sum(alpha_ref)``, is compared with the input's as our rasterizer draws it from the same
camera (through every depth-peeled layer where it has alpha), ``sum(alpha_input)``: their ratio
is the view's share. A view whose share is below
``MIN_COVERAGE_SHARE`` stops the run with one line.
"""

from __future__ import annotations

import torch

from ..asset import Asset
from ..errors import ReferenceCoverageError
from ..report.heldout import AssetRenderer, HeldoutViews
from .reference_kinds import RunReference

MIN_COVERAGE_SHARE = 0.5
"""Least share of the input's coverage a reference view may show: a reference is either right
(shares within a few per cent of 1) or broken (far below), and antialiasing or a path tracer's
noise moves a share by well under this."""

EMPTY_VIEW = 1e-3
"""Share of a view's pixels under which the input itself counts as absent from it (no share)."""


def coverage_shares(reference: torch.Tensor, input: torch.Tensor) -> torch.Tensor:
    """``[B]`` float64: ``sum(reference) / sum(input)`` per view of coverages ``[B, H, W]``;
    NaN where the input covers less than ``EMPTY_VIEW`` of the view."""
    ours, theirs = reference.double().sum(dim=(1, 2)), input.double().sum(dim=(1, 2))
    pixels = reference.shape[1] * reference.shape[2]
    return torch.where(theirs > EMPTY_VIEW * pixels, ours / theirs.clamp(min=1e-12), torch.nan)


def check_reference_coverage(reference: RunReference, asset: Asset, views: list[HeldoutViews],
                             draw: AssetRenderer) -> dict:
    """The shares of ``views`` (held-out, validation: ``coverage_shares`` against ``asset`` drawn
    by ``draw``, or against themselves where the reference draws the input) as
    ``{"min", "max", "mean", "views"}``; ``ReferenceCoverageError`` where any view's share is
    below ``MIN_COVERAGE_SHARE``, or where the input shows in none."""
    shares = torch.cat([coverage_shares(v.coverage, v.coverage if reference.draws_input else v.renders(asset, draw)[..., 3])
                        for v in views])
    seen = shares[~torch.isnan(shares)]
    if seen.numel() == 0:
        raise ReferenceCoverageError(f"{reference.label} shows nothing in any of its {shares.numel()} held-out and "
                                     "validation views: is the input empty?")
    low = seen < MIN_COVERAGE_SHARE
    if bool(low.any()):
        raise ReferenceCoverageError(
            f"{reference.label} shows {float(seen.min()):.0%} of the input's silhouette in its emptiest view "
            f"({int(low.sum())} of {seen.numel()} views below {MIN_COVERAGE_SHARE:.0%}): it does not show the input, "
            "so there is nothing to fit")
    return {"min": float(seen.min()), "max": float(seen.max()), "mean": float(seen.mean()), "views": int(seen.numel())}
