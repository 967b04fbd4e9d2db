"""Tracking techniques behind switches (issue 14 item 3): each changes the answer where it must
and nothing where it must not; the switches round-trip through parameter files and --set."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sensemaking import settings
from sensemaking.classes import CLASS_IDS
from sensemaking.cli import main
from sensemaking.detections import Detections
from sensemaking.motion import KalmanBank, KalmanConfig
from sensemaking.results import TrackState
from sensemaking.tracker import SCENE_SHIFT_MIN_TRACKS, Tracker, TrackerConfig

PED = CLASS_IDS["pedestrian"]


def frame(*boxes: tuple[float, float, float, float]) -> Detections:
    if not boxes:
        return Detections.empty()
    return Detections(np.array(boxes, dtype=float), confidence=0.9, class_id=PED)


def box(x: float, y: float = 100.0, w: float = 40.0, h: float = 100.0) -> tuple[float, ...]:
    return (x, y, x + w, y + h)


# ---- resume_reupdate: the observation-centric re-update ------------------------------------
SPEED = 3.0  # pixels per frame
UNSEEN = range(6, 14)  # frames without a detection


def _walker_velocities(reupdate: bool) -> tuple[list[float], set[int]]:
    """A pedestrian standing still for 6 frames starts walking at SPEED as it goes unseen and is
    seen again 8 frames later, walking on at SPEED: the prediction across the gap (at rest) has
    drifted from the truth. Returns the track's x velocity after each frame and the ids given.
    The velocity noise is the KITTI preset's (0.1 box widths per frame)."""
    config = TrackerConfig(
        kalman=KalmanConfig(velocity_std=0.1),
        inherit_motion=False,
        max_missing_s=2.0,
        iou_resume=0.05,
        resume_reupdate=reupdate,
    )
    tracker = Tracker(config)
    velocities, ids = [], set()
    for f in range(17):
        x = 100 + SPEED * max(0, f - 5)
        result = tracker.update(frame() if f in UNSEEN else frame(box(x)), frame=f)
        ids |= set(result.tracks.tracker_id.tolist())
        velocities.append(float(tracker.tracks.kf.velocity()[0, 0]))
    return velocities, ids


def test_reupdate_resumes_with_the_true_velocity() -> None:
    (plain, plain_ids), (re, re_ids) = _walker_velocities(False), _walker_velocities(True)
    assert plain_ids == re_ids == {1}  # one id throughout, both ways
    resumed = UNSEEN.stop  # the frame the walker is seen again
    assert plain[: resumed - 1] == re[: resumed - 1]  # the same until then
    # one correction from the drifted prediction overshoots; the straight line between the two
    # observations gives the true velocity at once
    assert abs(plain[resumed] - SPEED) > 0.5
    assert abs(re[resumed] - SPEED) < 0.1
    assert all(abs(v - SPEED) < 0.1 for v in re[resumed:])


def test_reupdate_changes_nothing_without_a_gap() -> None:
    outs = {}
    for on in (False, True):
        tracker = Tracker(TrackerConfig(resume_reupdate=on, velocity_prior=0.3))
        outs[on] = [
            tracker.update(frame(box(100 + 6 * f), box(400 - 3 * f)), frame=f).tracks.xyxy
            for f in range(12)
        ]
    for a, b in zip(outs[False], outs[True], strict=True):
        np.testing.assert_array_equal(a, b)


def test_kalman_reupdate_is_the_straight_line() -> None:
    """On the bank: after a gap, the re-updated filter equals one that was given the straight
    line's points as detections; without a gap it equals a plain update."""
    cfg = KalmanConfig()
    a, b, c = KalmanBank(cfg), KalmanBank(cfg), KalmanBank(cfg)
    for bank in (a, b, c):
        bank.add(np.array([box(0.0), box(500.0)]))
        bank.predict(1)
        bank.update(np.array([0, 1]), np.array([box(2.0), box(498.0)]))
    for _ in range(4):  # track 0 unseen for 4 frames, track 1 seen
        for bank in (a, b):
            bank.predict(1)
        a.update(np.array([1]), np.array([box(498.0)]))
        b.update(np.array([1]), np.array([box(498.0)]))
    for bank in (a, b):
        bank.predict(1)
    # track 0 seen again at 52 after 4 unseen frames (5 steps from 2); track 1 with no gap
    a.reupdate(np.array([0, 1]), np.array([box(52.0), box(498.0)]), np.array([4, 0]))
    b.update(np.array([0, 1]), np.array([box(52.0), box(498.0)]))
    # c: the same two tracks given the virtual detections 12, 22, 32, 42, 52 for track 0
    for k in range(1, 6):
        c.predict(1)
        c.update(np.array([0, 1]), np.array([box(2.0 + 10 * k), box(498.0)]))
    np.testing.assert_allclose(a.cxcywh()[0], c.cxcywh()[0])
    np.testing.assert_allclose(a.velocity()[0], c.velocity()[0])
    np.testing.assert_allclose(a.covariance()[0], c.covariance()[0])
    np.testing.assert_allclose(a.cxcywh()[1], b.cxcywh()[1])  # no gap: the plain update
    np.testing.assert_allclose(a.velocity()[1], b.velocity()[1])
    assert abs(a.velocity()[0, 0] - 10.0) < abs(b.velocity()[0, 0] - 10.0)


