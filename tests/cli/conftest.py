"""Fixtures shared by the command-line tests."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture()
def scene_file(tmp_path: Path) -> Path:
    """The demo's scene file (``track --scene`` of the paper's Figure 1), written fresh."""
    from sensemaking.demo import run_demo

    return run_demo(tmp_path / "demo", render=False).files["scene"]
