"""``revive_s`` (issue 27): a track that ended by leaving the view or by being lost is found again
under its own id when a fitting detection comes back within the grace time; off, nothing
changes."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from sensemaking.abduction.components import SolverCache
from sensemaking.classes import CLASS_IDS
from sensemaking.config import ParameterError, apply_settings
from sensemaking.detections import Detections
from sensemaking.io.kitti import read_kitti_detections
from sensemaking.track_table import REVIVE_MAX, EndedTracks, TrackTable
from sensemaking.tracker import Tracker, TrackerConfig

CAR = CLASS_IDS["car"]
KITTI = Path(__file__).resolve().parents[2] / "shared" / "data" / "kitti"


def _car(x1: float, x2: float) -> Detections:
    return Detections(np.array([[x1, 180.0, x2, 300.0]]), confidence=0.9, class_id=CAR)


def _run(boxes: list[tuple[float, float] | None], **config) -> list[tuple[list[int], list]]:
    """(ids output, events as (name, args)) per frame of a scripted single-car scene."""
    cfg = TrackerConfig(fps=10, image_size=(1242, 375), **config)
    tracker = Tracker(cfg, solver_cache=SolverCache())
    out = []
    for f, box in enumerate(boxes):
        r = tracker.update(Detections.empty() if box is None else _car(*box), frame=f)
        out.append((r.tracks.tracker_id.tolist(), [(e.name, e.args) for e in r.events]))
    return out


def _border_scene(missed: int = 3) -> list[tuple[float, float] | None]:
    """A car cut by the left border, moving 2 px a frame, missed ``missed`` frames from frame 8."""
    return [None if 8 <= f < 8 + missed else (0.0, 120.0 + 2.0 * f) for f in range(16)]


def _events(run: list[tuple[list[int], list]]) -> list[tuple[int, str, tuple]]:
    return [(f, name, args) for f, (_, evs) in enumerate(run) for name, args in evs]


@pytest.mark.parametrize("revive_s", [0.0, 0.5])
def test_a_car_missed_at_the_border_keeps_its_id_with_the_setting(revive_s):
    run = _run(_border_scene(), revive_s=revive_s)
    events = _events(run)
    assert (8, "leaves_fov", (1,)) in events  # said when it ended, either way
    assert all(ids == [] for ids, _ in run[8:11])  # gone while missed
    if revive_s:
        assert all(ids == [1] for ids, _ in run[11:])
        assert (11, "reenters_fov", (1,)) in events
        assert not any(name in ("enters_fov", "starts") for f, name, _ in events if f > 0)
    else:
        assert all(ids == [2] for ids, _ in run[11:])
        assert (11, "enters_fov", (2,)) in events


@pytest.mark.parametrize("hold", [True, False])
def test_a_lost_car_returns(hold):
    # a car away from the border, missed 4 frames: its missing time (0.2 s) runs out first
    boxes = [None if 6 <= f < 10 else (500.0 + 3.0 * f, 600.0 + 3.0 * f) for f in range(14)]
    on = _run(boxes, max_missing_s=0.2, revive_s=0.5, revive_hold=hold)
    events = _events(on)
    ended = [f for f, name, _ in events if name == "ends"]
    assert ended and ended[0] < 10
    assert (10, "returns", (1,)) in events
    assert all(ids == [1] for ids, _ in on[10:])
    off = _run(boxes, max_missing_s=0.2)
    assert all(ids == [2] for ids, _ in off[10:])


def test_the_story_tells_the_leave_with_the_return(tmp_path):
    from sensemaking.reasoning.questions import explain
    from sensemaking.scene import Scene, SceneRecorder

    cfg = TrackerConfig(fps=10, image_size=(1242, 375), revive_s=0.5)
    tracker = Tracker(cfg, solver_cache=SolverCache())
    rec = SceneRecorder(10.0, (1242, 375))
    for f, box in enumerate(_border_scene()):
        rec.add(tracker.update(Detections.empty() if box is None else _car(*box), frame=f))
    rec.scene().save(tmp_path / "scene.json")
    story = " ".join(explain(Scene.load(tmp_path / "scene.json"), 1))
    assert (
        "At frame 11 it re-enters the field of view at the left border (it left at frame 8)"
        in (story)
    )
    assert "still tracked at the end of the scene (frame 15)" in story
    assert story.count("leaves the field of view") == 0


def test_a_revived_track_is_confirmed_again_as_a_new_one_is():
    # min_hits 3: reported from its second detection on, its event dated then
    run = _run(_border_scene(), revive_s=0.5, min_hits=3)
    assert run[11][0] == [] and all(ids == [1] for ids, _ in run[12:])
    assert (12, "reenters_fov", (1,)) in _events(run)
    # a single detection where it ended does not bring it back
    flicker = [b if f < 11 or f == 12 else None for f, b in enumerate(_border_scene())]
    run = _run(flicker, revive_s=0.5, min_hits=3)
    assert all(ids == [] for ids, _ in run[8:])
    assert not any(name == "reenters_fov" for _, name, _ in _events(run))


def test_the_scene_keeps_the_problem_of_a_revival_for_why_not():
    from sensemaking.scene import SceneRecorder

    cfg = TrackerConfig(fps=10, image_size=(1242, 375), revive_s=0.5, min_hits=3)
    tracker = Tracker(cfg, solver_cache=SolverCache())
    rec = SceneRecorder(10.0, (1242, 375))
    for f, box in enumerate(_border_scene()):
        rec.add(tracker.update(Detections.empty() if box is None else _car(*box), frame=f))
    scene = rec.scene()
    event = next(e for e in scene.events if e.name == "reenters_fov")
    assert event.frame == 12  # reported when confirmed again
    assert scene.abduction is not None
    found = scene.abduction.alternatives(event)
    assert found is not None
    problem, alternatives = found
    assert problem.frame == 11 and problem.revives(1)  # abduced when its detection revived it
    assert alternatives.holds  # solved again, the recorded facts give the same explanation


def test_past_the_grace_time_a_new_track():
    run = _run(_border_scene(missed=6), revive_s=0.3)  # gone 6 frames, 3 allowed
    assert all(ids == [2] for ids, _ in run[14:])


def test_a_car_elsewhere_is_not_the_one_that_left():
    # the car leaves at the left border; another one enters at the right border
    boxes = [(0.0, 120.0 + 2.0 * f) if f < 8 else None for f in range(11)]
    boxes += [(1100.0, 1242.0)] * 4
    run = _run(boxes, revive_s=1.0)
    assert all(ids == [2] for ids, _ in run[11:])
    assert not any(name == "reenters_fov" for _, name, _ in _events(run))


def test_other_heights_are_not_revived():
    boxes = _border_scene()  # it comes back twice as tall: another object
    cfg = TrackerConfig(fps=10, image_size=(1242, 375), revive_s=0.5)
    tracker = Tracker(cfg, solver_cache=SolverCache())
    for f, b in enumerate(boxes):
        if b is None:
            d = Detections.empty()
        elif f >= 11:
            d = Detections(np.array([[0.0, 60.0, b[1], 300.0]]), confidence=0.9, class_id=CAR)
        else:
            d = _car(*b)
        r = tracker.update(d, frame=f)
    assert r.tracks.tracker_id.tolist() == [2]


def test_the_setting_is_declared_and_checked():
    assert TrackerConfig().revive_s == 0.0 and TrackerConfig().revive_frames == 0
    cfg = apply_settings(TrackerConfig(fps=10), {"revive_s": 0.5})
    assert cfg.revive_frames == 5
    with pytest.raises(ParameterError):
        TrackerConfig(revive_s=-1.0)
    with pytest.raises(ParameterError):
        TrackerConfig(revive_height_ratio=1.5)


def test_ended_tracks_are_bounded_and_popped_with_their_filters():
    table = TrackTable()
    n = REVIVE_MAX + 3
    boxes = np.array([[10.0 * i, 0, 10.0 * i + 5, 5] for i in range(n)])
    table.add(np.arange(1, n + 1), boxes, np.ones(n), np.ones(n), np.zeros(n, dtype=np.int64))
    ended = EndedTracks()
    ended.add(table, np.zeros(n))
    assert len(ended) == REVIVE_MAX and ended.table.id[0] == 4  # the oldest went
    back = ended.pop([10, 5])
    assert back.id.tolist() == [10, 5] and len(ended) == REVIVE_MAX - 2
    assert np.allclose(back.kf.xyxy(), boxes[[9, 4]])


@pytest.mark.slow
@pytest.mark.skipif(not KITTI.exists(), reason="shared KITTI data absent")
def test_a_shared_sequence_is_unchanged_until_the_first_revival():
    dets = read_kitti_detections(KITTI / "detections" / "rrc" / "car" / "0004.txt", "car")
    frames = sorted(set(dets.frame.tolist()))
    base = TrackerConfig.for_dataset("kitti")
    off = Tracker(base, solver_cache=SolverCache())
    on = Tracker(base.replace(revive_s=0.5, revive_hold=False), solver_cache=SolverCache())
    revived = None
    for f in range(frames[-1] + 1):
        d = dets[dets.frame == f]
        a, b = off.update(d, frame=f), on.update(d, frame=f)
        if any(e.name in ("reenters_fov", "returns") for e in b.events):
            revived = f
            break
        assert a.events == b.events, f
        assert a.tracks.tracker_id.tolist() == b.tracks.tracker_id.tolist(), f
        assert np.array_equal(a.tracks.xyxy, b.tracks.xyxy), f
    assert revived is not None  # the car of 0004 hidden at the right border (issue 27)


def test_a_snapshot_keeps_the_ended_tracks():
    """The look-ahead rolls hypotheses forward from a snapshot: a restored tracker revives the
    car that left the view as the first run did, and does not once the ended track is gone."""
    cfg = TrackerConfig(fps=10, image_size=(1242, 375), revive_s=0.5)
    tracker = Tracker(cfg, solver_cache=SolverCache())
    boxes = _border_scene()

    def frames(start: int) -> list[list[int]]:
        out = []
        for f in range(start, len(boxes)):
            box = boxes[f]
            r = tracker.update(Detections.empty() if box is None else _car(*box), frame=f)
            out.append(r.tracks.tracker_id.tolist())
        return out

    for f in range(8):
        tracker.update(_car(*boxes[f]), frame=f)
    tracker.update(Detections.empty(), frame=8)  # the car leaves: an ended track is kept
    state = tracker.snapshot()
    first = frames(9)
    assert first[-1] == [1]  # revived
    tracker.restore(state)
    assert frames(9) == first
    assert len(state.ended) == 1
    tracker.restore(replace(state, ended=EndedTracks(cfg.kalman_config)))  # forget it
    assert frames(9)[-1] == [2]  # a new track: what the snapshot kept was what revived it
