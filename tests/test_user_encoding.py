"""A user's own rules change the tracker's behaviour on every frame, with nothing changed in
Python."""

from __future__ import annotations

import numpy as np
import pytest

from sensemaking.abduction.solver import load_encoding
from sensemaking.detections import Detections
from sensemaking.errors import InputError
from sensemaking.records import event_record
from sensemaking.tracker import Tracker, TrackerConfig

#: a new event: a track whose predicted motion is near zero stops (speed/2: pixels per second)
STOPS = "occurs(stops(T)) :- track(T), speed(T,S), S < 30."


def _car(f: int) -> tuple[float, float, float, float]:
    """A car driving right at 20 px per frame for 10 frames, then standing still."""
    x = 50 + 20 * min(f, 10)
    return x, 100, x + 80, 160


def _frames(n: int = 50):
    for f in range(n):
        yield (
            f,
            Detections(
                np.array([_car(f), (300 + 6 * f, 300, 350 + 6 * f, 340)], dtype=float),
                confidence=np.array([0.9, 0.9]),
                class_id=np.array([2, 2]),
            ),
        )


def test_a_new_event_in_user_rules_is_reported_on_every_frame_where_it_holds():
    tracker = Tracker(TrackerConfig(fps=10, image_size=(1000, 500)), rules=STOPS)
    reported, expected = [], []
    for f, dets in _frames():
        # the rule's condition, from the tracker's own prediction for this frame
        if len(tracker.tracks.kf):
            v = tracker.tracks.kf.copy().predict(1) - tracker.tracks.kf.xyxy()
            speed = np.rint(np.hypot((v[:, 0] + v[:, 2]) / 2, (v[:, 1] + v[:, 3]) / 2) * 10)
            ids = tracker.tracks.id.tolist()
            expected += [(f, t) for t, s in zip(ids, speed.tolist(), strict=False) if s < 30]
        result = tracker.update(dets, frame=f)
        reported += [(f, e.args[0]) for e in result.events if e.name == "stops"]
    assert reported == expected
    frames_of = {t: [f for f, u in reported if u == t] for _, t in reported}
    # the car that parks stops for good; the one driving on only before its velocity is known
    assert frames_of[1][-1] == 49 and all(f <= 1 for f in frames_of.get(2, []))
    assert min(f for f in frames_of[1] if f > 1) > 10  # not while it drives (frame 1: at rest yet)


def test_user_rules_change_no_other_answer():
    plain = Tracker(TrackerConfig(fps=10, image_size=(1000, 500)))
    extended = Tracker(TrackerConfig(fps=10, image_size=(1000, 500)), rules=STOPS)
    for f, dets in _frames():
        a, b = plain.update(dets, frame=f), extended.update(dets, frame=f)
        assert [e for e in b.events if e.name != "stops"] == a.events
        assert np.array_equal(a.tracks.tracker_id, b.tracks.tracker_id)


def test_a_replaced_encoding_is_used_and_rules_may_come_from_a_file(tmp_path):
    # the packaged encoding with leaving the view made impossible: tracks end as lost instead
    path = tmp_path / "no_leaving.lp"
    path.write_text(load_encoding() + "\n:- occurs(leaves_fov(T)).\n")
    tracker = Tracker(TrackerConfig(fps=10, image_size=(300, 300), min_hits=1), encoding=path)
    names = set()
    for f in range(12):
        x = 100 + 30 * f
        dets = Detections(
            np.array([[x, 100, x + 60, 160]], dtype=float) if x < 300 else np.zeros((0, 4)),
            confidence=np.full(int(x < 300), 0.9),
            class_id=np.full(int(x < 300), 2),
        )
        names |= {e.name for e in tracker.update(dets, frame=f).events}
    assert "leaves_fov" not in names and "ends" in names
    default = Tracker(TrackerConfig(fps=10, image_size=(300, 300), min_hits=1))
    for f in range(12):
        x = 100 + 30 * f
        dets = Detections(
            np.array([[x, 100, x + 60, 160]], dtype=float) if x < 300 else np.zeros((0, 4)),
            confidence=np.full(int(x < 300), 0.9),
            class_id=np.full(int(x < 300), 2),
        )
        names |= {e.name for e in default.update(dets, frame=f).events}
    assert "leaves_fov" in names


def test_events_with_constants_and_without_arguments_are_reported():
    rules = (
        "occurs(lane_change(T,left)) :- track(T), speed(T,S), S > 100. "
        "occurs(busy) :- 2 #count{ T : track(T) }."
    )
    tracker = Tracker(TrackerConfig(fps=10, image_size=(1000, 500)), rules=rules)
    seen = []
    for f, dets in _frames(20):
        result = tracker.update(dets, frame=f)
        seen += [e for e in result.events if e.name in ("lane_change", "busy")]
        assert [event_record(e)["args"] for e in result.events if e.name == "busy"] in ([], [[]])
    assert {e.name for e in seen} == {"lane_change", "busy"}
    assert all(e.args[1:] == ("left",) for e in seen if e.name == "lane_change")


def test_a_broken_encoding_is_a_clear_error_naming_the_file(tmp_path):
    path = tmp_path / "broken.lp"
    path.write_text("occurs(stops(T)) :- track(T)\n")  # no final dot
    with pytest.raises(InputError, match="broken.lp.*does not parse"):
        Tracker(rules=path)
    with pytest.raises(InputError, match="cannot read"):
        Tracker(rules=tmp_path / "absent.lp")


def test_track_cli_reports_user_events_and_situations(tmp_path):
    """`track --rules FILE --situations FILE`: the user's event and situation, end to end."""
    import json

    from sensemaking.cli import main

    det = tmp_path / "det.txt"
    rows = []
    for f, dets in _frames(30):
        for (x1, y1, x2, y2), c in zip(dets.xyxy.tolist(), dets.confidence.tolist(), strict=True):
            rows.append(f"{f + 1},-1,{x1},{y1},{x2 - x1},{y2 - y1},{c},-1,-1,-1")
    det.write_text("\n".join(rows) + "\n")
    rules = tmp_path / "stops.lp"
    rules.write_text(STOPS + "\noccurs(moving(T,fast)) :- track(T), speed(T,S), S > 100.\n")
    situations = tmp_path / "seen.lp"
    situations.write_text("warn(seen,(T,)) :- now(N), track(T,_), state(T,N,visible).\n")
    out, events, warnings = tmp_path / "out.txt", tmp_path / "ev.jsonl", tmp_path / "w.jsonl"
    scene = tmp_path / "scene.json"
    code = main(
        [
            "-q",
            "track",
            "--detections",
            str(det),
            "--format",
            "mot",
            "--output",
            str(out),
            "--events",
            str(events),
            "--warnings",
            str(warnings),
            "--fps",
            "10",
            "--scene",
            str(scene),
            "--image-size",
            "1000x500",
            "--rules",
            str(rules),
            "--situations",
            str(situations),
        ]
    )
    assert code == 0
    names = [json.loads(line)["event"] for line in events.read_text().splitlines()]
    assert "stops" in names and "starts" in names
    # an event with a constant argument, in the events file and in the scene
    assert "moving" in names
    scene_events = json.loads(scene.read_text())["events"]
    assert any(e["event"] == "moving" and e["args"][1] == "fast" for e in scene_events)
    assert main(["-q", "explain", str(scene)]) == 0  # the scene with such events loads
    records = [json.loads(line) for line in warnings.read_text().splitlines()]
    assert "SEEN" in {r["situation"] for r in records}
    # a situation that could not be checked (BLOCKED_LANE: no lanes) is no warning record
    assert records and all(r["objects"] for r in records)
