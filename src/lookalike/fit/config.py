"""Every setting of a ``simplify`` run, with all defaults in one place.

A run is described by :class:`Config`, a tree of small dataclasses that maps one to one onto
a TOML file (one table per section)::

    [latent]
    triangles = 1500
    texture_size = 1024

    [optim]
    time_budget = 600.0

``None`` means "not set" and is simply left out of the TOML file (TOML has no null).
Every run writes its complete configuration to ``OUTDIR/config.toml``; passing that file back
with ``--config`` repeats the run.
"""

from __future__ import annotations

import dataclasses
import math
import re
import tomllib
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import tomli_w

from ..errors import ConfigError

LOSSES = ("l1-tonemapped", "l2", "smape", "relative-l2")
INITS = ("bake", "source", "average", "random")
WARM_INITS = ("bake", "source")


@dataclass
class IOConfig:
    """Files.

    Attributes:
        input: the asset to simplify (any format ``lookalike.io.load`` reads).
        outdir: where ``model.glb``, ``report.html``, ``metrics.json``, ``config.toml`` go.
        export_obj: also write ``model.obj`` (with ``.mtl`` and PNG textures).
    """

    input: str = ""
    outdir: str = ""
    export_obj: bool = False


@dataclass
class LatentConfig:
    """The low-poly model being optimised.

    Attributes:
        triangles: target triangle count of the decimated initial mesh.
        ratio: target count as a fraction of the input's (used when ``triangles`` is unset);
            when both are unset, ``DEFAULT_RATIO``.
        texture_size: side S of the square base colour, specular and normal textures.
        init: how the textures start: ``"bake"`` (a fresh atlas with the classic projection
            bake of the input, ``lookalike.init.bake``: normals, colours and specular from rays
            along the low-poly normals), ``"source"`` (the input's own UVs and textures, where it
            has one material with UVs; else as ``"average"``), ``"average"`` (a fresh atlas
            holding the input's mean material) or ``"random"`` (a fresh atlas with uniform
            noise, as in the paper). Fresh normal maps start flat.
    """

    DEFAULT_RATIO = 0.02

    triangles: int | None = None
    ratio: float | None = None
    texture_size: int = 1024
    init: str = "bake"


@dataclass
class RenderConfig:
    """Rendering of training images.

    Attributes:
        resolution: side, in pixels, of the square training images (and of report images).
        target_spp: supersampling of reference images, in samples *per axis*: the reference
            is rendered at ``resolution * target_spp`` pixels per side and box-filtered down,
            i.e. ``target_spp**2`` samples per pixel.
        latent_msaa: visibility samples per axis for the latent model (MSAA, paper Sec. 6.2):
            coverage is sampled ``latent_msaa**2`` times per pixel, shading once. 1 disables.
    """

    resolution: int = 512
    target_spp: int = 2
    latent_msaa: int = 2


@dataclass
class ViewsConfig:
    """Cameras and lights.

    Attributes:
        batch_size: views per optimisation step (the paper uses 1 to 8; on two CPU cores at
            512 px, more single-view steps beat fewer two-view ones in the same time).
        pool_size: reference images rendered before optimising, from which mini-batches are
            drawn; 0 renders fresh random views at every step instead.
        refresh_every: steps between renders of one new view into the pool (replacing its
            oldest); 0 keeps the pool fixed.
        heldout: views of the report, drawn from ``heldout_seed`` and never trained on.
        heldout_seed: seed of the held-out views (fixed so that runs stay comparable).
        validation: views, drawn from ``validation_seed`` and never trained on, on which the
            model is scored every ``optim.validate_every`` steps: the best-scoring state is the
            one kept (the training loss of one-view batches is too noisy to choose by), and the
            scores are the run's convergence curve. 0 chooses by the training loss instead.
        validation_seed: seed of the validation views (not the held-out ones: the report's
            scores stay independent of the choice).
    """

    batch_size: int = 1
    pool_size: int = 64
    refresh_every: int = 2
    heldout: int = 16
    heldout_seed: int = 20_210_809
    validation: int = 4
    validation_seed: int = 20_211_021


