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


def load_module(path: Path, name: str):
    """The Python file ``path`` imported as module ``name`` (once per session)."""
    import importlib.util
    import sys

    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up while the class is made
    spec.loader.exec_module(module)
    return module


def load_benchmarks_script(name: str):
    """A script of ``benchmarks/`` imported as a module (``benchmark_report``, ...)."""
    return load_module(REPO / "benchmarks" / f"{name}.py", name)


@pytest.fixture()
def scene_file(tmp_path: Path) -> Path:
    """The demo's scene file (``track --scene`` of the paper's Figure 1), written fresh."""
    from sensemaking.demo import run_demo

    return run_demo(tmp_path / "demo", render=False).files["scene"]
