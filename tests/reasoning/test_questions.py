"""Question answering and stories over a hand-built scene (sensemaking.reasoning.questions)."""

from __future__ import annotations

import pytest
from test_scene_helpers import CAR, PED, Obj, build_scene, cyclist_behind_turning_car, linear

from sensemaking.errors import SensemakingError
from sensemaking.reasoning.questions import NAMED_QUESTIONS, QueryError, ask, explain, stories
from sensemaking.scene import Scene


@pytest.fixture(scope="module")
def scene() -> Scene:
    """Cyclist 1 hidden behind car 2 (frames 21-33); pedestrian 3 with missing detections
    (12-14) who leaves at the right border; car 4 lost after 5 missing frames."""
    objs = cyclist_behind_turning_car() + [
        Obj(
            3,
            PED,
            linear(range(5, 40), (1000, 200, 1040, 300), (6, 0, 6, 0)),
            missing={12, 13, 14},
        ),
        Obj(4, CAR, linear(range(0, 20), (100, 220, 220, 300)), missing={15, 16, 17, 18, 19}),
    ]
    return build_scene(objs)


def lines(scene: Scene, q: str) -> list[str]:
    return list(ask(scene, q).lines)


def test_hidden(scene):
    assert lines(scene, "hidden") == [
        "track 1 (cyclist) was hidden by track 2 (car) from frame 21 to frame 33, "
        "13 frames (1.3 s); it reappeared at frame 34"
    ]
    assert ask(scene, "hidden").atoms == ("hidden_episode(1,2,21,33)",)
    assert lines(scene, "hidden 3") == ["track 3 (pedestrian) was never hidden"]


def test_reappeared(scene):
    assert lines(scene, "reappeared 1") == [
        "track 1 (cyclist) reappeared at frame 34 from behind track 2 (car), "
        "unseen since frame 21: 13 frames (1.3 s)"
    ]
    assert lines(scene, "reappeared 3") == [
        "track 3 (pedestrian) reappeared at frame 15 after missing detections, "
        "unseen since frame 12: 3 frames (0.3 s)"
    ]
    assert lines(scene, "reappeared 2") == [
        "track 2 (car) never disappeared: visible whenever tracked (frames 0-44)"
    ]
    assert lines(scene, "reappeared 4") == [
        "track 4 (car) did not reappear: unseen from frame 15 until its last frame 19"
    ]


def test_in_front(scene):
    assert lines(scene, "in-front 25") == [
        "at frame 25 (2.5 s into the scene), in front of the ego vehicle:",
        "track 2 (car): nearest, bottom at y=290 px",
        "track 1 (cyclist): hidden behind track 2 (car), bottom at y=254 px",
    ]
    assert ask(scene, "in-front 25").atoms == ("in_front(25,2,290)", "in_front(25,1,254)")
    assert lines(scene, "in-front 99") == ["frame 99 is not in this scene (frames 0-44)"]


def test_why_ended(scene):
    assert lines(scene, "why-ended 3") == [
        "track 3 (pedestrian) ended because it left the field of view at the right border "
        "(event at frame 40; last tracked at frame 39)"
    ]
    assert lines(scene, "why-ended 4") == [
        "track 4 (car) was lost at frame 20: its detections had been missing for 5 frames "
        "(0.5 s) since frame 15, and the tracker could no longer explain its absence"
    ]
    assert lines(scene, "why-ended 1") == [
        "track 1 (cyclist) did not end: it was still tracked (visible) at the last frame "
        "of the scene (44)"
    ]


def test_unknown_track_gets_a_clear_answer(scene):
    for q in ("why-ended 42", "reappeared 42", "hidden 42", "events 42", "story 42"):
        assert lines(scene, q) == ["track 42 does not appear in this scene (tracks: 1, 2, 3, 4)"]
    assert explain(scene, 42) == ["track 42 does not appear in this scene (tracks: 1, 2, 3, 4)"]


def test_tracks_and_events(scene):
    assert lines(scene, "tracks") == [
        "track 1 (cyclist): frames 0-44, visible 32, hidden 13, missing 0",
        "track 2 (car): frames 0-44, visible 45, hidden 0, missing 0",
        "track 3 (pedestrian): frames 5-39, visible 32, hidden 0, missing 3",
        "track 4 (car): frames 0-19, visible 15, hidden 0, missing 5",
    ]
    assert lines(scene, "events 3") == [
        "frame 5: starts(3)",
        "frame 12: missing_detections(3)",
        "frame 15: reappears(3)",
        "frame 40: leaves_fov(3)",
    ]