@dataclass
class OptimConfig:
    """The optimisation (paper Sec. 6.3).

    Attributes:
        time_budget: wall-clock seconds for the whole run (loading to report); the number of
            iterations is derived from it after timing the first steps unless ``iterations``
            is given.
        iterations: fixed number of optimisation steps, or ``None`` to follow the budget.
        seed: seeds torch and numpy; same seed, same result.
        loss: image loss, one of ``LOSSES`` (see ``lookalike.fit.losses``).
        lr_positions: Adam's lr_0 for vertex positions, in units of the bounding-sphere
            radius; ``None`` picks ``COLD_START``'s (the paper's [0.001, 0.003] for a
            decimated start) where the textures start from scratch (``average``, ``random``)
            and ``WARM_START``'s where they start close (``bake``, ``source``; see
            ``learning_rates``).
        lr_textures: Adam's lr_0 for texels (values in [0, 1]); ``None`` picks
            ``COLD_START``'s or ``WARM_START``'s, as for ``lr_positions``.
        lr_decay: k in lr_t = lr_0 * 10^(-k t); ``None`` stretches the schedule over the run,
            k = decades / iterations, with ``COLD_START``'s two decades (the paper's; its 0.0002
            is that for its 10k steps) or ``WARM_START``'s one, as for ``lr_positions`` (see
            ``lookalike.fit.schedule``).
        outline_views: extra views per step, drawn with the batch, on which only the latent's
            antialiased coverage is rendered and compared (L1) with the reference's: cheap
            gradients for the vertices on the outline. ``None`` picks the warm or cold default
            (see ``outline_views``); 0 turns the term off. A pool smaller than the batch plus
            these gives fewer; without a pool (``views.pool_size`` 0) they are fresh reference
            renders too; latents with alpha do without them.
        outline_weight: weight of that coverage L1 against the image loss.
        laplacian_weight: lambda_0; ``None`` takes 0.25 * L_image / L_laplacian at the start.
        laplacian_min_fraction: lambda_min = this * lambda_0 (the paper's 2 %).
        laplacian_decay_fraction: fraction of the run after which lambda_t - lambda_min has
            fallen to 1 % of lambda_0 - lambda_min (see ``lookalike.fit.schedule``; 0.2
            reproduces the paper's k = 1e-6 on its 10k-step runs).
        validate_every: steps between scorings on the validation views (``views.validation``).
        checkpoint_seconds: write ``OUTDIR/checkpoint.pt`` at most this often.
        rollback_lr_factor: a non-finite step rolls back and multiplies the lr by this.
        max_rollbacks: give up (keeping the best state) after this many rollbacks in a row.
    """

    time_budget: float = 600.0
    iterations: int | None = None
    seed: int = 0
    loss: str = "l1-tonemapped"
    lr_positions: float | None = None
    lr_textures: float | None = None
    lr_decay: float | None = None
    outline_views: int | None = None
    outline_weight: float = 1.0
    laplacian_weight: float | None = None
    laplacian_min_fraction: float = 0.02
    laplacian_decay_fraction: float = 0.2
    validate_every: int = 25
    checkpoint_seconds: float = 60.0
    rollback_lr_factor: float = 0.5
    max_rollbacks: int = 8


@dataclass
class ClampConfig:
    """Valid ranges, enforced after every step.

    Attributes:
        kd: range of base colour and alpha.
        gamma, roughness, metalness: ranges of the three specular channels.
        normal_max_slope: largest |x / z| and |y / z| of a tangent-space normal (3 allows
            tilts of about 72 degrees along each tangent axis).
    """

    kd: tuple[float, float] = (0.0, 1.0)
    gamma: tuple[float, float] = (0.0, 1.0)
    roughness: tuple[float, float] = (0.08, 1.0)
    metalness: tuple[float, float] = (0.0, 1.0)
    normal_max_slope: float = 3.0


