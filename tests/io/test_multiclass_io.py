"""Several class files of one sequence read as one stream; tracks written one file per class."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sensemaking.classes import CLASS_IDS
from sensemaking.detections import Detections
from sensemaking.io.kitti import read_kitti_labels
from sensemaking.io.stream import (
    iter_detection_frames,
    merge_frames,
    scan_detections,
    sequence_name,
)
from sensemaking.results import FrameResult
from sensemaking.sinks import ClassTracksSink, TracksSink, class_paths

CAR, PED, CYC = CLASS_IDS["car"], CLASS_IDS["pedestrian"], CLASS_IDS["cyclist"]


def pointrcnn_line(frame: int, code: int, x: float, logit: float = 1.0) -> str:
    return f"{frame},{code},{x},100,{x + 40},180,{logit},1.5,1.6,3.9,1.0,1.6,20.0,0.1,0.2\n"


@pytest.fixture()
def class_files(tmp_path: Path) -> tuple[Path, Path, Path]:
    """RRC cars (no 3D columns), PointRCNN pedestrians and cyclists of sequence 0007."""
    car = tmp_path / "rrc" / "car" / "0007.txt"
    ped = tmp_path / "pointrcnn" / "pedestrian" / "0007.txt"
    cyc = tmp_path / "pointrcnn" / "cyclist" / "0007.txt"
    for p in (car, ped, cyc):
        p.parent.mkdir(parents=True)
    car.write_text("0,10,10,60,60,0.9\n2,12,10,62,60,0.8\n2,200,10,260,60,0.7\n")
    ped.write_text(pointrcnn_line(1, 1, 300) + pointrcnn_line(2, 1, 305))
    cyc.write_text(pointrcnn_line(2, 3, 500) + pointrcnn_line(5, 3, 520))
    return car, ped, cyc


def test_merge_gives_every_row_once_by_frame_in_file_order(class_files) -> None:
    car, ped, cyc = class_files
    streams = [iter_detection_frames(p, "kitti") for p in class_files]
    merged = list(merge_frames(streams, keep_data=()))
    assert [f for f, _ in merged] == [0, 1, 2, 5]
    f2 = dict(merged)[2]
    assert f2.class_id.tolist() == [CAR, CAR, PED, CYC]  # rows of each file in file order
    assert f2.source_row.tolist() == [2, 3, 2, 1]  # each row keeps its line in its own file
    assert all(d.data == {} for _, d in merged)  # RRC has no 3D columns: none kept
    total = sum(len(d) for _, d in merged)
    assert total == sum(scan_detections(p, "kitti").detections for p in class_files)


def test_merge_keeps_the_shared_columns(class_files) -> None:
    _, ped, cyc = class_files
    merged = dict(merge_frames([iter_detection_frames(p, "kitti") for p in (ped, cyc)]))
    assert set(merged[2].data) == {"dimensions", "location", "rotation_y", "alpha"}
    assert merged[2].data["location"].shape == (2, 3)
    # PointRCNN logits through the one sigmoid of the reader
    assert np.allclose(merged[2].confidence, 1 / (1 + np.exp(-1.0)))


def test_scan_reports_classes_and_columns(class_files) -> None:
    car, ped, _ = class_files
    assert scan_detections(car, "kitti").classes == (CAR,)
    s = scan_detections(ped, "kitti")
    assert s.classes == (PED,) and "location" in s.data_keys


def test_sequence_names() -> None:
    assert sequence_name("a/car/0001.txt", "kitti") == "0001"
    assert sequence_name("MOT17-02/det/det.txt", "mot") == "MOT17-02"
    assert sequence_name("runs/MOT17-02.txt", "mot") == "MOT17-02"


def tracks(frame: int, ids: list[int], classes: list[int], state: list[int] | None = None):
    n = len(ids)
    return FrameResult(
        frame=frame,
        tracks=Detections(
            xyxy=np.array([[10.0 * i, 10, 10.0 * i + 30, 60] for i in range(n)]).reshape(n, 4),
            confidence=np.full(n, 0.9),
            class_id=np.array(classes, dtype=np.int64),
            tracker_id=np.array(ids, dtype=np.int64),
            frame=np.full(n, frame, dtype=np.int64),
            data={
                "state": np.array(state or [0] * n, dtype=np.int64),
                "occluder": np.full(n, -1, dtype=np.int64),
                "visibility": np.zeros(n, dtype=np.int64),
                "hidden_frames": np.zeros(n, dtype=np.int64),
            },
        ),
    )


def test_class_sink_writes_what_one_sink_writes_split_by_class(tmp_path: Path) -> None:
    frames = [tracks(0, [1, 2, 3], [CAR, PED, CAR]), tracks(1, [2, 4], [PED, CYC], [0, 1])]
    one = TracksSink(tmp_path / "all.txt", "kitti")
    paths = class_paths(tmp_path / "{class}" / "0001.txt", [CAR, PED, CYC])
    assert paths[PED] == tmp_path / "pedestrian" / "0001.txt"
    split = ClassTracksSink(paths, "kitti")
    for r in frames:
        one.frame(r, [])
        split.frame(r, [])
    one.finish()
    split.finish()
    lines = (tmp_path / "all.txt").read_text().splitlines()
    for cid, kitti in ((CAR, "Car"), (PED, "Pedestrian"), (CYC, "Cyclist")):
        assert paths[cid].read_text().splitlines() == [
            ln for ln in lines if ln.split()[2] == kitti
        ]
    assert paths[CYC].read_text() == ""  # the hidden cyclist is not written (no --write-hidden)
    assert split.ids == {1, 2, 3} and split.boxes == one.boxes == 4
    assert set(read_kitti_labels(paths[CAR]).tracker_id.tolist()) == {1, 3}


def test_class_sink_refuses_a_class_without_a_file_and_aborts_cleanly(tmp_path: Path) -> None:
    split = ClassTracksSink(class_paths(tmp_path / "{class}.txt", [CAR]), "kitti")
    with pytest.raises(ValueError, match="pedestrian"):
        split.frame(tracks(0, [1, 2], [CAR, PED]), [])
    split.abort()
    assert list(tmp_path.iterdir()) == []


def test_class_paths_needs_the_field() -> None:
    with pytest.raises(ValueError, match="{class}"):
        class_paths("runs/0001.txt", [CAR])


def test_pipeline_api_tracks_class_files_jointly(tmp_path: Path, class_files) -> None:
    """The docstring's recipe: merged class streams through one tracker, one file per class."""
    from sensemaking.pipeline import Pipeline
    from sensemaking.tracker import Tracker, TrackerConfig

    config = TrackerConfig.for_dataset("kitti", min_hits=1, start_confidence=0.5)
    tracker = Tracker(config)
    paths = class_paths(tmp_path / "{class}" / "0007.txt", [CAR, PED, CYC])
    streams = [iter_detection_frames(p, "kitti") for p in class_files]
    with Pipeline(tracker, sinks=[ClassTracksSink(paths, "kitti")]) as pipe:
        summary = pipe.run(merge_frames(streams, keep_data=()), first_frame=0, last_frame=6)
    assert summary.frames == 7
    out = {c: read_kitti_labels(p) for c, p in paths.items()}
    assert all(set(d.class_id.tolist()) == {c} for c, d in out.items())
    ids = [set(d.tracker_id.tolist()) for d in out.values()]
    assert not (ids[0] & ids[1] or ids[0] & ids[2] or ids[1] & ids[2])  # one id space
    # every detection shows as a visible track box in its class's file, at its frame
    assert out[CAR].frame.tolist() == [0, 2, 2] and out[PED].frame.tolist() == [1, 2]
    assert out[CYC].frame.tolist() == [2, 5]
    assert np.array_equal(out[PED].xyxy[:, 0], [300, 305])
