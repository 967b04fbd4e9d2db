"""``class_confidence`` (issue 27): a class's own ``start_confidence`` / ``min_confidence``.
A pedestrian scoring between its own and the global thresholds starts or continues a track
only with the override; a car at the same score is gated by the global values either way;
the table is validated, set with ``--set`` and read from parameter files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sensemaking import settings
from sensemaking.abduction.components import SolverCache
from sensemaking.classes import CLASS_IDS
from sensemaking.config import ParameterError, apply_settings
from sensemaking.detections import Detections
from sensemaking.results import TrackState
from sensemaking.tracker import Tracker, TrackerConfig

PERSON, CAR = CLASS_IDS["pedestrian"], CLASS_IDS["car"]
SEEN, MISSING = int(TrackState.VISIBLE), int(TrackState.MISSING)
#: the KITTI preset's global gates; the pedestrian override lies below both
GLOBAL = {"start_confidence": 0.7, "min_confidence": 0.65}
LOW = {"pedestrian": {"start_confidence": 0.5, "min_confidence": 0.5}}


def _frame(f: int, scores: tuple[float, float]) -> Detections:
    """A pedestrian walking right at the left, a car driving right further on, at ``scores``."""
    x = 100.0 + 10.0 * f
    return Detections(
        np.array([[x, 100.0, x + 40.0, 200.0], [x + 400.0, 120.0, x + 560.0, 220.0]]),
        confidence=np.array(scores),
        class_id=np.array([PERSON, CAR]),
    )


def _run(scores: list[tuple[float, float]], **config) -> list[dict[int, int]]:
    """Per frame: class id -> the state of its output track (``TrackState``: VISIBLE, its
    detection assigned; MISSING), for the tracks output that frame."""
    cfg = TrackerConfig(fps=10, image_size=(1242, 375), **GLOBAL, **config)
    tracker = Tracker(cfg, solver_cache=SolverCache())
    out = []
    for f, s in enumerate(scores):
        t = tracker.update(_frame(f, s), frame=f).tracks
        out.append(dict(zip(t.class_id.tolist(), t.data["state"].tolist(), strict=True)))
    return out


@pytest.mark.parametrize("override", [False, True])
def test_a_pedestrian_between_the_thresholds_starts_a_track_only_with_the_override(override):
    scores = [(0.55, 0.55)] * 5
    out = _run(scores, class_confidence=LOW if override else {})
    # the car never starts (0.55 < the global 0.7); the pedestrian only under its own 0.5
    assert out == ([{PERSON: SEEN}] * 5 if override else [{}] * 5)


@pytest.mark.parametrize("override", [False, True])
def test_a_pedestrian_between_the_thresholds_continues_its_track_only_with_the_override(
    override,
):
    scores = [(0.9, 0.9)] * 3 + [(0.55, 0.55)] * 3
    out = _run(scores, class_confidence=LOW if override else {})
    assert out[:3] == [{PERSON: SEEN, CAR: SEEN}] * 3
    # the car is missing (its 0.55 is below the global 0.65) with the override as without
    assert [o[CAR] for o in out[3:]] == [MISSING] * 3
    assert [o[PERSON] for o in out[3:]] == ([SEEN] * 3 if override else [MISSING] * 3)


def test_without_overrides_the_gates_are_the_global_scalars():
    cfg = TrackerConfig(**GLOBAL)
    assert cfg.class_gates(np.array([PERSON, CAR])) == (0.65, 0.7)
    low, start = TrackerConfig(
        **GLOBAL, class_confidence={"Pedestrian": {"min_confidence": 0.4}}
    ).class_gates(np.array([PERSON, CAR, PERSON]))
    # a threshold the class does not name is the global one
    assert low.tolist() == [0.4, 0.65, 0.4] and start.tolist() == [0.7, 0.7, 0.7]


def test_class_names_are_canonical_and_the_table_is_a_copy():
    table = {"Pedestrian": {"min_confidence": 0.5}}
    cfg = TrackerConfig(class_confidence=table)
    assert cfg.class_confidence == {"pedestrian": {"min_confidence": 0.5}}
    table["Pedestrian"]["min_confidence"] = 0.1
    assert cfg.class_confidence["pedestrian"]["min_confidence"] == 0.5


@pytest.mark.parametrize(
    "value, message",
    [
        ({"dog": {"min_confidence": 0.5}}, "class_confidence: unknown class 'dog'"),
        ({"car": {"max_confidence": 0.5}}, "unknown parameter 'class_confidence.car.max_conf"),
        ({"car": {}}, "class_confidence.car must be a table naming"),
        ({"car": 0.5}, "class_confidence.car must be a table naming"),
        ({"car": {"min_confidence": "high"}}, "class_confidence.car.min_confidence must be a fi"),
        ({"car": {"min_confidence": float("nan")}}, "class_confidence.car.min_confidence must"),
        ({"car": {"min_confidence": True}}, "class_confidence.car.min_confidence must be a fin"),
        ([("car", 0.5)], "class_confidence must be a table of class name"),
    ],
)
def test_bad_tables_are_errors_naming_the_class_and_threshold(value, message):
    with pytest.raises(ParameterError) as err:
        TrackerConfig(class_confidence=value)
    assert message in str(err.value)


def test_set_reaches_one_threshold_of_one_class_over_the_preset():
    base = TrackerConfig.for_dataset("kitti")
    cfg = settings.load_config(
        None, "kitti", overrides=["class_confidence.pedestrian.min_confidence=0.45"]
    )
    assert cfg.class_confidence == {"pedestrian": {"min_confidence": 0.45}}
    assert cfg.replace(class_confidence=base.class_confidence) == base
    both = settings.load_config(
        None,
        "kitti",
        overrides=[
            "class_confidence.pedestrian.min_confidence=0.45",
            "class_confidence.pedestrian.start_confidence=0.5",
            "class_confidence.cyclist.start_confidence=0.6",
        ],
    )
    assert both.class_confidence == {
        "cyclist": {"start_confidence": 0.6},
        "pedestrian": {"min_confidence": 0.45, "start_confidence": 0.5},
    }
    # a later dotted key changes one threshold and keeps the rest of the table
    more = apply_settings(both, {"class_confidence.pedestrian.min_confidence": 0.3})
    assert more.class_confidence["pedestrian"] == {"min_confidence": 0.3, "start_confidence": 0.5}
    assert more.class_confidence["cyclist"] == {"start_confidence": 0.6}
    cleared = settings.load_config(None, "kitti", overrides=["class_confidence={}"])
    assert cleared.class_confidence == {}
    table = settings.load_config(
        None, "kitti", overrides=['class_confidence={"pedestrian": {"min_confidence": 0.4}}']
    )
    assert table.class_confidence == {"pedestrian": {"min_confidence": 0.4}}


@pytest.mark.parametrize(
    "item, message",
    [
        ("class_confidence.dog.min_confidence=0.5", "unknown class 'dog'"),
        ("class_confidence.pedestrian.min=0.5", "a class may set start_confidence or min_conf"),
        ("class_confidence.pedestrian=0.5", "class_confidence.CLASS.THRESHOLD"),
        ("class_confidence.pedestrian.min_confidence=high", "must be a number"),
        ("class_confidence=pedestrian", "must be a JSON table"),
    ],
)
def test_bad_set_items_are_one_line_errors(item, message):
    with pytest.raises(ParameterError) as err:
        settings.load_config(None, "kitti", overrides=[item])
    assert message in str(err.value) and "\n" not in str(err.value)


def test_parameter_files_nested_or_dotted_and_written_back(tmp_path: Path):
    nested = tmp_path / "nested.json"
    nested.write_text(
        json.dumps({"params": {"class_confidence": {"pedestrian": {"min_confidence": 0.5}}}})
    )
    dotted = tmp_path / "dotted.json"
    dotted.write_text(json.dumps({"params": {"class_confidence.pedestrian.min_confidence": 0.5}}))
    a = settings.load_config(nested, "kitti")
    assert a == settings.load_config(dotted, "kitti")
    assert a.class_confidence == {"pedestrian": {"min_confidence": 0.5}}
    out = settings.write_params(tmp_path / "w.json", settings.load_params(dotted), "test")
    assert json.loads(out.read_text())["params"] == {
        "class_confidence": {"pedestrian": {"min_confidence": 0.5}}
    }
    assert settings.load_config(out, "kitti") == a
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"params": {"class_confidence": {"pedestrian": {"min": 0.5}}}}))
    with pytest.raises(ParameterError, match="bad.json"):
        settings.load_config(bad, "kitti")
