"""benchmarks/pipeline.py measures what `track` runs: every output, each frame timed once."""

from __future__ import annotations

from pathlib import Path

from conftest import load_benchmarks_script


def test_every_frame_of_the_pipeline_is_timed(tmp_path: Path) -> None:
    pipeline = load_benchmarks_script("pipeline")
    det = pipeline.write_synthetic(tmp_path / "scene", 30, n_objects=6)
    argv = ["--detections", str(det), "--format", "mot", "--class", "car"]
    out = tmp_path / "out"
    out.mkdir()
    r = pipeline.run_track(argv, out, ("events", "warnings", "scene"), False)
    # one timed step and one tracker update per input frame; the monitor answers each frame
    assert len(r["step"]) == 30 and len(r["tracker"]) == 30
    assert 0 < len(r["monitor"]) <= 30
    assert all(ms >= 0 for ms in r["step"]) and (out / "warnings.jsonl").exists()
