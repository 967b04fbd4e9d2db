"""The Pipeline: skipping gaps changes nothing, sinks write what the whole-run writers write."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sensemaking.detections import Detections
from sensemaking.pipeline import Pipeline
from sensemaking.reasoning.online import SituationMonitor
from sensemaking.scene import SceneRecorder
from sensemaking.sinks import EventsSink, SceneSink, TracksSink, WarningsSink
from sensemaking.synthetic import crossing_scene, figure1_scene
from sensemaking.tracker import Tracker, TrackerConfig


def gapped_frames() -> list[tuple[int, Detections]]:
    """Two synthetic scenes with a 500-frame gap between them, and a short gap inside."""
    a, b = figure1_scene(), crossing_scene(0, gap=12, far_speed=8.0)
    out = [(f, d) for f, d in a.frames() if not 30 <= f < 33]
    last = out[-1][0]
    out += [
        (f + last + 500, d.with_(frame=np.full(len(d), f + last + 500))) for f, d in b.frames()
    ]
    return out


def run(tmp_path: Path, name: str, skip: bool) -> tuple[Pipeline, dict[str, bytes]]:
    config = TrackerConfig.for_dataset("kitti", fps=10.0, image_size=(1242, 375))
    files = {k: tmp_path / f"{name}.{k}" for k in ("tracks", "events", "warnings", "scene")}
    sinks = [
        TracksSink(files["tracks"], "kitti", write_hidden=True),
        EventsSink(files["events"]),
        WarningsSink(files["warnings"]),
        SceneSink(files["scene"], fps=10.0, image_size=(1242, 375), metadata={"name": "x"}),
    ]
    pipe = Pipeline(
        Tracker(config),
        SceneRecorder(fps=10.0, image_size=(1242, 375), metadata={"name": "x"}),
        SituationMonitor(fps=10.0, image_size=(1242, 375)),
        sinks,
    )
    if not skip:
        pipe._horizon = -1  # step every frame
    with pipe:
        pipe.run(gapped_frames(), first_frame=0, last_frame=gapped_frames()[-1][0] + 300)
    return pipe, {k: p.read_bytes() for k, p in files.items()}


@pytest.mark.slow
def test_skipping_gaps_gives_the_same_outputs_as_stepping_every_frame(tmp_path: Path) -> None:
    skipped, a = run(tmp_path, "skip", True)
    stepped, b = run(tmp_path, "step", False)
    assert skipped.summary.skipped > 500 and stepped.summary.skipped == 0
    assert skipped.summary.frames == stepped.summary.frames == stepped.summary.stepped
    assert a == b
    assert json.loads(a["events"].splitlines()[0])  # something was written
    # the streamed scene is the recorder's scene, byte for byte
    recorded = tmp_path / "recorded.json"
    stepped.recorder.scene().save(recorded)
    assert recorded.read_bytes() == b["scene"]


def test_frames_must_increase_and_a_refused_frame_writes_nothing(tmp_path: Path) -> None:
    pipe = Pipeline(Tracker(TrackerConfig(fps=10)), sinks=[EventsSink(tmp_path / "e.jsonl")])
    pipe.step(3, Detections(xyxy=[[0, 0, 10, 10]]))
    with pytest.raises(ValueError, match="frames must increase"):
        pipe.step(3)
    with pytest.raises(ValueError, match="outside 0"):
        pipe.step(10**9)
    pipe.abort()
    assert not list(tmp_path.iterdir())


def test_an_error_inside_the_with_block_leaves_no_file(tmp_path: Path) -> None:
    with pytest.raises(RuntimeError):
        with Pipeline(
            Tracker(TrackerConfig(fps=10)),
            sinks=[TracksSink(tmp_path / "t.txt", "mot"), WarningsSink(tmp_path / "w.jsonl")],
        ) as pipe:
            pipe.step(1, Detections(xyxy=[[0, 0, 10, 10]]))
            raise RuntimeError("boom")
    assert not list(tmp_path.iterdir())