def test_kalman_reupdate_refuses_bad_input() -> None:
    bank = KalmanBank()
    bank.add(np.array([box(0.0)]))
    with pytest.raises(ValueError, match="gaps"):
        bank.reupdate(np.array([0]), np.array([box(1.0)]), np.array([-1]))
    with pytest.raises(ValueError, match="finite"):
        bank.reupdate(np.array([0]), np.array([[np.nan, 0, 1, 1]]), np.array([1]))


# ---- scene_shift: the image motion of a moving camera ----------------------------------------
PAN = 10.0  # pixels per frame: the camera starts to turn at frame PAN_START
PAN_START, HIDE, SHOW = 8, 10, 18


def _pan_scene(scene_shift: bool, others: int = 4, pan: float = PAN) -> list:
    """Pedestrians standing still in the world while the camera, at rest until PAN_START, then
    pans: every box moves left by ``pan`` per frame. The last one is not detected from HIDE to
    SHOW (the frames between); the ``others`` are always seen."""
    config = TrackerConfig(
        fps=10.0,
        image_size=(2000, 400),
        min_hits=1,
        max_missing_s=2.0,
        scene_shift=scene_shift,
    )
    tracker = Tracker(config)
    out = []
    for f in range(SHOW + 4):
        offset = -pan * max(0, f - PAN_START)
        xs = [300.0 + 250 * i + offset for i in range(others)]
        boxes = [box(x) for x in xs]
        if not HIDE <= f < SHOW:
            boxes.append(box(300.0 + 250 * others + offset))
        out.append(tracker.update(frame(*boxes), frame=f))
    return out


def _ids_of_last(results: list, others: int = 4) -> set[int]:
    """Ids given to the box that was not detected for a while (the rightmost box)."""
    found = set()
    for r in results:
        visible = r.tracks.data["state"] == int(TrackState.VISIBLE)
        if visible.sum() == others + 1:
            right = int(np.argmax(r.tracks.xyxy[:, 0] * visible))
            found.add(int(r.tracks.tracker_id[right]))
    return found


def test_scene_shift_keeps_the_id_of_an_unseen_track_while_the_camera_pans() -> None:
    # without it the missing track stays where the camera left it: 80 px away, a new id
    assert len(_ids_of_last(_pan_scene(False))) == 2
    on = _pan_scene(True)
    assert len(_ids_of_last(on)) == 1
    # and its predicted box followed the camera while it was missing
    r = on[SHOW - 1]
    missing = r.tracks.data["state"] == int(TrackState.MISSING)
    assert missing.sum() == 1
    expected = 300.0 + 250 * 4 - PAN * (SHOW - 1 - PAN_START)
    assert abs(r.tracks.xyxy[missing][0, 0] - expected) < 0.3 * PAN


def test_scene_shift_changes_nothing_without_camera_motion_or_evidence() -> None:
    # a still camera; a panning one with too few tracks to tell (the unseen one and a new id
    # for it count too: SCENE_SHIFT_MIN_TRACKS - 2 others)
    for others, pan in ((4, 0.0), (SCENE_SHIFT_MIN_TRACKS - 2, PAN)):
        runs = [_pan_scene(on, others=others, pan=pan) for on in (False, True)]
        for a, b in zip(*runs, strict=True):
            np.testing.assert_allclose(a.tracks.xyxy, b.tracks.xyxy, atol=1e-9)
            assert a.tracks.tracker_id.tolist() == b.tracks.tracker_id.tolist()


# ---- the switches as parameters ----------------------------------------------------------------
@pytest.mark.parametrize("key", ["resume_reupdate", "scene_shift"])
def test_switches_round_trip_through_params_and_set(key: str, tmp_path) -> None:
    assert settings.PARAMETERS[key].kind == "bool"
    assert getattr(TrackerConfig(), key) is False
    path = settings.write_params(tmp_path / "p.json", {key: True}, source="test", base="kitti")
    assert settings.load_params(path) == {key: True}
    on = settings.load_config(path, "kitti")
    assert getattr(on, key) is True
    assert getattr(settings.load_config(path, "kitti", overrides=[f"{key}=false"]), key) is False
    assert getattr(settings.load_config(None, "mot", overrides=[f"{key}=on"]), key) is True
    with pytest.raises(settings.ParameterError, match=f"{key} must be true or false"):
        settings.load_config(None, "mot", overrides=[f"{key}=2"])


