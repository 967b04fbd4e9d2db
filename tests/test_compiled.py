"""The mypyc-compiled modules (setup.py): the list is kept in one place, they compute what their
Python sources compute, and CI installs them compiled."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

from sensemaking.reasoning import COMPILED, compiled

ROOT = Path(__file__).resolve().parents[1]
KITTI = ROOT.parent / "shared" / "data" / "kitti"
DIGEST = ROOT / "tests" / "compiled_digest.py"


def _setup_list() -> list[str]:
    tree = ast.parse((ROOT / "setup.py").read_text())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", None) == "COMPILED" for t in node.targets):
            return list(ast.literal_eval(node.value))
    raise AssertionError("setup.py defines no COMPILED list")


def test_setup_py_and_the_package_list_the_same_modules():
    paths = _setup_list()
    assert [p.removeprefix("src/").removesuffix(".py").replace("/", ".") for p in paths] == list(COMPILED)
    assert all((ROOT / p).is_file() for p in paths)
    makefile = (ROOT / "Makefile").read_text()
    assert all(p in makefile for p in paths), "the Makefile rebuilds when a compiled module changes"


def test_compiled_reports_every_listed_module():
    status = compiled()
    assert list(status) == list(COMPILED) and all(isinstance(v, bool) for v in status.values())


@pytest.mark.skipif(os.environ.get("SENSEMAKING_EXPECT_COMPILED") != "1",
                    reason="set SENSEMAKING_EXPECT_COMPILED=1 where mypyc and a C compiler are present (CI does)")
def test_the_listed_modules_are_installed_compiled():
    missing = [name for name, ok in compiled().items() if not ok]
    assert not missing, (f"{missing} installed as pure Python: `pip install -v -e .` shows why (often a mypy "
                         "type error in the module, which makes setup.py fall back)")


def _digest(*args: str) -> str:
    run = subprocess.run([sys.executable, str(DIGEST), *args], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    return run.stdout.strip()


@pytest.mark.skipif(not any(compiled().values()), reason="nothing is installed compiled")
def test_compiled_modules_compute_what_their_sources_compute():
    """Warnings, active situations, anticipations and helper results, compiled against pure Python
    (on KITTI too where ../shared/data is present)."""
    args = [str(KITTI)] if (KITTI / "detections" / "rrc" / "car" / "0001.txt").is_file() else []
    compiled_digest, pure_digest = _digest(*args), _digest("--pure", *args)
    assert len(compiled_digest) == 40 and compiled_digest == pure_digest


def test_the_digest_tells_different_computations_apart():
    """The digest is not blind: without KITTI it differs from the one with it."""
    if not (KITTI / "detections" / "rrc" / "car" / "0001.txt").is_file():
        pytest.skip("needs ../shared/data/kitti")
    assert _digest("--pure") != _digest("--pure", str(KITTI))


def _records():
    import numpy as np

    from sensemaking.reasoning import anticipation, relations

    return [
        relations.RelationConfig(near=0.3), relations.MotionThresholds(lag_s=0.2),
        relations.MotionFeatures(*(np.arange(2.0) + k for k in range(5))), anticipation.AnticipationConfig(horizon_s=2.0),
        anticipation.Anticipation(1, 2, 3, 7, (0.0, 1.0, 2.0, 3.0), (1.0, 3.0), 4, 0.4, True, False, True),
        anticipation.ReappearanceError(1, 2, 3, 7, 8, -1, 2.5, (1.0, 3.0), (2.0, 4.0)),
    ]


@pytest.mark.parametrize("index", range(6))
def test_records_of_the_compiled_modules_pickle_and_copy(index):
    """Compiled frozen dataclasses have no __dict__: pickle and copy go through __reduce__."""
    import copy
    import dataclasses
    import pickle

    import numpy as np

    record = _records()[index]

    def values(r):
        return [np.asarray(getattr(r, f.name)).tolist() for f in dataclasses.fields(r)]

    for clone in (pickle.loads(pickle.dumps(record)), copy.copy(record), copy.deepcopy(record)):
        assert type(clone) is type(record) and values(clone) == values(record)
    if hasattr(record, "to_json"):
        assert record.to_json()["track"] == 1


def test_a_monitor_mid_sequence_deep_copies_and_goes_on_alike():
    """A copy of a monitor (compiled or not) carries its whole state: both give the same warnings."""
    import copy

    from sensemaking.reasoning.online import SituationMonitor
    from sensemaking.synthetic import figure1_scene
    from sensemaking.tracker import Tracker, TrackerConfig

    sc = figure1_scene(0)
    tracker = Tracker(TrackerConfig(fps=sc.fps, image_size=(sc.width, sc.height)))
    results = [tracker.update(d, frame=f) for f, d in sc.frames()]
    half = 10  # before the cyclist hides (the demo warns at frame 21)
    mon = SituationMonitor(fps=sc.fps, image_size=(sc.width, sc.height))
    for r in results[:half]:
        mon.update(r)
    twin = copy.deepcopy(mon)
    rest = [[w.to_json() for w in m.update(r)] for m in (mon, twin) for r in results[half:]]
    assert rest[:len(results) - half] == rest[len(results) - half:]
    assert any(rest), "the rest of the demo scene warns (HIDDEN_ENTITY)"