@dataclass
class Config:
    """One ``simplify`` run."""

    io: IOConfig = field(default_factory=IOConfig)
    latent: LatentConfig = field(default_factory=LatentConfig)
    render: RenderConfig = field(default_factory=RenderConfig)
    views: ViewsConfig = field(default_factory=ViewsConfig)
    optim: OptimConfig = field(default_factory=OptimConfig)
    clamp: ClampConfig = field(default_factory=ClampConfig)

    def validate(self) -> "Config":
        """Raise ``ConfigError`` naming the first invalid setting; return ``self``."""
        lat, ren, vw, opt = self.latent, self.render, self.views, self.optim
        checks = [
            (lat.triangles is None or lat.triangles > 0,
             f"target triangle count must be positive, got {lat.triangles} (latent.triangles)"),
            (lat.ratio is None or 0.0 < lat.ratio < 1.0, f"latent.ratio must lie in (0, 1), not {lat.ratio}"),
            (lat.triangles is None or lat.ratio is None, "give latent.triangles or latent.ratio, not both"),
            (lat.texture_size >= 4, f"latent.texture_size must be at least 4, not {lat.texture_size}"),
            (lat.init in INITS, f"latent.init must be one of {', '.join(INITS)}, not {lat.init!r}"),
            (ren.resolution >= 16, f"render.resolution must be at least 16, not {ren.resolution}"),
            (ren.target_spp >= 1, f"render.target_spp must be at least 1, not {ren.target_spp}"),
            (ren.latent_msaa >= 1, f"render.latent_msaa must be at least 1, not {ren.latent_msaa}"),
            (vw.batch_size >= 1, f"views.batch_size must be at least 1, not {vw.batch_size}"),
            (vw.pool_size == 0 or vw.pool_size >= vw.batch_size,
             f"views.pool_size must be 0 or at least views.batch_size, not {vw.pool_size}"),
            (vw.refresh_every >= 0, f"views.refresh_every must not be negative, not {vw.refresh_every}"),
            (vw.heldout >= 1, f"views.heldout must be at least 1, not {vw.heldout}"),
            (vw.validation >= 0, f"views.validation must not be negative, not {vw.validation}"),
            (opt.validate_every >= 1, f"optim.validate_every must be at least 1, not {opt.validate_every}"),
            (opt.time_budget > 0, f"optim.time_budget must be positive, not {opt.time_budget}"),
            (opt.iterations is None or opt.iterations >= 0,
             f"optim.iterations must not be negative, not {opt.iterations}"),
            (opt.loss in LOSSES, f"optim.loss must be one of {', '.join(LOSSES)}, not {opt.loss!r}"),
            (all(lr is None or lr >= 0 for lr in (opt.lr_positions, opt.lr_textures)), "learning rates must not be negative"),
            (opt.lr_decay is None or opt.lr_decay >= 0, "optim.lr_decay must not be negative"),
            (opt.outline_views is None or opt.outline_views >= 0, "optim.outline_views must not be negative"),
            (opt.outline_weight >= 0, "optim.outline_weight must not be negative"),
            (self.clamp.normal_max_slope > 0, "clamp.normal_max_slope must be positive"),
            (opt.laplacian_weight is None or opt.laplacian_weight >= 0,
             "optim.laplacian_weight must not be negative"),
            (0 <= opt.laplacian_min_fraction <= 1, "optim.laplacian_min_fraction must lie in [0, 1]"),
            (opt.laplacian_decay_fraction > 0, "optim.laplacian_decay_fraction must be positive"),
            (0 < opt.rollback_lr_factor < 1, "optim.rollback_lr_factor must lie in (0, 1)"),
        ]
        for ok, message in checks:
            if not ok:
                raise ConfigError(message)
        return self


def parse_duration(text: str | float | int) -> float:
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


def load_config(path: str | Path) -> Config:
    """Read a run's TOML file (missing settings keep their defaults)."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such configuration file") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise ConfigError(f"{path}: not a valid TOML file: {e}") from None
    return config_from_dict(data, origin=str(path))


def with_overrides(base: Config | str | Path | None, **overrides: Any) -> Config:
    """``base`` (a ``Config``, a TOML file, or ``None`` for the defaults) with the non-``None``
    ``overrides`` applied, each named after a field of one section (``triangles`` sets
    ``latent.triangles``; command-line options and keyword arguments map this way). Setting
    ``triangles`` clears a configured ``ratio`` and vice versa. Validated."""
    config = load_config(base) if isinstance(base, (str, Path)) else dataclasses.replace(base or Config())
    section_of = {key.name: section.name for section in dataclasses.fields(config)
                  for key in dataclasses.fields(getattr(config, section.name))}
    changes: dict[str, dict[str, Any]] = {}
    for key, value in overrides.items():
        if value is not None:
            changes.setdefault(section_of[key], {})[key] = value
    if "triangles" in changes.get("latent", {}):
        config.latent = dataclasses.replace(config.latent, ratio=None)
    if "ratio" in changes.get("latent", {}):
        config.latent = dataclasses.replace(config.latent, triangles=None)
    return config_from_dict(changes, base=config, origin="options")


class StartDefaults(NamedTuple):
    """Optimiser settings that depend on how close the textures start (``latent.init``):
    the learning rates' lr_0 (``learning_rates``), the decades they fall over the run
    (``lookalike.fit.schedule.learning_rate_decay``) and the outline views (``outline_views``)."""

    lr_positions: float
    lr_textures: float
    lr_decades: float
    outline_views: int


COLD_START = StartDefaults(lr_positions=0.002, lr_textures=0.03, lr_decades=2.0, outline_views=0)
"""Where the textures start from scratch (``average``, ``random``)."""
WARM_START = StartDefaults(lr_positions=0.0003, lr_textures=0.005, lr_decades=1.0, outline_views=2)
"""Where the textures start from a bake or the input's own maps (``WARM_INITS``)."""


