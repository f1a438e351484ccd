"""Resuming a run from its checkpoint: the checks that it is the same run (the same command,
the same input), and its settings, which are the checkpoint's."""

from __future__ import annotations

import logging
from pathlib import Path

from ..errors import ConfigError
from ..settings import Config, config_from_dict, setting_value, with_overrides

log = logging.getLogger(__name__)

CHECKPOINT_APPLICATION = "application"
"""The checkpoint's entry naming the command that started the run (a run resumes by the same)."""


def resumed_config(saved: dict, checkpoint: Path, given: dict) -> Config:
    """The configuration stored in the checkpoint ``saved``; logs one line naming the given
    settings (``given``, ``None`` where not given) that it overrides: every setting of a resumed
    run is the checkpoint's, except a new ``time_budget`` for this session."""
    cfg = config_from_dict(saved["config"], origin=str(checkpoint))
    ignored = []
    for key, value in given.items():
        if value is None or key == "time_budget":
            continue
        if key in ("config", "init_mesh"):
            ignored.append(f"--{key.replace('_', '-')} {value}")
            continue
        current = setting_value(cfg, key)
        if setting_value(with_overrides(cfg, **{key: value}), key) != current:
            ignored.append(f"--{key.replace('_', '-')} {value} (the run has {current})")
    if ignored:
        log.warning("%s: resuming with the checkpoint's settings; ignored: %s", checkpoint, ", ".join(ignored))
    return cfg


def check_same_command(saved: dict, checkpoint: Path, command: str) -> None:
    """``ConfigError`` unless the checkpoint's run was started by ``command`` (runs from before
    the checkpoint named its command were ``simplify``'s)."""
    started_by = saved.get(CHECKPOINT_APPLICATION, "simplify")
    if started_by != command:
        raise ConfigError(f"{checkpoint}: this run was started by lookalike {started_by}; resume it with "
                          f"lookalike {started_by} ... --resume, or start afresh with --force")


def check_same_input(saved: dict, checkpoint: Path, fingerprint: str, input_name) -> None:
    """``ConfigError`` naming both inputs unless the asset being resumed has the content the
    checkpoint's run started from."""
    if saved.get("input_fingerprint") != fingerprint:
        raise ConfigError(f"{checkpoint}: this run was started from {saved['config']['io']['input']}, and "
                          f"{input_name} is a different asset (content {fingerprint[:12]}, not "
                          f"{str(saved.get('input_fingerprint'))[:12]}); resume with the same input, or start "
                          "afresh with --force")
