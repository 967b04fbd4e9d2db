"""``ask SCENE why TRACK [FRAME]``: the chosen explanation against the next-best ones, from the
abduction problems the scene records; and the record's JSON."""

from __future__ import annotations

import json

import numpy as np
import pytest

from sensemaking.abduction.solver import encoding_constants
from sensemaking.cli import main
from sensemaking.detections import Detections
from sensemaking.errors import InputError
from sensemaking.reasoning.questions import QueryError, ask
from sensemaking.scene import Scene, SceneRecorder
from sensemaking.tracker import AbductionCosts, Tracker, TrackerConfig

C = encoding_constants()
SIZE = (1242, 375)
# the far object (track 1) lies within the near one's box, behind it (lower bottom edge)
# at the top border (a box cut at the left, right or bottom border cannot start hiding)
NEAR_EDGE, FAR_EDGE = (130, 0, 230, 200), (150, 0, 210, 130)
NEAR_MID, FAR_MID = (500, 100, 600, 300), (520, 150, 580, 280)  # away from it


def hiding_scene(near, far, **config) -> Scene:
    """Far alone (frames 0-2), both (3-5), then only the near one: far hides at frame 6."""
    t = Tracker(TrackerConfig(image_size=SIZE, **config))
    rec = SceneRecorder(image_size=SIZE)
    for f in range(10):
        boxes = [far] if f < 3 else [near, far] if f < 6 else [near]
        rec.add(t.update(Detections(np.array(boxes, float), confidence=0.9, class_id=1), frame=f))
    return rec.scene()


@pytest.fixture(scope="module")
def edge_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("why") / "scene.json"
    hiding_scene(NEAR_EDGE, FAR_EDGE).save(path)
    return path


def test_why_names_leaving_the_view_as_the_next_best_at_the_border(edge_file, capsys):
    assert main(["ask", str(edge_file), "why", "1", "6"]) == 0
    out = capsys.readouterr().out
    hide, leave = C["cost_hides"], C["cost_leaves"]
    missing, lost = C["cost_missing"], C["cost_lost"]
    assert out.startswith("At frame 6, track 1 (pedestrian) hides behind track 2 (pedestrian)")
    assert "rather than: leaves the field of view" in out
    # the differences are the encoding's constants: hiding against leaving, missing, lost
    assert f"{leave - hide:+d})" in out and f"{missing - hide:+d})" in out
    assert f"{lost - hide:+d})" in out
    assert out.index("leaves the field of view") < out.index("missing detections")


def test_why_away_from_the_border_and_the_answers_atoms():
    scene = hiding_scene(NEAR_MID, FAR_MID)
    answer = ask(scene, "why 1 6")
    assert "leaves the field of view" not in str(answer)
    chosen = [a for a in answer.atoms if a.startswith("chosen(")]
    assert len(chosen) == 1 and chosen[0].startswith("chosen(hides_behind(1,2),6,")
    cost = int(chosen[0].rsplit(",", 1)[1].rstrip(")"))
    alts = [a for a in answer.atoms if a.startswith("alternative(")]
    first = [a for a in alts if a.startswith("alternative(1,6,1,")]
    assert first == [
        f"alternative(1,6,1,missing_detections(1),{cost + C['cost_missing'] - C['cost_hides']},"
        f"{C['cost_missing'] - C['cost_hides']})"
    ]


def test_why_follows_the_trackers_costs():
    scene = hiding_scene(NEAR_MID, FAR_MID, costs=AbductionCosts(missing=120))
    answer = ask(scene, "why 1 6")
    assert scene.abduction is not None and scene.abduction.constants["cost_missing"] == 120
    assert "missing detections) (cost " in str(answer)
    assert f"{120 - C['cost_hides']:+d})" in str(answer)


