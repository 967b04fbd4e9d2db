"""Scene.load reads a scene file a track at a time (sensemaking.scene._read_scene): the same
scene and the same errors as ``Scene.from_json(json.loads(text))``; and the parts of a scene
that a question about one track or one frame builds its facts from."""

from __future__ import annotations

import json
import os
import threading
from pathlib import Path

import numpy as np
import pytest
from test_scene_helpers import CAR, PED, Obj, build_scene, cyclist_behind_turning_car, linear

import sensemaking.scene as scene_module
from sensemaking.detections import Detections
from sensemaking.errors import InputError
from sensemaking.reasoning.questions import ask
from sensemaking.records import event_record
from sensemaking.scene import Scene, SceneRecorder, Track
from sensemaking.synthetic import make_scene
from sensemaking.tracker import Tracker, TrackerConfig

SIZE = (1242, 375)
_FIELDS = ("frames", "xyxy", "confidence", "state", "occluder", "visibility", "hidden_frames")


def reference_load(path: Path) -> Scene:
    """What Scene.load did before it read a track at a time: json.loads, then from_json."""
    text = path.read_text(encoding="utf-8")
    try:
        record = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"not valid JSON: {exc.msg}", path, exc.lineno) from None
    return Scene.from_json(record, path)


def assert_same(a: Scene, b: Scene) -> None:
    assert list(a.tracks) == list(b.tracks)
    for k, t in a.tracks.items():
        u = b.tracks[k]
        assert (t.id, t.class_id) == (u.id, u.class_id)
        for f in _FIELDS:
            x, y = getattr(t, f), getattr(u, f)
            assert x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y), (k, f)
    assert [event_record(e) for e in a.events] == [event_record(e) for e in b.events]
    assert np.array_equal(a.frame_numbers, b.frame_numbers)
    assert a.frame_numbers.dtype == b.frame_numbers.dtype
    assert (a.fps, a.image_size, a.metadata) == (b.fps, b.image_size, b.metadata)
    assert (a.abduction is None) == (b.abduction is None)
    if a.abduction is not None and b.abduction is not None:
        assert a.abduction.to_json() == b.abduction.to_json()
        assert a.abduction.problems == b.abduction.problems


