"""Motion-direction consistency (``direction_weight``, issue 27; OC-SORT's observation-centric
momentum): the rule of tracking.lp on tiny programs, the numbers the gate computes, the facts
of the components and the slots, and the setting."""

from __future__ import annotations

import numpy as np
import pytest
from helpers import optimal, problem

from sensemaking.abduction.observe import headings, size_gaps
from sensemaking.abduction.problem import FrameProblem
from sensemaking.abduction.slots import SlotSolver
from sensemaking.abduction.solver import AbductionSolver
from sensemaking.config import ParameterError, TrackerConfig
from sensemaking.detections import Detections
from sensemaking.track_table import TrackTable
from sensemaking.tracker import Tracker


def active(t: int) -> str:
    return (
        f"track({t}). ttype({t},1). active({t}). holds(in_fov({t}),true,0). "
        f"holds(visibility({t}),fully_visible,0). "
    )


def det(j: int) -> str:
    return f"det(d({j}),900). dtype(d({j}),1). "


# two people crossing: their predictions fit the other's detection a little better (the swap),
# but each one's detection lies along its own motion and the other's against it
CROSSING = (
    active(1)
    + active(2)
    + det(0)
    + det(1)
    + "cand(1,d(0),600). cand(1,d(1),650). cand(2,d(0),650). cand(2,d(1),600). "
)
MOTION = "moving(1). moving(2). heading(1,d(1),4). heading(2,d(0),4). "


def answer(facts: str, consts: dict[str, int] | None = None) -> list[str]:
    models = optimal(facts, consts)
    assert len(models) == 1, f"optimum not unique: {models}"
    return models[0][1]


def test_the_direction_term_flips_a_crossing():
    swapped = answer(CROSSING + MOTION)  # direction_weight 0 (the default): off
    assert "assign(1,d(1))" in swapped and "assign(2,d(0))" in swapped
    kept = answer(CROSSING + MOTION, {"direction_weight": 200})
    assert "assign(1,d(0))" in kept and "assign(2,d(1))" in kept
    # too light to outweigh 2 x 50 of likelihood: each swapped match costs 40 x 4 / 4 = 40 more
    light = answer(CROSSING + MOTION, {"direction_weight": 40})
    assert "assign(1,d(1))" in light


def test_a_match_along_the_motion_is_cheaper_than_none_and_against_it_dearer():
    one = active(1) + det(0) + "moving(1). cand(1,d(0),400). "
    base = optimal(one)[0][0]
    # aligned (no heading fact): the unmatched alternative would pay the half weight
    assert optimal(one, {"direction_weight": 200})[0][0] == base
    # the opposite way: 200 more, and a new track (appears 400 + unmatched 1000 + half 100)
    # is still dearer than the match (1000 - 400 + 200)
    against = one + "heading(1,d(0),4). "
    assert optimal(against, {"direction_weight": 200})[0][0] == base + 200
    # past twice (1000 + missing 250 + appears 400 - 600) the track halts and the detection
    # starts a new one: the match pays the weight, leaving it unmatched half of it
    assert "assign(1,d(0))" in answer(against, {"direction_weight": 2000})
    atoms = answer(against, {"direction_weight": 2200})
    assert "halt(1)" in atoms and "start(d(0))" in atoms


def test_without_moving_facts_the_weight_changes_nothing():
    plain = CROSSING
    assert optimal(plain) == optimal(plain, {"direction_weight": 400})


# ---- the numbers of the gate -------------------------------------------------------------
def _table(trails: list[list[tuple[int, float, float]]], height: float = 100.0) -> TrackTable:
    """Tracks whose trails hold ``(frame, cx, cy)`` observations (oldest first), boxes
    ``height`` pixels tall around the last one."""
    table = TrackTable()
    last = np.array(
        [
            [cx - 20, cy - height / 2, cx + 20, cy + height / 2]
            for _, cx, cy in (trail[-1] for trail in trails)
        ]
    )
    table.add(
        np.arange(1, len(trails) + 1),
        last,
        np.ones(len(trails), dtype=np.int64),
        np.full(len(trails), 0.9),
        np.zeros(len(trails), dtype=np.int64),
    )
    for i, trail in enumerate(trails):
        for frame, cx, cy in trail:
            box = np.array([[cx - 20, cy - height / 2, cx + 20, cy + height / 2]])
            table.record(np.array([i]), frame, box)
    return table


def _dets(frame: int, centres: list[tuple[float, float]]) -> Detections:
    xyxy = np.array([[x - 20, y - 50, x + 20, y + 50] for x, y in centres], dtype=np.float64)
    n = len(centres)
    return Detections(
        xyxy=xyxy,
        confidence=np.full(n, 0.9),
        class_id=np.ones(n, dtype=np.int64),
        frame=np.full(n, frame, dtype=np.int64),
    )


