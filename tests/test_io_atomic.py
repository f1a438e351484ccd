"""Atomic writes (``lookalike.io.atomic``): a file appears complete or not at all."""

from __future__ import annotations

import os

import pytest

from lookalike.io.atomic import atomic_path, write_text_atomic


def test_atomic_writes_leave_the_old_file_on_failure(tmp_path):
    target = tmp_path / "metrics.json"
    write_text_atomic(target, "first")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as temp:
            temp.write_text("half")
            raise RuntimeError("writer crashed")
    assert target.read_text() == "first"
    assert os.listdir(tmp_path) == ["metrics.json"]
