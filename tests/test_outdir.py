"""The output folder of a job (``lookalike.jobs.outdir``): never overwritten without force, and
a resume needs a checkpoint."""

from __future__ import annotations

import pytest

from lookalike.errors import ConfigError
from lookalike.jobs.outdir import CHECKPOINT_NAME, prepare_outdir


def test_outdir_is_never_overwritten_without_force(tmp_path):
    out = tmp_path / "out"
    prepare_outdir(out, force=False, resume=False)  # absent: created
    prepare_outdir(out, force=False, resume=False)  # empty: fine
    (out / "model.glb").write_text("old")
    with pytest.raises(ConfigError, match="--force"):
        prepare_outdir(out, force=False, resume=False)
    (out / CHECKPOINT_NAME).write_text("stale")
    prepare_outdir(out, force=True, resume=False)
    assert not (out / CHECKPOINT_NAME).exists() and (out / "model.glb").exists()


def test_resume_needs_a_checkpoint(tmp_path):
    with pytest.raises(ConfigError, match="nothing to resume"):
        prepare_outdir(tmp_path, force=False, resume=True)
    (tmp_path / CHECKPOINT_NAME).write_text("x")
    assert prepare_outdir(tmp_path, force=False, resume=True) == tmp_path