def test_headings_measure_the_angle_in_eighths_of_a_turn():
    right = [(f, 100.0 + 10 * f, 200.0) for f in range(1, 5)]  # 10 px / frame to the right
    table = _table([right])
    # ahead, across (up), behind, back and down (131 degrees)
    dets = _dets(5, [(150.0, 200.0), (120.0, 100.0), (60.0, 200.0), (60.0, 270.0)])
    cand = np.array([[0, j, 500] for j in range(4)], dtype=np.int64)
    config = TrackerConfig(fps=10.0, direction_weight=200)
    moving, rows = headings(table, dets, cand, config)
    assert moving.tolist() == [True]
    # origin: the observation 3 frames back (frame 2, x = 120)
    assert rows.tolist() == [[0, 1, 2], [0, 2, 4], [0, 3, 3]]


def test_slow_or_young_tracks_have_no_direction():
    slow = [(f, 100.0 + 0.5 * f, 200.0) for f in range(1, 5)]  # 5 px / s: 0.05 heights / s
    young = [(3, 100.0, 200.0), (4, 110.0, 200.0)]  # two observations only
    fast = [(f, 100.0 + 10 * f, 200.0) for f in range(1, 5)]
    table = _table([slow, young, fast])
    config = TrackerConfig(fps=10.0, direction_weight=200)
    cand = np.array([[t, 0, 500] for t in range(3)], dtype=np.int64)
    moving, rows = headings(table, _dets(5, [(60.0, 200.0)]), cand, config)
    assert moving.tolist() == [False, False, True]
    assert rows[:, 0].tolist() == [2]
    # a lower speed threshold lets the slow one count
    loose = config.replace(direction_min_speed=0.01)
    assert headings(table, _dets(5, [(60.0, 200.0)]), cand, loose)[0].tolist()[0]


def test_a_hidden_track_is_measured_from_its_last_observation():
    right = [(f, 100.0 + 10 * f, 200.0) for f in range(1, 5)]  # last seen at frame 4, x = 140
    table = _table([right])
    config = TrackerConfig(fps=10.0, direction_weight=200)
    cand = np.array([[0, 0, 300], [0, 1, 300], [0, 2, 300]], dtype=np.int64)
    # 6 frames later: right of where it was last seen, left of it, and 10 px left of it (at
    # 0.17 heights / s: jitter, neither along nor against the motion)
    dets = _dets(10, [(200.0, 200.0), (60.0, 200.0), (130.0, 200.0)])
    _, rows = headings(table, dets, cand, config)
    assert rows.tolist() == [[0, 1, 4], [0, 2, 2]]


# ---- facts, components, slots ------------------------------------------------------------
def _problem(moving: bool = True) -> FrameProblem:
    return problem(
        [4, 7],
        2,
        cand=[[0, 0, 600], [0, 1, 650], [1, 0, 650], [1, 1, 600]],
        visibility=[0, 0],
        moving=[True, True] if moving else None,
        heading=[[0, 1, 4], [1, 0, 4]] if moving else np.zeros((0, 3), dtype=np.int64),
    )


def test_the_facts_name_moving_tracks_and_headings():
    ((component, ids, _),) = _problem().components()
    facts = {str(s) for s in component.facts()}
    assert ids == [4, 7]
    assert {"moving(0)", "moving(1)", "heading(0,d(1),4)", "heading(1,d(0),4)"} <= facts
    ((plain, _, _),) = _problem(moving=False).components()
    assert not any(str(s).startswith(("moving", "heading")) for s in plain.facts())


@pytest.mark.parametrize("weight, straight", [(0, False), (200, True)])
def test_fresh_and_slot_solves_agree(weight: int, straight: bool):
    solver = AbductionSolver(constants={"direction_weight": weight} if weight else {})
    fresh = solver.solve(_problem())
    assert fresh is not None
    assert (fresh.assign == {4: 0, 7: 1}) is straight
    slots = SlotSolver(solver, misses_per_cell=0)
    ((component, ids, rows),) = _problem().components()
    slotted = slots.solve(component)
    if weight:
        assert slotted is not None  # the headings lie in the shape's universe
        assert slotted.mapped(ids, rows).assign == fresh.assign
    else:  # off: the universe has no headings, the component goes to a fresh Control
        assert slotted is None


# ---- the tracker and the setting ---------------------------------------------------------
def test_the_tracker_keeps_trails_and_writes_headings_only_when_on():
    frames = [_dets(f, [(100.0 + 10 * f, 200.0)]) for f in range(1, 6)]
    on, off = Tracker(fps=10.0, direction_weight=200), Tracker(fps=10.0)
    for d in frames:
        on.update(d)
        off.update(d)
    trail = on.tracks.trail_frame[0]
    assert trail[-5:].tolist() == [1, 2, 3, 4, 5] and (trail[:-5] == -1).all()
    assert (off.tracks.trail_frame == -1).all()
    assert on.problem(_dets(6, [(160.0, 200.0)])).moving.tolist() == [True]
    assert off.problem(_dets(6, [(160.0, 200.0)])).moving is None
    assert "direction_weight" not in off.solver.solver.constants


