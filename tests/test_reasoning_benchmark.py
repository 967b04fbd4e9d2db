"""benchmarks/reasoning_overhead.py: clear failure without the tracker; a tiny real run."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "reasoning_overhead.py"
KITTI = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "kitti"


_NEEDS_KITTI = (pytest.mark.integration, pytest.mark.skipif(
    not (KITTI / "detections" / "rrc" / "car" / "0003.txt").exists(), reason="needs ../shared/data/kitti"))


def needs_kitti(test):
    """Marks a test that runs the script on ../shared/data/kitti."""
    for mark in _NEEDS_KITTI:
        test = mark(test)
    return test


def _load():
    spec = importlib.util.spec_from_file_location("reasoning_overhead", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_fails_with_a_clear_message_without_the_tracker(monkeypatch, capsys):
    bench = _load()
    monkeypatch.setitem(sys.modules, "sensemaking.tracker", None)  # import raises ImportError
    assert bench.main(["--data", str(KITTI)]) == 2
    err = capsys.readouterr().err
    assert "sensemaking.tracker is not available yet" in err and "needs the tracker" in err


@needs_kitti
def test_runs_on_one_sequence(capsys):
    pytest.importorskip("sensemaking.tracker")
    bench = _load()
    assert bench.main(["--data", str(KITTI), "--seqs", "0003", "--repeat", "2", "--chunk", "7"]) == 0
    out = capsys.readouterr().out
    assert "ratio (tracker + reasoning) / tracker =" in out and " 0003 " in out
    assert "budget: ratio <= 1.20" in out


@needs_kitti
def test_control_run_compares_the_tracker_with_itself(capsys):
    pytest.importorskip("sensemaking.tracker")
    bench = _load()
    assert bench.main(["--data", str(KITTI), "--seqs", "0003", "--repeat", "1", "--control"]) == 0
    out = capsys.readouterr().out
    assert "control run: both conditions are the tracker alone" in out and "budget:" not in out
    row = next(line.split() for line in out.splitlines() if line.startswith(" 0003 "))
    assert float(row[4]) == 0.0  # no monitor time: the monitor did not run
