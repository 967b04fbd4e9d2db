"""What every test folder shares: the repository root and the ``../shared/data`` fixture.

Benchmark data is never committed: it lives in ``shared/data`` beside the repository (CI puts
it there). Tests that need it take the ``shared_data`` fixture, or mark themselves with
``pytest.mark.skipif(not SHARED_DATA.is_dir(), ...)``, so that they skip cleanly without it.
"""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]  # this file sits at <repo>/tests/conftest.py
SHARED_DATA = REPO.parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The benchmark data folder ``../shared/data``; the test skips when it is absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip("../shared/data is absent")
    return SHARED_DATA