@pytest.mark.parametrize(
    "changes, message",
    [
        ({"direction_weight": -1}, "direction_weight must be in"),
        ({"direction_weight": 1.5}, "direction_weight must be an integer"),
        ({"direction_weight": 100_001}, "direction_weight must be in"),
        ({"direction_min_speed": -0.1}, "direction_min_speed must be in"),
        ({"direction_min_speed": float("inf")}, "direction_min_speed must be a finite number"),
    ],
)
def test_the_settings_are_validated(changes, message):
    with pytest.raises(ParameterError, match=message):
        TrackerConfig(**changes)
    assert TrackerConfig().direction_weight == 0  # off by default


# ---- size consistency of a resume (size_weight) -----------------------------------------
def halted(t: int) -> str:
    return (
        f"track({t}). ttype({t},1). halted({t}). holds(in_fov({t}),true,0). "
        f"holds(visibility({t}),fully_visible,0). "
    )


def test_a_resume_of_another_height_costs_size_weight_and_a_new_track_wins():
    facts = halted(1) + det(0) + "cand(1,d(0),300). size_gap(1,d(0),4). "
    assert "resume(1,d(0))" in answer(facts)  # off
    # resume: 700 + resumes 100 + size 800 > start: appears 400 + unmatched 1000 + unseen 20
    # (600 is not enough: 1400 < 1420)
    assert "resume(1,d(0))" in answer(facts, {"size_weight": 600})
    atoms = answer(facts, {"size_weight": 800})
    assert "start(d(0))" in atoms and "ignore_trk(1)" in atoms
    # a quarter of the weight per tenth: a level-1 gap costs 200, the resume still wins
    one = facts.replace("size_gap(1,d(0),4)", "size_gap(1,d(0),1)")
    assert "resume(1,d(0))" in answer(one, {"size_weight": 800})
    assert optimal(one, {"size_weight": 800})[0][0] == optimal(one)[0][0] + 200


def test_size_gaps_count_tenths_for_unseen_tracks_only():
    table = _table([[(1, 100.0, 200.0)], [(1, 300.0, 200.0)]])  # both 100 px tall
    table.unseen[:] = [2, 0]  # the first unseen for two frames, the second seen last frame
    dets = Detections(
        xyxy=np.array([[80, 150, 120, 245], [80, 160, 120, 235], [280, 170, 320, 230]], float),
        confidence=np.full(3, 0.9),
        class_id=np.ones(3, dtype=np.int64),
        frame=np.full(3, 4, dtype=np.int64),
    )
    cand = np.array([[0, 0, 500], [0, 1, 500], [0, 2, 100], [1, 2, 500]], dtype=np.int64)
    rows = size_gaps(table, dets, cand)
    # 95 px: under a tenth, no row; 75 px: 2 tenths; 60 px: 4; the seen track: none
    assert rows.tolist() == [[0, 1, 2], [0, 2, 4]]
    config = TrackerConfig(size_weight=300)
    tracker = Tracker(config)
    assert tracker.solver.solver.constants["size_weight"] == 300
    assert "size_weight" not in Tracker().solver.solver.constants


def test_the_size_setting_is_validated():
    with pytest.raises(ParameterError, match="size_weight must be in"):
        TrackerConfig(size_weight=-5)
    assert TrackerConfig().size_weight == 0


def test_the_span_is_long_enough_that_a_jittering_standing_person_has_no_direction():
    assert TrackerConfig(fps=30.0).direction_span_frames == 9
    assert TrackerConfig(fps=10.0).direction_span_frames == 3
    assert TrackerConfig(fps=1000.0).direction_span_frames == 15  # the trail's length
    assert TrackerConfig(fps=1.0).direction_span_frames == 1
    # standing, its box centre jittering by 4 px (100 px tall) frame to frame, at 30 fps
    jitter = [(f, 200.0 + (4.0 if f % 2 else 0.0), 200.0) for f in range(1, 16)]
    table = _table([jitter])
    cand = np.array([[0, 0, 500]], dtype=np.int64)
    dets = _dets(16, [(200.0, 200.0)])
    config = TrackerConfig(fps=30.0, direction_weight=200)
    assert headings(table, dets, cand, config)[0].tolist() == [False]
    # over one frame the jitter reads as 1.2 heights per second
    short = config.replace(direction_span_s=1 / 30)
    assert headings(table, dets, cand, short)[0].tolist() == [True]
