"""``resume_last_seen`` (issue 27): an object that stops while unseen is found again where it
was last seen, under its own id; off, nothing changes; the setting is validated."""

from __future__ import annotations

import numpy as np
import pytest

from sensemaking.abduction.components import SolverCache
from sensemaking.classes import CLASS_IDS
from sensemaking.config import ParameterError, apply_settings
from sensemaking.detections import Detections
from sensemaking.tracker import Tracker, TrackerConfig

PERSON = CLASS_IDS["pedestrian"]


def _person(x: float) -> Detections:
    return Detections(np.array([[x, 100.0, x + 40.0, 200.0]]), confidence=0.9, class_id=PERSON)


def _run(xs: list[float | None], **config) -> list[list[int]]:
    """Ids output per frame of a scripted single-person scene (x of the box's left edge)."""
    cfg = TrackerConfig(fps=10, image_size=(1000, 400), max_missing_s=2.0, **config)
    tracker = Tracker(cfg, solver_cache=SolverCache())
    out = []
    for f, x in enumerate(xs):
        r = tracker.update(Detections.empty() if x is None else _person(x), frame=f)
        out.append(r.tracks.tracker_id.tolist())
    return out


def _stops_unseen() -> list[float | None]:
    """Walks 12 px a frame to the right, unseen 8 frames, seen again where it was last seen
    (it stopped): its prediction has run ~100 px on, more than twice its width."""
    walk: list[float | None] = [100.0 + 12.0 * f for f in range(10)]
    last = walk[-1]
    return walk + [None] * 8 + [last] * 5


@pytest.mark.parametrize("on", [False, True])
def test_a_person_who_stopped_while_unseen_keeps_the_id_with_the_setting(on):
    ids = _run(_stops_unseen(), resume_last_seen=on)
    assert all(i == [1] for i in ids[:18])  # unseen tracks are output at their prediction
    # found again at its last seen box, or a new track there beside the drifting old one
    assert all(i == ([1] if on else [1, 2]) for i in ids[18:])


def test_a_person_who_walked_on_is_found_at_the_prediction_either_way():
    xs: list[float | None] = [100.0 + 12.0 * f for f in range(10)]
    xs += [None] * 3 + [100.0 + 12.0 * f for f in range(13, 18)]
    assert _run(xs, resume_last_seen=True) == _run(xs)


@pytest.mark.parametrize(
    "key, value",
    [
        ("resume_last_seen", 1),
        ("resume_last_seen", "yes"),
        ("costs.resumes_seen", -1),
        ("costs.resumes_seen", 0.5),
        ("costs.resumes_seen", 100_001),
    ],
)
def test_the_setting_is_validated(key, value):
    with pytest.raises(ParameterError, match=key.replace(".", r"\.")):
        apply_settings(TrackerConfig(), {key: value})


def test_the_cost_reaches_the_solver_only_with_the_setting():
    off = Tracker(TrackerConfig(), solver_cache=SolverCache())
    assert "cost_resumes_seen" not in off.solver.solver.constants
    on = Tracker(
        apply_settings(TrackerConfig(), {"resume_last_seen": True, "costs.resumes_seen": 250}),
        solver_cache=SolverCache(),
    )
    assert on.solver.solver.constants["cost_resumes_seen"] == 250
