"""A :class:`~lookalike.fit.config.Config` in and out of files and options: TOML text, plain
nested dicts (checked against each field's type), command-line overrides, and durations
(``"10m"``). ``None`` values are left out of the TOML file (TOML has no null).
"""

from __future__ import annotations

import dataclasses
import math
import re
import tomllib
import types
import typing
from pathlib import Path
from typing import Any

import tomli_w

from ..errors import ConfigError
from .config import Config


def parse_duration(text: str | float) -> float:
    """Seconds in ``"90"``, ``"90s"``, ``"10m"``, ``"1h"``, ``"1h30m"`` or a number.

    Raises ``ConfigError`` for anything else or for a duration that is not positive.
    """
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        seconds = float(text)
    else:
        s = str(text).strip().lower()
        parts = re.fullmatch(r"(?:(\d+(?:\.\d*)?)h)?(?:(\d+(?:\.\d*)?)m)?(?:(\d+(?:\.\d*)?)s?)?", s)
        if not s or parts is None:
            raise ConfigError(f"cannot read the duration {text!r}: use e.g. 90, 90s, 10m or 1h")
        h, m, sec = (float(p) if p else 0.0 for p in parts.groups())
        seconds = 3600 * h + 60 * m + sec
    if not math.isfinite(seconds) or seconds <= 0:
        raise ConfigError(f"the duration {text!r} must be positive")
    return seconds


def config_to_dict(config: Config) -> dict[str, dict[str, Any]]:
    """Nested plain dict of ``config`` without ``None`` values (tuples become lists)."""
    out = {}
    for section in dataclasses.fields(config):
        values = dataclasses.asdict(getattr(config, section.name))
        out[section.name] = {k: list(v) if isinstance(v, tuple) else v for k, v in values.items() if v is not None}
    return out


def to_toml(config: Config) -> str:
    """The TOML text of ``config`` (every setting, defaults included)."""
    return tomli_w.dumps(config_to_dict(config))


def config_from_dict(data: dict[str, Any], base: Config | None = None, origin: str = "configuration") -> Config:
    """``base`` (default: all defaults) with the values of ``{section: {key: value}}`` applied.

    Raises ``ConfigError`` naming ``origin`` for an unknown section or key or a value of
    the wrong type; the result is validated.
    """
    config = dataclasses.replace(base) if base is not None else Config()
    sections = {f.name: f for f in dataclasses.fields(Config)}
    for name, values in data.items():
        if name not in sections:
            raise ConfigError(f"{origin}: unknown section [{name}]; known: {', '.join(sections)}")
        if not isinstance(values, dict):
            raise ConfigError(f"{origin}: [{name}] must be a table")
        current = getattr(config, name)
        setattr(config, name, _apply(current, values, f"{origin}: [{name}]"))
    return config.validate()


def _apply(section, values: dict[str, Any], where: str):
    """A copy of the dataclass ``section`` with ``values`` set, each checked against its field's type."""
    hints = typing.get_type_hints(type(section))
    known = [f.name for f in dataclasses.fields(section)]
    changes = {}
    for key, value in values.items():
        if key not in known:
            raise ConfigError(f"{where}: unknown key {key!r}; known: {', '.join(known)}")
        changes[key] = _coerce(key, value, hints[key], where)
    return dataclasses.replace(section, **changes)


def _coerce(key: str, value: Any, hint: Any, where: str) -> Any:
    """``value`` checked against the annotation ``hint`` (ints are accepted for floats)."""
    if key == "time_budget":
        return parse_duration(value)
    options = typing.get_args(hint) if typing.get_origin(hint) in (types.UnionType, typing.Union) else (hint,)
    if value is None and type(None) in options:
        return None
    for option in options:
        if typing.get_origin(option) is tuple:
            n = len(typing.get_args(option))
            if isinstance(value, (list, tuple)) and len(value) == n and all(_is_number(v) for v in value):
                return tuple(float(v) for v in value)
        elif option is float and _is_number(value):
            return float(value)
        elif option in (int, str, bool) and type(value) is option:
            return value
    raise ConfigError(f"{where}: {key} = {value!r} has the wrong type (expected {hint})")


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def load_config(path: str | Path, defaults: Config | None = None) -> Config:
    """Read a run's TOML file; missing settings keep those of ``defaults`` (default: ``Config()``).
    A file that sets ``latent.triangles`` clears the defaults' ``ratio`` and vice versa."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such configuration file") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise ConfigError(f"{path}: not a valid TOML file: {e}") from None
    base = defaults or Config()
    latent = data.get("latent")
    if isinstance(latent, dict):
        base = _one_count(base, latent)
    return config_from_dict(data, base=base, origin=str(path))


def _one_count(config: Config, latent: dict[str, Any]) -> Config:
    """``config`` with ``latent.ratio`` cleared where ``latent`` (settings about to be applied)
    sets ``triangles``, and ``latent.triangles`` cleared where it sets ``ratio``."""
    cleared = {other: None for key, other in (("triangles", "ratio"), ("ratio", "triangles"))
               if latent.get(key) is not None}
    return dataclasses.replace(config, latent=dataclasses.replace(config.latent, **cleared)) if cleared else config


def with_overrides(base: Config | str | Path | None, defaults: Config | None = None, **overrides: Any) -> Config:
    """``base`` (a ``Config``, a TOML file, or ``None`` for ``defaults``, themselves by default
    ``Config()``; a file's missing settings keep those of ``defaults``) with the non-``None``
    ``overrides`` applied, each named after a field of one section (``triangles`` sets
    ``latent.triangles``; command-line options and keyword arguments map this way). Setting
    ``triangles`` clears a configured ``ratio`` and vice versa. Validated."""
    config = load_config(base, defaults) if isinstance(base, (str, Path)) \
        else dataclasses.replace(base or defaults or Config())
    section_of = {key.name: section.name for section in dataclasses.fields(config)
                  for key in dataclasses.fields(getattr(config, section.name))}
    changes: dict[str, dict[str, Any]] = {}
    for key, value in overrides.items():
        if value is not None:
            changes.setdefault(section_of[key], {})[key] = value
    return config_from_dict(changes, base=_one_count(config, changes.get("latent", {})), origin="options")
