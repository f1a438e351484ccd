"""Colour transfer functions: the sRGB encoding (IEC 61966-2-1) and the paper's HDR tone map.

Each function works elementwise on any shape and takes either a torch tensor (differentiable;
the result is a tensor) or a NumPy array (the result is an array), in the input's dtype. Inputs
are not clamped to ``[0, 1]``: callers that need a displayable range clamp themselves.
"""

from __future__ import annotations

import numpy as np
import torch


def _namespace(x):
    """``torch`` for a tensor, else ``numpy``: both provide the ``where``, ``clip`` and ``log1p``
    used here with the same meaning."""
    return torch if isinstance(x, torch.Tensor) else np


def srgb_encode(x):
    """sRGB encoding of linear values ``x`` (the sRGB transfer function):
    ``12.92 x`` for ``x <= 0.0031308``, else ``1.055 x^(1/2.4) - 0.055``.

    The power is taken of ``max(x, 0.0031308)``, so negative ``x`` gives no NaN (nor NaN
    gradients); those map to ``12.92 x``."""
    xp = _namespace(x)
    return xp.where(x <= 0.0031308, 12.92 * x, 1.055 * xp.clip(x, 0.0031308, None) ** (1 / 2.4) - 0.055)


def srgb_decode(c):
    """Linear values of sRGB-encoded ``c`` (inverse of ``srgb_encode``):
    ``c / 12.92`` for ``c <= 0.04045``, else ``((c + 0.055) / 1.055)^2.4``.

    The power is taken of ``max(c, 0.04045)``, so negative ``c`` gives no NaN; those map to
    ``c / 12.92``."""
    xp = _namespace(c)
    return xp.where(c <= 0.04045, c / 12.92, ((xp.clip(c, 0.04045, None) + 0.055) / 1.055) ** 2.4)


def tonemap(x):
    """The paper's tone map of linear radiance (Sec. "Objective function"):
    ``x' = srgb_encode(log(x + 1))`` with ``x`` clamped below at 0; not clamped above (values
    above ``e - 1`` map above 1)."""
    xp = _namespace(x)
    return srgb_encode(xp.log1p(xp.clip(x, 0, None)))