def start_defaults(config: Config) -> StartDefaults:
    """``WARM_START`` or ``COLD_START`` for ``config.latent.init``."""
    return WARM_START if config.latent.init in WARM_INITS else COLD_START


def learning_rates(config: Config) -> tuple[float, float]:
    """Adam's ``(lr_0 of positions, lr_0 of texels)``: ``optim.lr_positions`` and
    ``optim.lr_textures`` where set, else the warm or cold defaults for ``latent.init``.

    Why two sets: with one-view batches, Adam moves every parameter by a fraction of its
    learning rate at each step whatever the gradient's size, so the rate sets a noise floor.
    From scratch, the cold rates climb fastest. From a good bake, they first push the model
    down to their noise floor (1-2 dB below the bake on stanford-bunny within 25-100 steps):
    vertices whose gradients are mostly view-to-view noise random-walk away from a surface
    whose shading is already right (with frozen texels too, and with the normal map held in
    object space), and texels jitter. The warm rates, 1/6 of the cold ones, keep the climb
    monotone. Re-measured once antialiasing gave the outline its full gradient (10-minute
    stanford-bunny bake starts): positions at 0.001 reached the random start's best at step
    450 against 425 at 0.0003, best validation PSNR 36.11 against 36.00, held-out 35.32
    against 35.26 with FLIP 0.0125 both; within run-to-run noise, so 0.0003 stays.

    Why warm rates fall one decade over the run (``StartDefaults.lr_decades``), not two:
    stanford-bunny's bake start given half the random start's 1,006 steps (503, fixed) ended
    at best validation PSNR 35.50 with two decades, below the random start's 35.63: after
    step 300 its rates were too small to move the outline (35.36 -> 35.50 over the last 200
    steps). With one decade: 35.71 (held-out 35.14 against the random start's 34.94). Other
    503-step variants, each with two decades unless said: positions at 0.001, 35.58 (it
    drops to 34.02 at step 50); 4 outline views, 35.71; positions at 0.002 rising linearly
    over the first 100 steps, 35.55 (34.35 at step 150); one decade with 4 outline views,
    35.78, within noise of one decade alone, at 10 % more time per step.
    """
    opt, default = config.optim, start_defaults(config)
    return (default.lr_positions if opt.lr_positions is None else opt.lr_positions,
            default.lr_textures if opt.lr_textures is None else opt.lr_textures)


def outline_views(config: Config) -> int:
    """``optim.outline_views`` where set, else the warm or cold default for ``latent.init``.

    Why: from a good bake the remaining error sits at the outline (``report.metrics``), which
    only vertex positions move, and one view per step gives them a noisy gradient (see
    ``learning_rates``). Two more views, coverage only (no shading; on stanford-bunny a step
    takes 0.595 s instead of 0.537), make it steadier. In 10-minute runs of stanford-bunny's
    bake start, with the antialiasing that finds sub-pixel outline triangles: best validation
    PSNR 35.90 and held-out 35.23 with them, 35.74 and 35.02 without (784 against 890 steps);
    their coverage at 1 sample per pixel instead of the latent's 2 x 2 scored the same and
    was not faster.
    Random starts keep the paper's loss: the term was not measured there.
    """
    if config.optim.outline_views is not None:
        return config.optim.outline_views
    return start_defaults(config).outline_views
