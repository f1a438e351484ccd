"""``expect_warning``: a check that a block logs one warning through ``logging`` (the project's
warnings are one line each, through ``logging``, not ``warnings``)."""

from __future__ import annotations

import contextlib
import logging


@contextlib.contextmanager
def expect_warning(caplog, words: str):
    """Fail unless the block logs a WARNING whose message contains ``words``."""
    with caplog.at_level(logging.WARNING, logger="lookalike"):
        start = len(caplog.records)
        yield
    messages = [r.getMessage() for r in caplog.records[start:] if r.levelno == logging.WARNING]
    assert any(words in m for m in messages), f"no warning with {words!r} in {messages}"
