"""The event vocabulary (sensemaking.vocabulary) is the encoding's: every event it names is
abduced by tracking.lp with its arity, and every event tracking.lp abduces is in it."""

from __future__ import annotations

import re
from importlib import resources

from sensemaking.abduction.problem import VISIBILITY_VALUES as PROBLEM_VISIBILITY
from sensemaking.results import VISIBILITY_VALUES, Visibility
from sensemaking.vocabulary import EVENT_NAMES, EVENTS, START_EVENTS, event_sentence


def _encoding_events() -> dict[str, int]:
    text = resources.files("sensemaking.abduction").joinpath("encodings", "tracking.lp")
    code = "\n".join(line.split("%")[0] for line in text.read_text().splitlines())
    found: dict[str, int] = {}
    for name, args in re.findall(r"occurs\((\w+)\(([^()]*)\)\)", code):
        found[name] = len(args.split(","))
    return found


def test_the_table_is_the_encodings_events():
    assert _encoding_events() == EVENT_NAMES
    assert set(START_EVENTS) <= set(EVENTS)


def test_a_sentence_names_the_subject_first_and_an_unknown_event_verbatim():
    assert event_sentence("hides_behind", ["cyclist #2", "car #1"]) == (
        "cyclist #2 hides behind car #1"
    )
    assert event_sentence("hides_behind", ["cyclist #2"]) == "hides_behind(cyclist #2)"
    assert event_sentence("stops", ["car #1"]) == "stops(car #1)"


def test_visibility_values_follow_the_enum():
    assert VISIBILITY_VALUES == tuple(v.name.lower() for v in Visibility)
    assert PROBLEM_VISIBILITY == VISIBILITY_VALUES
