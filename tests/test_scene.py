"""The scene model: recorder, fluents as intervals, JSON, ASP facts (sensemaking.scene)."""

from __future__ import annotations

import json

import clingo
import numpy as np
import pytest
from test_scene_helpers import (
    CAR,
    CYC,
    PED,
    VAN,
    H,
    Obj,
    W,
    build_results,
    build_scene,
    cyclist_behind_turning_car,
    linear,
)

from sensemaking.errors import InputError
from sensemaking.reasoning.facts import scene_facts_text
from sensemaking.results import FrameResult, TrackState
from sensemaking.scene import FluentInterval, Scene, SceneRecorder, frame_runs


@pytest.fixture(scope="module")
def scene() -> Scene:
    return build_scene(cyclist_behind_turning_car())


def test_recorder_builds_tracks_events_and_frames(scene):
    assert list(scene.tracks) == [1, 2]
    assert (scene.first_frame, scene.last_frame, len(scene)) == (0, 44, 45)
    cyc = scene.tracks[1]
    assert cyc.class_name == "cyclist" and cyc.frames.tolist() == list(range(45))
    assert (cyc.state == TrackState.HIDDEN).sum() == 13
    assert [str(e) for e in scene.events] == [
        "starts(1)@0",
        "starts(2)@0",
        "hides_behind(1, 2)@21",
        "unhides_from_behind(1, 2)@34",
    ]
    assert 1 in scene and 42 not in scene and "1" not in scene
    assert scene.describe(1) == "track 1 (cyclist)" and scene.describe(42) == "track 42"


def test_fluents_as_intervals(scene):
    hid = scene.fluent_intervals("hidden_by")
    assert hid == [FluentInterval(21, 33, "hidden_by", (1, 2), "true")]
    assert [(f.start, f.end, f.value) for f in scene.fluent_intervals("visibility", 1)] == [
        (0, 19, "fully_visible"),
        (20, 20, "partially_occluded"),
        (21, 33, "fully_occluded"),
        (34, 35, "partially_occluded"),
        (36, 44, "fully_visible"),
    ]
    assert [(f.start, f.end) for f in scene.fluent_intervals("in_fov")] == [(0, 44), (0, 44)]
    assert hid[0].asp() == "holds_during(hidden_by(1,2),true,21,33)."


def test_in_fov_breaks_at_gaps_and_occluder_changes():
    a = Obj(
        1,
        CAR,
        {**linear(range(0, 4), (500, 200, 560, 240)), **linear(range(7, 9), (500, 200, 560, 240))},
    )
    scene = build_scene([a], 10)
    assert [(f.start, f.end) for f in scene.fluent_intervals("in_fov")] == [(0, 3), (7, 8)]


def test_json_round_trip(scene, tmp_path):
    path = tmp_path / "sub" / "scene.json"
    scene.save(path)
    back = Scene.load(path)
    assert list(back.tracks) == list(scene.tracks)
    assert back.events == scene.events
    assert back.fluents == scene.fluents
    assert back.fps == 10.0 and back.image_size == (1242, 375)
    t, u = scene.tracks[1], back.tracks[1]
    assert np.allclose(t.xyxy, u.xyxy, atol=0.01) and (t.state == u.state).all()
    assert (t.occluder == u.occluder).all() and (t.visibility == u.visibility).all()
    record = json.loads(path.read_text())
    assert record["format"] == "sensemaking.scene" and record["version"] == 1
    assert record["tracks"][0]["state"][21] == "hidden"
    assert not list(path.parent.glob("*.part"))  # atomic write leaves nothing behind


