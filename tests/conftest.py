"""Shared fixtures. Tests that need the real assets in ``../shared/assets`` skip, with a
reason, where that folder is absent."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

from lookalike import threads

SHARED_ASSETS = Path(__file__).resolve().parents[1].parent / "shared" / "assets"


@pytest.fixture
def shared_assets() -> Path:
    """Path of ``../shared/assets``; skips the test where it is absent."""
    if not SHARED_ASSETS.is_dir():
        pytest.skip(f"needs the real assets in {SHARED_ASSETS}, which is absent")
    return SHARED_ASSETS


@pytest.fixture(autouse=True)
def _seeded():
    """Every test starts from the same random state."""
    torch.manual_seed(0)
    yield


@pytest.fixture(autouse=True, scope="session")
def _pinned_threads():
    """Every test runs with the thread count pinned to the available cores, so that runs that
    must repeat bit for bit (resume) do not adapt to whatever else the machine runs
    (``lookalike.threads.CoreShare`` has tests of its own)."""
    threads.set_threads(threads.available_cores())
    yield
