"""Shared fixtures. Tests that need the real assets in ``../shared/assets`` skip, with a
reason, where that folder is absent."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

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