def test_non_contiguous_frames_round_trip(tmp_path):
    rec = SceneRecorder(fps=5.0)
    results = build_results([Obj(3, CAR, linear(range(6), (10, 10, 50, 40)))])
    for r in results[::2]:
        rec.add(r)
    scene = rec.scene()
    assert scene.frame_numbers.tolist() == [0, 2, 4]
    scene.save(tmp_path / "s.json")
    assert Scene.load(tmp_path / "s.json").frame_numbers.tolist() == [0, 2, 4]
    assert Scene.load(tmp_path / "s.json").image_size is None
    # consecutive in the recorded frames: one in_fov interval
    assert [(f.start, f.end) for f in scene.fluent_intervals("in_fov")] == [(0, 4)]


def test_the_streamed_file_is_json_dump_of_the_dict(scene, tmp_path):
    # save streams the scene (write_scene); its bytes are json.dump of to_json, gaps and all
    rec = SceneRecorder(fps=5.0, metadata={"name": "é"})
    for r in build_results([Obj(3, CAR, linear(range(9), (10, 10, 50, 40)))])[::2]:
        rec.add(r)
    for s in (scene, rec.scene()):
        s.save(tmp_path / "s.json")
        plain = json.dumps(s.to_json(), separators=(",", ":")) + "\n"
        assert (tmp_path / "s.json").read_text(encoding="utf-8") == plain
    assert "frame_numbers" in rec.scene().to_json() and "frame_numbers" not in scene.to_json()
    assert frame_runs([0, 2, 3, 4, 9]) == [(0, 0), (2, 4), (9, 9)] and frame_runs([]) == []


def test_frame_results_replay(scene):
    again = list(scene.frame_results())
    orig = build_results(cyclist_behind_turning_car())
    assert [r.frame for r in again] == [r.frame for r in orig]
    for a, b in zip(again, orig, strict=False):
        assert a.events == b.events
        assert sorted(a.tracks.tracker_id.tolist()) == sorted(b.tracks.tracker_id.tolist())
        assert a.state_of(1) == b.state_of(1)


@pytest.mark.parametrize(
    "text,problem",
    [
        ("{", "not valid JSON"),
        ('{"format": "other"}', "not a scene file"),
        ('{"format": "sensemaking.scene", "version": 99}', "newer"),
        (
            '{"format": "sensemaking.scene", '
            '"tracks": [{"id": 1, "frames": [0, 1], "boxes": [[0,0,1,1]]}]}',
            "'boxes' has 1 entries for 2 frames",
        ),
        (
            '{"format": "sensemaking.scene", '
            '"tracks": [{"id": 1, "frames": [0], "boxes": [[0,0,1,1]], "state": ["flying"]}]}',
            "unknown state 'flying'",
        ),
        ('{"format": "sensemaking.scene", "tracks": [{"frames": [0]}]}', "malformed scene"),
    ],
)
def test_load_errors_name_the_file(tmp_path, text, problem):
    p = tmp_path / "bad.json"
    p.write_text(text)
    with pytest.raises(InputError, match=problem) as err:
        Scene.load(p)
    assert str(p) in str(err.value)


def test_load_missing_file(tmp_path):
    with pytest.raises(InputError, match="scene file not found"):
        Scene.load(tmp_path / "nope.json")


def test_recorder_rejects_decreasing_frames_and_resets():
    rec = SceneRecorder()
    results = build_results([Obj(1, CAR, linear(range(3), (10, 10, 50, 40)))])
    rec.add(results[1])
    with pytest.raises(ValueError, match="frames must increase"):
        rec.add(results[0])
    rec.reset()
    assert len(rec) == 0 and not rec.scene().tracks


def test_empty_frames_are_recorded():
    rec = SceneRecorder(image_size=(100, 100))
    from sensemaking.detections import Detections

    empty = Detections.empty().with_(data={"state": np.zeros(0, np.int64)})
    for f in range(3):
        rec.add(FrameResult(f, empty))
    scene = rec.scene()
    assert len(scene) == 3 and not scene.tracks and scene.fluents == []
    assert "scene_frames(0,2)." in scene_facts_text(scene)


