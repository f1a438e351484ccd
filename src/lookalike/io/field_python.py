"""Signed distance fields written in Python: a ``.py`` file defining ``sdf(p)`` (torch,
``[N, 3] -> [N]``, negative inside), ``bounds = ((xmin, ymin, zmin), (xmax, ymax, zmax))`` and
optionally ``material(p)`` (a dict of ``base_color [N, 3]`` linear, ``roughness [N]``,
``metallic [N]``), read as an ``ImplicitSurface`` (``io.field_asset``).

The file is the user's own code, run in this process. Whatever it raises, at load or in a later
call, becomes a ``UserCodeError`` naming their file and line; what it returns is checked
(shape, NaN) on every call, so that a mistake is reported where it is made.
"""

from __future__ import annotations

import runpy
import traceback
from pathlib import Path

import torch

from ..asset import Asset
from ..asset.implicit import ImplicitSurface
from ..errors import AssetError, UserCodeError
from .field_asset import checked_distances, field_asset, parse_bounds
from .registry import reader


def user_code_error(path: Path, error: BaseException) -> UserCodeError:
    """``error``, raised by the user's file ``path``, as a ``UserCodeError`` at the deepest line
    of ``path`` in its traceback (or the line a ``SyntaxError`` gives)."""
    target = path.resolve()
    frames = [f for f in traceback.extract_tb(error.__traceback__) if Path(f.filename).resolve() == target]
    detail = "".join(traceback.format_exception_only(type(error), error)).strip().splitlines()[-1]
    if frames:
        return UserCodeError(path, frames[-1].lineno, detail, frames[-1].name)
    return UserCodeError(path, getattr(error, "lineno", None), detail)


class CheckedCall:
    """The user's function ``name`` of ``path``, called on ``points [N, 3]`` with their errors
    reported as theirs (``user_code_error``)."""

    def __init__(self, fn, name: str, path: Path):
        self.fn, self.name, self.path = fn, name, path

    def __call__(self, points: torch.Tensor):
        try:
            with torch.no_grad():
                return self.fn(points)
        except Exception as e:  # the user's code: any error is theirs
            raise user_code_error(self.path, e) from None


class CheckedField(CheckedCall):
    """``sdf``: ``[N]`` float32, or ``AssetError`` naming a wrong shape or the first NaN."""

    def __call__(self, points: torch.Tensor) -> torch.Tensor:
        return checked_distances(super().__call__(points), points, self.path)


class CheckedMaterial(CheckedCall):
    """``material``: a dict whose ``base_color`` is ``[N, 3]`` and whose other channels have one
    value per point (or one for all), or ``AssetError`` naming what is wrong."""

    def __call__(self, points: torch.Tensor) -> dict:
        values = super().__call__(points)
        n = points.shape[0]
        if not isinstance(values, dict) or "base_color" not in values:
            raise AssetError(self.path, "material(p) must return a dict with 'base_color' ([N, 3], linear)")
        checked = {}
        for key, shape in (("base_color", (n, 3)), ("roughness", (n,)), ("metallic", (n,))):
            if key not in values:
                continue
            value = torch.as_tensor(values[key]).detach().float()
            if value.numel() not in (1, shape[0] * (shape[1] if len(shape) > 1 else 1)):
                raise AssetError(self.path, f"material(p)[{key!r}] has shape {tuple(value.shape)}; it must be "
                                 f"[N{', 3' if len(shape) > 1 else ''}] for N points")
            if not bool(torch.isfinite(value).all()):
                raise AssetError(self.path, f"material(p)[{key!r}] is not finite everywhere")
            checked[key] = value.expand(shape) if value.numel() == 1 else value.reshape(shape)
        return checked


def load_python_field(path: Path) -> ImplicitSurface:
    """The ``ImplicitSurface`` that the Python file ``path`` defines."""
    text = path.read_text(encoding="utf-8", errors="replace")
    try:
        names = runpy.run_path(str(path), run_name=f"lookalike_field_{path.stem}")
    except Exception as e:  # the user's code: any error is theirs
        raise user_code_error(path, e) from None
    if not callable(names.get("sdf")):
        raise AssetError(path, "defines no function sdf(p) ([N, 3] torch points -> [N] signed distances)")
    if "bounds" not in names:
        raise AssetError(path, "defines no bounds = ((xmin, ymin, zmin), (xmax, ymax, zmax))")
    lo, hi = parse_bounds(names["bounds"], path)
    material = names.get("material")
    if material is not None and not callable(material):
        raise AssetError(path, "material must be a function material(p) returning a dict")
    return ImplicitSurface(sdf=CheckedField(names["sdf"], "sdf", path),
                           material=None if material is None else CheckedMaterial(material, "material", path),
                           lo=lo, hi=hi, text=text, kind="python", path=path)


@reader(".py")
def read_python_field(path: Path) -> Asset:
    return field_asset(load_python_field(path), path)
