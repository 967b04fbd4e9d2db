"""Shared test setup: refuse to test stale compiled modules."""

from __future__ import annotations

import importlib.machinery
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"


def pytest_sessionstart(session: pytest.Session) -> None:
    """An editable install builds the mypyc modules beside their sources (setup.py), where they
    shadow the ``.py``: a source edited since would go untested. Stop with what to run."""
    from sensemaking.reasoning import COMPILED

    for name in COMPILED:
        source = SRC / (name.replace(".", "/") + ".py")
        for suffix in importlib.machinery.EXTENSION_SUFFIXES:
            built = source.with_suffix(suffix)
            if built.is_file() and source.is_file() and built.stat().st_mtime < source.stat().st_mtime:
                pytest.exit(f"{built.name} is older than {source.name}: run `make setup` to compile it again "
                            f"(or delete {built} to test the Python source)", returncode=2)
