"""The event log and the output tracks agree about when a track starts: a tentative track's start
event is reported, and dated, at the frame the track is confirmed (its first output frame);
a tentative track dropped unconfirmed leaves no event at all."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import SHARED_DATA

from sensemaking.detections import Detections
from sensemaking.evaluation.explanations import late_start_events
from sensemaking.results import Event, FrameResult
from sensemaking.tracker import Tracker, TrackerConfig

START = ("starts", "enters_fov")


def _check_agreement(results: list[FrameResult]) -> tuple[int, int]:
    """Assert the log and the tracks agree; return ``late_start_events`` of the run."""
    events = [e for r in results for e in r.events]
    for r in results:
        assert all(e.frame == r.frame for e in r.events), "an event dated at another frame"
    output = Detections.concatenate([r.tracks for r in results])
    first: dict[int, int] = {}
    for t, f in zip(output.tracker_id.tolist(), output.frame.tolist(), strict=True):
        first.setdefault(t, f)
    starts = [e for e in events if e.name in START]
    # one start per output track, at its first output frame; no event of an unseen track
    assert sorted(e.args[0] for e in starts) == sorted(first)
    assert all(e.frame == first[e.args[0]] for e in starts)
    assert {a for e in events for a in e.args if isinstance(a, int)} <= set(first)
    visible = Detections.concatenate([r.visible for r in results])
    return late_start_events(visible, events)


def test_tentative_starts_are_dated_when_confirmed_and_dropped_ones_leave_nothing():
    t = Tracker(TrackerConfig(image_size=(1242, 375), min_hits=3, confirm_confidence=None))
    results = []
    for f in range(12):
        boxes = [(400 + 5 * f, 100, 460 + 5 * f, 250)]  # a walker, seen every frame
        if f in (4, 5):  # a false detection, twice: never confirmed
            boxes.append((900, 50, 940, 120))
        if f >= 6:  # a second object, from frame 6 on
            boxes.append((700, 120, 760, 260))
        dets = Detections(np.array(boxes, float), confidence=0.9, class_id=1)
        results.append(t.update(dets, frame=f))
    late, total = _check_agreement(results)
    assert (late, total) == (0, 2)
    events = [e for r in results for e in r.events]
    # the first min_hits frames confirm at once; the second object is confirmed at frame 8
    assert Event(0, "starts", (1,)) in events
    assert [e for e in events if e.args[0] != 1] == [Event(8, "starts", (3,))]


@pytest.mark.slow
@pytest.mark.skipif(not SHARED_DATA.is_dir(), reason="../shared/data is absent")
def test_kitti_sequence_log_and_tracks_agree():
    from sensemaking.benchmark.datasets import iter_benchmarks
    from sensemaking.benchmark.runner import ours_config

    bench = next(iter_benchmarks(SHARED_DATA, ["kitti-rrc-car"]), None)
    if bench is None or not bench.sequences:
        pytest.skip("no KITTI RRC car data in ../shared/data")
    seq = min(bench.sequences, key=lambda s: len(s.frame_numbers))
    size = (int(seq.info.width), int(seq.info.height))
    tracker = Tracker(ours_config("kitti", fps=float(seq.info.fps), image_size=size))
    assert tracker.config.min_hits > 1  # tentative tracks exist
    frames = dict(seq.detections.frames())
    results = [
        tracker.update(frames.get(f, Detections.empty()), frame=f) for f in seq.frame_numbers
    ]
    late, total = _check_agreement(results)
    assert total > 0 and late == 0