@pytest.fixture(params=[None, 1, 7, 64], ids=["window default", "1", "7", "64"])
def window(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> None:
    """The file read a few characters at a time: values, keys, numbers and whitespace cut by
    the window's end, long values read again in a wider window."""
    if request.param is not None:
        monkeypatch.setattr(scene_module, "_WINDOW_CHARS", request.param)


@pytest.fixture(scope="module")
def tracked() -> Scene:
    """A tracker's scene of synthetic objects, with missing detections and the abduction
    problems behind its events."""
    syn = make_scene(5, n_frames=60, overlap=0.6, miss_rate=0.15, seed=3, width=SIZE[0])
    det = syn.detections
    assert det.frame is not None
    t = Tracker(TrackerConfig(image_size=SIZE))
    rec = SceneRecorder(image_size=SIZE, metadata={"name": "sÿnthétique ✓ 日本", "k": ["ü", 1]})
    for f in range(60):
        rows = np.flatnonzero(det.frame == f)
        rec.add(
            t.update(
                Detections(det.xyxy[rows], confidence=det.confidence[rows], class_id=3), frame=f
            )
        )
    scene = rec.scene()
    assert scene.abduction is not None and scene.abduction.problems and scene.events
    return scene


@pytest.fixture(scope="module")
def hand_built() -> Scene:
    objs = cyclist_behind_turning_car() + [
        Obj(3, PED, linear(range(5, 40), (1000, 200, 1040, 300), (6, 0, 6, 0)), missing={12}),
        Obj(4, CAR, linear(range(0, 20), (100, 220, 220, 300)), missing={15, 16, 17, 18, 19}),
        Obj(5, CAR, linear(range(30, 31), (400, 200, 460, 250))),  # one frame
    ]
    return build_scene(objs)


def _no_json_loads(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError("a valid scene file is read a track at a time, not by json.loads")

    monkeypatch.setattr(scene_module.json, "loads", refuse)


def test_saved_scenes_load_back_equal_without_json_loads(
    tracked, hand_built, tmp_path, monkeypatch, window
):
    gappy = SceneRecorder(fps=5.0, metadata={"note": 'é\u2028"quoted"\\'})
    empty = Scene({}, [], np.arange(3, 9), fps=2.5, metadata={"ünï": "cödé"})
    for r in build_scene([Obj(3, CAR, linear(range(9), (10, 10, 50, 40)))]).frame_results():
        if r.frame % 3:
            gappy.add(r)
    scenes = {"tracked": tracked, "hand": hand_built, "gappy": gappy.scene(), "empty": empty}
    scenes["no frames"] = Scene({}, [], [])
    assert len(hand_built.tracks[5]) == 1 and "frame_numbers" in scenes["gappy"].to_json()
    for name, s in scenes.items():
        path = tmp_path / f"{name}.json"
        s.save(path)
        want = reference_load(path)
        with monkeypatch.context() as m:
            _no_json_loads(m)
            got = Scene.load(path)
        assert_same(got, want)
        assert all(isinstance(t, Track) for t in got.tracks.values())
    assert Scene.load(tmp_path / "empty.json").tracks == {}
    assert Scene.load(tmp_path / "tracked.json").metadata["name"] == "sÿnthétique ✓ 日本"


def test_any_json_layout_loads_the_same(tracked, tmp_path, monkeypatch, window):
    # indented, spaced and reordered: the reader walks whitespace and keys as JSON does
    record = tracked.to_json()
    keys = list(record)[::-1]
    layouts = {
        "indent": json.dumps(record, indent=2, ensure_ascii=False),
        "spaced": " \n\t" + json.dumps(record, separators=(" , ", " : ")) + " \r\n ",
        "reordered": json.dumps({k: record[k] for k in keys}, indent=1),
        # a repeated key keeps its last value, as json.loads does
        "repeated": '{"tracks": [1, 2],' + json.dumps(record)[1:],
    }
    for name, text in layouts.items():
        path = tmp_path / f"{name}.json"
        path.write_text(text, encoding="utf-8")
        want = reference_load(path)
        with monkeypatch.context() as m:
            _no_json_loads(m)
            assert_same(Scene.load(path), want)


def _mutations(record: dict) -> dict[str, object]:
    """Malformed variants of a scene record, several with more than one problem (the first
    one found must stay the one reported)."""

    def mutate(**changes: object) -> dict:
        r = json.loads(json.dumps(record))
        for path, value in changes.items():
            *head, last = path.split("__")
            node = r
            for k in head:
                node = node[int(k)] if k.isdigit() else node[k]
            if value is _DELETE:
                del node[int(last) if last.isdigit() else last]
            else:
                node[int(last) if last.isdigit() else last] = value
        return r

    return {
        "bad fps and bad track": mutate(fps=0, tracks__1__boxes=[[0, 0, 1]]),
        "bad second track": mutate(tracks__1__state=["flying"] * 3),
        "two bad tracks": mutate(tracks__0__frames=[3, 2], tracks__2__id=-1),
        "frames not a list later": mutate(tracks__2__frames=5),
        "frames a dict": mutate(tracks__0__frames={"a": 1}),
        "duplicate id": mutate(tracks__2__id=record["tracks"][0]["id"]),
        "frames outside": mutate(frames=[0, 3]),
        "track not an object": mutate(tracks__1=[1, 2]),
        "tracks an object": mutate(tracks={"a": 1}),
        "no id": mutate(tracks__0__id=_DELETE),
        "box not finite": mutate(tracks__0__boxes__0=[0, 0, 1e9, 1]),
        "bad occluder": mutate(tracks__0__occluder=[99] * len(record["tracks"][0]["frames"])),
        "bad event and bad problem": mutate(events__0__event="Bad", abduction__problems__0=3),
        "bad problem fact": mutate(abduction__problems__1__facts=["a :- b"]),
        "two bad problems": mutate(abduction__problems__0__own=-1, abduction__problems__1=[]),
        "abduction a list": mutate(abduction=[1]),
        "bad encoding and problem": mutate(abduction__encoding="x", abduction__problems__0=1),
        "top level a list": [record],
        "not a scene": mutate(format="other"),
    }


_DELETE = object()


def test_malformed_files_give_the_same_one_line_errors(tracked, tmp_path, window):
    record = tracked.to_json()
    assert len(record["tracks"]) >= 3 and len(record["abduction"]["problems"]) >= 2
    text = json.dumps(record)
    cut = text.index('"boxes"', text.index('"id"', text.index('"tracks"') + 20))
    texts = {name: json.dumps(r) for name, r in _mutations(record).items()}
    texts |= {
        "truncated in a track": text[:cut],
        "trailing comma in tracks": text.replace("]}],", "]},],", 1),
        "missing colon": text.replace('"tracks":', '"tracks"', 1),
        "extra data": text + " {}",
        "byte order mark": "\ufeff" + text,
        "empty": "",
        "nan box": text.replace("[[", "[[NaN,", 1),
        "unquoted key": text.replace('"fps"', "fps", 1),
        "control character": text.replace('"name"', '"na\nme"', 1),
    }
    for name, body in texts.items():
        path = tmp_path / "bad.json"
        path.write_text(body, encoding="utf-8")
        with pytest.raises(InputError) as want:
            reference_load(path)
        with pytest.raises(InputError) as got:
            Scene.load(path)
        assert str(got.value) == str(want.value), name
        assert "\n" not in str(got.value) and str(path) in str(got.value)


def test_not_utf8_is_the_same_error(tmp_path):
    path = tmp_path / "latin.json"
    path.write_bytes(b'{"format": "sensemaking.scene", "metadata": {"n": "\xe9"}}')
    with pytest.raises(InputError, match="cannot read scene file: 'utf-8' codec"):
        Scene.load(path)


# -- the parts of a scene a question needs --------------------------------------------------------
def test_only_keeps_the_tracks_and_their_events(hand_built):
    part = hand_built.only([1, 42])
    assert list(part.tracks) == [1] and part.tracks[1] is hand_built.tracks[1]
    assert part.events == [e for e in hand_built.events if 1 in e.args]
    assert np.array_equal(part.frame_numbers, hand_built.frame_numbers)
    assert part.fluents == hand_built.fluent_intervals(track_id=1)
    assert hand_built.only([]).tracks == {}


def test_window_keeps_the_rows_of_its_frames(hand_built):
    part = hand_built.window(30, 30)
    assert part.frame_numbers.tolist() == [30]
    assert sorted(part.tracks) == [
        t.id for t in hand_built.tracks.values() if t.index(30) is not None
    ]
    for k, t in part.tracks.items():
        i = hand_built.tracks[k].index(30)
        assert i is not None and t.frames.tolist() == [30]
        for f in _FIELDS:
            assert np.array_equal(getattr(t, f), getattr(hand_built.tracks[k], f)[i : i + 1])
    assert all(e.frame == 30 for e in part.events)
    wide = hand_built.window(10, 20)
    assert {e.frame for e in wide.events} <= set(range(10, 21))
    assert len(wide.events) == sum(10 <= e.frame <= 20 for e in hand_built.events)


@pytest.mark.parametrize("which", ["hand_built", "tracked"])
def test_questions_about_one_track_or_frame_answer_as_from_the_whole_scene(which, request):
    # the answers from a track's (or a frame's) part of the scene against those from all of it
    scene = request.getfixturevalue(which)
    questions = [f"{q} {t}" for t in scene.tracks for q in ("why-ended", "reappeared", "hidden")]
    questions += [f"in-front {f}" for f in scene.frame_numbers.tolist()[::3]]
    answers = {q: ask(scene, q) for q in questions}
    with pytest.MonkeyPatch.context() as m:
        m.setattr(Scene, "only", lambda self, ids: self)
        m.setattr(Scene, "window", lambda self, a, b: self)
        whole = {q: ask(scene, q) for q in questions}
    assert answers == whole
    assert any(a.atoms for q, a in answers.items() if q.startswith("in-front"))
    assert any(a.atoms for q, a in answers.items() if q.startswith("reappeared"))
    assert any("ended" in " ".join(a.atoms) for a in answers.values())


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes")
@pytest.mark.parametrize("body", ['{"format": "sensemaking.scene",\n "tracks": [1,]}', "x"])
def test_a_pipe_is_read_once_for_its_error(tmp_path, body):
    # a pipe cannot be read again for the error's message: it is read as a whole at once
    text = tmp_path / "bad.json"
    text.write_text(body, encoding="utf-8")
    with pytest.raises(InputError) as want:
        reference_load(text)
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    writer = threading.Thread(target=fifo.write_text, args=(body,), kwargs={"encoding": "utf-8"})
    writer.start()
    try:
        with pytest.raises(InputError) as got:
            Scene.load(fifo)
    finally:
        writer.join(timeout=10)
    assert str(got.value) == str(want.value).replace(str(text), str(fifo))


@pytest.mark.parametrize("inside", [True, False])
def test_json_nested_too_deeply_is_a_one_line_error_naming_the_file(tmp_path, inside):
    deep = "[" * 100_000 + "]" * 100_000
    body = (
        '{"format": "sensemaking.scene", "version": 1, "fps": 10, "tracks": [{"id": 1, "x": '
        + deep
        + "}]}"
        if inside
        else deep
    )
    path = tmp_path / "deep.json"
    path.write_text(body)
    with pytest.raises(InputError, match="nested too deeply") as err:
        Scene.load(path)
    assert str(path) in str(err.value)