def test_story_sentences(scene):
    assert explain(scene, 1) == [
        "Track 1 (cyclist) is in view from the first frame (0), in front of the ego vehicle "
        "(x=454, y=254 px).",
        "It moves right at about 60 px/s.",
        "At frame 21 it hides behind track 2 (car).",
        "At frame 34 it comes out from behind track 2 (car) after 13 frames (1.3 s).",
        "It is still tracked at the end of the scene (frame 44), visible.",
    ]
    assert explain(scene, 3) == [
        "Track 3 (pedestrian) appears at frame 5, on the right (x=1020, y=300 px).",
        "It moves right at about 60 px/s.",
        "From frame 12 its detections are missing.",
        "At frame 15 it is detected again after 3 frames (0.3 s).",
        "At frame 40 it leaves the field of view at the right border.",
    ]
    assert explain(scene, 4)[-1] == (
        "At frame 20 the track ends: unseen for 5 frames (0.5 s), its absence could "
        "no longer be explained."
    )
    assert "At frame 21 it hides track 1 (cyclist) from view." in explain(scene, 2)
    every = stories(scene)
    assert list(every) == [1, 2, 4, 3]  # order of appearance
    assert explain(scene) == [s for ss in every.values() for s in ss]
    assert lines(scene, "story 1") == explain(scene, 1)


def test_asp_query_with_and_without_show(scene):
    a = ask(scene, "q(T) :- occurs_at(hides_behind(T,_),_).")
    assert a.atoms == ("q(1)",) and a.lines == ("q(1)",)
    a = ask(scene, "q(T,F) :- holds_at(visibility(T),partially_occluded,F), F < 22. #show q/2.")
    assert a.atoms == ("q(1,20)",)
    a = ask(scene, "near(A,B) :- ra(A,B,25,_,_), A < B.")
    assert a.atoms == ("near(1,2)",)
    a = ask(scene, "q(T) :- track(T,C), C != car, not in_corridor(T,0). #show q/1.")
    assert a.atoms == ("q(3)",)
    assert ask(scene, "q(T) :- motion(T,30,moving_left).").atoms == ("q(2)",)
    assert ask(scene, "q(A,B) :- closer(A,B,25).").atoms == ("q(2,1)",)
    assert ask(scene, "q(T) :- box(T,0,X,_,_,_), X < 200.").atoms == ("q(4)",)


def test_asp_constraints_models_and_notes(scene):
    assert ask(scene, ":- not occurs_at(ends(4),_).").lines == (
        "yes: the scene satisfies the query's constraints",
    )
    unsat = ask(scene, ":- occurs_at(ends(4),_).")
    assert not unsat.satisfiable and "UNSATISFIABLE" in unsat.lines[0]
    many = ask(scene, "{ pick(T) : track(T,_) } = 1.", max_models=0)
    assert sorted(many.models) == [("pick(1)",), ("pick(2)",), ("pick(3)",), ("pick(4)",)]
    assert many.lines[0].startswith("answer 1: pick(")
    typo = ask(scene, "q(X) :- ocurs_at(X,_).")
    assert typo.lines == ("none: no shown atom holds",)
    assert typo.notes and typo.notes[0].startswith("query:1:9-") and "ocurs_at" in typo.notes[0]


@pytest.mark.parametrize(
    "query,line,column,text",
    [
        ("q(X) :- track(X,car.", 1, 20, "syntax error"),
        ("q(X) :- track(X,_).\nr(Y) :- q(Y) q(Y).", 2, 14, "syntax error"),
        ("q(X) :- not track(X,_).", 1, 1, "unsafe variables"),
    ],
)
def test_malformed_query_reports_the_position(scene, query, line, column, text):
    with pytest.raises(QueryError) as err:
        ask(scene, query)
    e = err.value
    assert isinstance(e, SensemakingError)
    assert (e.line, e.column) == (line, column)
    assert f"query:{line}:{column}" in str(e) and text in str(e)
    assert "<string>" not in str(e) and "<block>" not in str(e)


@pytest.mark.parametrize(
    "query,usage",
    [
        ("reappeared", "reappeared TRACK"),
        ("reappeared x", "reappeared TRACK"),
        ("in-front", "in-front FRAME"),
        ("tracks 3", "tracks"),
    ],
)
def test_named_question_misuse(scene, query, usage):
    with pytest.raises(QueryError, match=f"usage: {usage}"):
        ask(scene, query)


def test_empty_query_and_aliases(scene):
    with pytest.raises(QueryError, match="empty query"):
        ask(scene, "   ")
    assert ask(scene, "why_ended 3").lines == ask(scene, "why-ended 3").lines
    assert set(NAMED_QUESTIONS) == {
        "tracks",
        "events",
        "hidden",
        "reappeared",
        "in-front",
        "why-ended",
        "story",
        "warnings",
        "why",
    }


def test_warnings_question_replays_the_monitor(scene):
    got = lines(scene, "warnings")
    assert any("HIDDEN_ENTITY" in x and "track 1 (cyclist)" in x for x in got)
    assert got[0].startswith("[0] BLOCKED_LANE: BLOCKED_LANE not checked")


def test_scene_without_image_size():
    from test_scene_helpers import build_results

    from sensemaking.scene import SceneRecorder

    rec = SceneRecorder()
    for r in build_results(cyclist_behind_turning_car()):
        rec.add(r)
    s = rec.scene()
    assert lines(s, "in-front 3") == [
        "this scene has no image size, so the ego corridor is unknown"
    ]
    assert lines(s, "warnings") == [
        "this scene has no image size, so situations cannot be checked"
    ]
    assert explain(s, 1)[0].startswith(
        "Track 1 (cyclist) is in view from the first frame (0), at x=454"
    )
