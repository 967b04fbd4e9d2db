"""benchmarks/reasoning_overhead.py: clear failure without the tracker; a tiny real run."""

from __future__ import annotations

import importlib.util
import sys

import pytest
from conftest import REPO, SHARED_DATA

SCRIPT = REPO / "benchmarks" / "reasoning_overhead.py"
KITTI = SHARED_DATA / "kitti"


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


@pytest.mark.integration
@pytest.mark.slow
@pytest.mark.skipif(
    not (KITTI / "detections" / "rrc" / "car" / "0003.txt").exists(),
    reason="needs ../shared/data/kitti",
)
def test_runs_on_one_sequence_and_prints_the_time_per_frame_against_the_target(capsys):
    pytest.importorskip("sensemaking.tracker")
    bench = _load()
    assert bench.main(["--data", str(KITTI), "--seqs", "0003", "--repeat", "1", "--gt"]) == 0
    out = capsys.readouterr().out
    rows = [line.split() for line in out.splitlines() if line.startswith(" 0003 ")]
    assert len(rows) == 2  # tracker output and ground truth
    for row in rows:
        frames, ms, calls, hits = int(row[1]), float(row[2]), int(row[3]), int(row[4])
        assert frames == 144 and ms > 0 and calls + hits == frames
    assert out.count("target 0.1 ms/frame:") == 2
