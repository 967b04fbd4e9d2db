"""benchmarks/monitor_restarts.py replays one run's frame results on a monitor per setting."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import load_benchmarks_script

from sensemaking.reasoning import online


def test_the_replay_times_every_frame_of_each_setting(tmp_path: Path, capsys, monkeypatch) -> None:
    script = load_benchmarks_script("monitor_restarts")
    det = script.write_synthetic(tmp_path / "scene", 40, n_objects=6)
    argv = ["--detections", str(det), "--format", "mot", "--class", "car"]
    kwargs, results = script.record(argv, tmp_path)
    assert len(results) == 40 and "_args" in kwargs
    monkeypatch.setattr(online, "STREAM_RESTART_FRAMES", 8)
    stage = online.STREAM_STAGE_FRAMES
    script.replay(kwargs, results, [0, 4], 1)
    rows = [line.split() for line in capsys.readouterr().out.splitlines()[1:]]
    assert [r[0] for r in rows] == ["0", "4"]
    assert float(rows[0][2]) == pytest.approx(1.0)
    assert all(int(r[-1]) >= 4 for r in rows)  # both restarted: 40 answers, a Control per 8
    assert online.STREAM_STAGE_FRAMES == stage  # the module's setting is given back