# ---- weak_confidence: weak detections continue tracks, never start them -----------------------
def _weak_run(weak: float | None, weak_box: tuple[float, ...]) -> list:
    """A pedestrian detected at 0.9 for 5 frames, then once at 0.3 (``weak_box``); a lone 0.3
    detection far away in that frame too; another pedestrian always detected at 0.9."""
    tracker = Tracker(TrackerConfig(min_confidence=0.5, weak_confidence=weak, min_hits=2))
    out = []
    for f in range(5):
        out.append(tracker.update(frame(box(100 + 4 * f), box(900.0)), frame=f))
    weak_dets = Detections(
        np.array([weak_box, box(600.0), box(900.0)]),
        confidence=np.array([0.3, 0.3, 0.9]),
        class_id=PED,
    )
    out.append(tracker.update(weak_dets, frame=5))
    return out


def test_weak_detection_continues_a_track_it_fits_closely() -> None:
    fits = box(120.0)  # the prediction itself (IoU 1)
    off, on = _weak_run(None, fits)[-1], _weak_run(0.1, fits)[-1]
    state = {int(TrackState.VISIBLE): "visible", int(TrackState.MISSING): "missing"}
    assert [state[int(s)] for s in off.tracks.data["state"]] == ["missing", "visible"]
    assert [state[int(s)] for s in on.tracks.data["state"]] == ["visible", "visible"]
    np.testing.assert_allclose(on.tracks.xyxy[0], fits)  # the weak detection's box
    # the far weak detection started nothing, either way
    assert off.tracks.tracker_id.tolist() == on.tracks.tracker_id.tolist() == [1, 2]


def test_weak_detection_that_fits_loosely_changes_nothing() -> None:
    loose = box(120.0 + 16)  # IoU 24 / 56 = 0.43 with the prediction: under weak_iou 0.5
    off, on = _weak_run(None, loose), _weak_run(0.1, loose)
    for a, b in zip(off, on, strict=True):
        np.testing.assert_array_equal(a.tracks.xyxy, b.tracks.xyxy)
        assert a.tracks.tracker_id.tolist() == b.tracks.tracker_id.tolist()


def test_weak_detection_waits_for_strong_evidence() -> None:
    """A track with a strong candidate is continued by it, never by a weak detection that fits it
    better (ByteTrack's cascade: strong detections first)."""
    tracker = Tracker(TrackerConfig(min_confidence=0.5, weak_confidence=0.1, min_hits=2))
    for f in range(5):
        tracker.update(frame(box(100 + 4 * f)), frame=f)
    dets = Detections(
        np.array([box(120.0), box(126.0)]), confidence=np.array([0.3, 0.9]), class_id=PED
    )
    lik = tracker.likelihood(tracker.tracks.kf.peek(1), dets)
    assert lik[0, 0] == 0.0 and lik[0, 1] > 0.5
    result = tracker.update(dets, frame=5)
    np.testing.assert_allclose(result.tracks.xyxy, [box(126.0)])


def test_class_blind_gate_with_several_tracks() -> None:
    """class_aware=False with two tracks or more (the gate once failed to broadcast)."""
    tracker = Tracker(TrackerConfig(class_aware=False))
    for f in range(3):
        cls = np.array([PED, CLASS_IDS["car"]]) if f < 2 else np.array([CLASS_IDS["car"], PED])
        result = tracker.update(
            Detections(np.array([box(100.0 + f), box(400.0 + f)]), confidence=0.9, class_id=cls),
            frame=f,
        )
    assert result.tracks.tracker_id.tolist() == [1, 2]  # classes swapped, ids kept by position


def _pan_det_file(tmp_path: Path) -> Path:
    """The panning scene of the scene_shift test as a MOT detection file."""
    lines = []
    for f in range(SHOW + 4):
        offset = -PAN * max(0, f - PAN_START)
        n = 5 if not HIDE <= f < SHOW else 4
        for i in range(n):
            x = 300.0 + 250 * i + offset
            lines.append(f"{f + 1},-1,{x:.2f},100.00,40.00,100.00,0.900,-1,-1,-1")
    path = tmp_path / "det.txt"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_switches_reach_the_tracker_from_the_cli(tmp_path: Path, capsys) -> None:
    det = _pan_det_file(tmp_path)
    args = ["-q", "track", "--detections", str(det), "--format", "mot", "--fps", "10"]
    args += ["--set", "min_hits=1", "--set", "max_missing_s=2"]
    ids = {}
    for name, extra in {
        "off": [],
        "set": ["--set", "scene_shift=true", "--set", "resume_reupdate=on"],
        "file": [
            "--params",
            str(
                settings.write_params(
                    tmp_path / "p.json",
                    {"scene_shift": True, "resume_reupdate": True},
                    source="test",
                )
            ),
        ],
    }.items():
        out = tmp_path / f"{name}.txt"
        assert main([*args, *extra, "--output", str(out)]) == 0
        ids[name] = len(np.unique(np.loadtxt(out, delimiter=",")[:, 1]))
    # the camera's pan makes the unseen pedestrian a new id unless scene_shift follows it
    assert ids == {"off": 6, "set": 5, "file": 5}
    bad = tmp_path / "bad.txt"
    assert main([*args, "--set", "weak_iou=1.5", "--output", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "--set weak_iou must be in [0, 1]" in err and err.count("\n") == 1
    assert not bad.exists()