def test_scene_facts_are_valid_asp_with_the_documented_predicates(scene):
    text = scene_facts_text(scene)
    ctl = clingo.Control(["--warn=none"])
    ctl.add("base", [], text)
    ctl.ground([("base", [])])
    names: set[str] = set()
    ctl.solve(on_model=lambda m: names.update(s.name for s in m.symbols(atoms=True)))
    assert names == {
        "scene_frames",
        "frame",
        "fps",
        "image",
        "track",
        "first_frame",
        "last_frame",
        "box",
        "state",
        "occurs_at",
        "holds_during",
        "in_corridor",
        "ra",
        "front",
        "motion",
    }
    assert "track(1,cyclist)." in text and "box(2,0,760,170,960,290)." in text
    assert "state(1,21,hidden)." in text and "occurs_at(hides_behind(1,2),21)." in text
    assert "frame(0)." in text and "frame(44)." in text and "frame(45)." not in text
    assert "motion(1,10,moving_right)." in text and "motion(2,10,moving_left)." in text
    # the cyclist's box lies inside the car's when hidden: during/during (x/y, y within tolerance)
    assert "ra(1,2,25,during,during)." in text
    small = scene_facts_text(
        scene, boxes=False, states=False, relations=False, motion=False, corridor=False
    )
    assert (
        "box(" not in small
        and "ra(" not in small
        and "motion(" not in small
        and "in_corridor(" not in small
    )
    assert "state(" not in small and "last_frame(1,44)." in small


def test_track_of_two_classes_takes_the_majority():
    results = build_results([Obj(1, CAR, linear(range(5), (10, 10, 50, 40)))])
    rec = SceneRecorder()
    for r in results:
        cls = np.full(len(r.tracks), CYC if r.frame == 0 else CAR)
        rec.add(FrameResult(r.frame, r.tracks.with_(class_id=cls), r.events))
    assert rec.scene().tracks[1].class_id == CAR


def test_the_scene_sink_keeps_a_bounded_tail_of_long_live_tracks(tmp_path):
    # tracks live for the whole input: their rows go to the temporary file a part at a time,
    # so what the sink holds stays bounded (issue 23), and the file is the recorder's, byte
    # for byte (parts across batches, a class change inside a track, a track that ends)
    from sensemaking.sinks import SceneSink

    n = 400
    objs = [
        Obj(1, CAR, linear(range(n), (10, 10, 50, 40), (0.7, 0.1, 0.7, 0.1))),
        Obj(2, CAR, linear(range(n), (300, 20, 360, 70), (-0.3, 0.05, -0.3, 0.05))),
        Obj(4, PED, linear(range(150), (900, 60, 930, 140), (0.2, 0, 0.2, 0))),
    ]
    results = build_results(objs, noise_px=0.7)
    rec = SceneRecorder(fps=10.0, image_size=(W, H))
    sink = SceneSink(tmp_path / "sink.json", fps=10.0, image_size=(W, H))
    sink.BATCH_FRAMES, sink.SPILL_ROWS = 8, 32  # small, so that n frames make many parts
    held = []
    for r in results:
        if r.frame in range(100, 103):  # a few frames of track 2 as a van: the majority wins
            cls = np.where(r.tracks.tracker_id == 2, VAN, r.tracks.class_id)
            r = FrameResult(r.frame, r.tracks.with_(class_id=cls), r.events, r.abduction)
        rec.add(r)
        sink.frame(r, [])
        held.append(sink.buffered_rows)
    sink.finish()
    rows = sum(len(r.tracks) for r in results)
    assert rows > 900 and max(held) <= 3 * (32 + 8)  # not one row per frame of the input
    assert max(len(parts) for parts in sink._index.values()) > 10
    rec.scene().save(tmp_path / "rec.json")
    assert (tmp_path / "sink.json").read_bytes() == (tmp_path / "rec.json").read_bytes()
    loaded = Scene.load(tmp_path / "sink.json")
    assert loaded.tracks[2].class_id == CAR and len(loaded.tracks[1]) == n