def test_why_a_tentative_tracks_start_is_abduced_at_its_first_frame():
    scene = hiding_scene(NEAR_MID, FAR_MID, min_hits=3, confirm_confidence=None)
    start = next(e for e in scene.events if e.args == (2,))
    assert start.name == "starts" and start.frame == scene.tracks[2].first == 5
    text = str(ask(scene, "why 2"))
    assert "abduced at frame 3, when its detection started the track" in text
    assert "is ignored (a detection explained by no track)" in text


def test_why_round_trips_through_the_scene_file(tmp_path):
    scene = hiding_scene(NEAR_EDGE, FAR_EDGE)
    path = tmp_path / "s.json"
    scene.save(path)
    again = Scene.load(path)
    assert again.abduction is not None
    assert again.abduction.to_json() == scene.abduction.to_json()
    assert str(ask(again, "why 1")) == str(ask(scene, "why 1"))
    record = json.loads(path.read_text())
    assert record["abduction"]["constants"]["cost_hides"] == C["cost_hides"]


def test_bad_why_input_is_a_one_line_error(edge_file, tmp_path, capsys):
    for words, message in [
        (["why", "42"], "track 42 does not appear in this scene"),
        (["why", "1", "99"], "frame 99 is out of range: track 1 (pedestrian) is in frames 0-9"),
        (["why", "x"], "usage: why TRACK [FRAME]"),
    ]:
        assert main(["ask", str(edge_file), *words]) == 2
        err = capsys.readouterr().err
        assert message in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err
    # a scene without the record
    record = json.loads(edge_file.read_text())
    del record["abduction"]
    old = tmp_path / "old.json"
    old.write_text(json.dumps(record))
    assert main(["ask", str(old), "why", "1", "6"]) == 2
    assert "does not record the abduction problems" in capsys.readouterr().err
    # a record whose facts are not facts
    record = json.loads(edge_file.read_text())
    record["abduction"]["problems"][-1]["facts"][0] = "a :- b"
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(record))
    assert main(["ask", str(bad), "why", "1", "6"]) == 2
    err = capsys.readouterr().err
    assert "is not a ground atom" in err and len(err.strip().splitlines()) == 1
    record["abduction"] = {"encoding": "mine.lp"}
    bad.write_text(json.dumps(record))
    with pytest.raises(InputError, match="only the packaged encoding"):
        Scene.load(bad)


def test_why_without_an_event_at_the_frame(edge_file):
    scene = Scene.load(edge_file)
    answer = ask(scene, "why 1 4")
    assert (
        str(answer)
        == "track 1 (pedestrian) has no event at frame 4 (frames with its events: 0, 6)"
    )
    with pytest.raises(QueryError):
        ask(scene, "why 1 2 3")


def test_explain_why_adds_the_alternatives_to_the_story(edge_file, capsys):
    assert main(["explain", str(edge_file), "--track", "1", "--why"]) == 0
    out = capsys.readouterr().out
    assert "rather than: leaves the field of view" in out
    assert out.index("At frame 6, track 1 (pedestrian) hides behind") > 0
    assert main(["explain", str(edge_file), "--why"]) == 2
    assert "--why needs --track K" in capsys.readouterr().err


def test_every_event_of_a_run_comes_back_from_its_recorded_problem():
    from sensemaking.synthetic import crossing_scene

    synthetic = crossing_scene(0)
    t = Tracker(
        TrackerConfig(image_size=(synthetic.width, synthetic.height), min_hits=2),
    )
    rec = SceneRecorder(image_size=(synthetic.width, synthetic.height))
    for f, d in synthetic.frames():
        rec.add(t.update(d, frame=f))
    scene = rec.scene()
    assert scene.abduction is not None and len(scene.events) >= 4
    assert {"hides_behind", "unhides_from_behind"} <= {e.name for e in scene.events}
    for e in scene.events:
        found = scene.abduction.alternatives(e, 0)
        assert found is not None, e
        record, alts = found
        assert alts.holds, e
        assert record.frame <= e.frame
    # a recorder told not to keep them keeps none
    quiet = SceneRecorder(problems=False)
    quiet.add(t.update(Detections.empty(), frame=10_000))
    assert quiet.scene().abduction is None
