"""Shared fixtures: paths to the project's test data and to the real data in ../shared/data."""

from __future__ import annotations

from pathlib import Path

import pytest

TESTS_DIR = Path(__file__).resolve().parent


@pytest.fixture(scope="session")
def tests_data() -> Path:
    """``tests/data`` of this project."""
    return TESTS_DIR / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """``../shared/data`` next to the project root (read-only real recordings); skips when absent."""
    path = Path(__file__).resolve().parents[1].parent / "shared" / "data"
    if not path.is_dir():
        pytest.skip(f"../shared/data not present: {path} (real-data tests skipped)")
    return path
