"""``resume_last_seen`` (issue 27, OC-SORT's observation-centric recovery): the rule of
tracking.lp on tiny programs, and the gate that writes ``at_last_seen/2``."""

from __future__ import annotations

import numpy as np
from helpers import optimal

from sensemaking.abduction.observe import frame_problem
from sensemaking.config import TrackerConfig
from sensemaking.detections import Detections
from sensemaking.track_table import TrackTable


def solve(facts: str, consts: dict[str, int] | None = None) -> list[str]:
    models = optimal(facts, consts)
    assert len(models) == 1, f"optimum not unique: {models}"
    return models[0][1]


def det(j: int, conf: int = 900) -> str:
    return f"det(d({j}),{conf}). dtype(d({j}),1). "


# a halted (missing) confirmed track 1: d(0) fits its drifted prediction weakly, d(1) fits the
# box where it was last seen well
HALTED = "track(1). halted(1). ttype(1,1). holds(in_fov(1),true,0). "
TWO = HALTED + det(0) + det(1) + "cand(1,d(0),300). cand(1,d(1),700). at_last_seen(1,d(1)). "


# ---- the rule ------------------------------------------------------------------------------
def test_a_track_is_resumed_at_its_last_seen_box_not_at_its_drifted_prediction():
    atoms = solve(TWO)
    assert "resume(1,d(1))" in atoms and "occurs(reappears(1))" in atoms
    assert "occurs(starts(d(0)))" in atoms  # the detection at the prediction is someone new


def test_the_resume_at_the_last_seen_box_costs_cost_resumes_seen_on_top():
    # resumes 100 + resumes_seen 100 + (1000 - 700) + d(0) starts (400)
    assert optimal(TWO)[0][0] == 100 + 100 + 300 + 400
    # the same pair without the evidence fact is an ordinary resume
    plain = TWO.replace("at_last_seen(1,d(1)).", "")
    assert optimal(plain)[0][0] == 100 + 300 + 400
    # dear enough, the prediction's weaker fit is the cheaper story: 1000-300+100+400 = 1200
    # against 1000-700+100+500+400 = 1300
    atoms = solve(TWO, {"cost_resumes_seen": 500})
    assert "resume(1,d(0))" in atoms and "occurs(starts(d(1)))" in atoms


def test_the_evidence_changes_nothing_but_the_cost_of_the_resume():
    # a visible track keeps its detection; the fact alone adds no action
    facts = "track(2). active(2). ttype(2,1). holds(in_fov(2),true,0). " + det(0)
    facts += "cand(2,d(0),800). at_last_seen(2,d(0)). "
    atoms = solve(facts)
    assert "assign(2,d(0))" in atoms
    assert optimal(facts)[0][0] == 1000 - 800  # assign, not resume: no resumes_seen charged


# ---- the gate --------------------------------------------------------------------------------
def _table(config: TrackerConfig, boxes: list[list[float]], unseen: list[int]) -> TrackTable:
    """Confirmed tracks seen at ``boxes`` (their last observation), then unseen for ``unseen``
    frames each (their Kalman state is set apart from the observation by the caller)."""
    t = TrackTable(config.kalman_config)
    k = len(boxes)
    t.add(
        np.arange(1, k + 1),
        np.array(boxes, dtype=float),
        np.ones(k, dtype=np.int64),
        np.full(k, 0.9),
        np.zeros(k, dtype=np.int64),
    )
    t.hits[:] = 5
    t.confirmed[:] = True
    t.unseen[:] = unseen
    return t


def _problem(config: TrackerConfig, t: TrackTable, pred: np.ndarray, dets: np.ndarray):
    d = Detections(dets, confidence=np.full(len(dets), 0.9), class_id=np.ones(len(dets), int))
    return frame_problem(t, pred, d, config, first_frame=False, speed=False)


def test_the_gate_admits_a_detection_at_the_last_seen_box_and_says_so():
    last = [100.0, 100.0, 150.0, 200.0]
    drifted = np.array([[400.0, 100.0, 450.0, 200.0]])  # far from where it went out of sight
    dets = np.array([[102.0, 100.0, 152.0, 200.0]])
    on = TrackerConfig(resume_last_seen=True)
    p = _problem(on, _table(on, [last], [8]), drifted, dets)
    assert p.cand[:, :2].tolist() == [[0, 0]] and p.cand[0, 2] >= 900
    assert p.at_last_seen.tolist() == [[0, 0]]
    off = TrackerConfig()
    p = _problem(off, _table(off, [last], [8]), drifted, dets)
    assert len(p.cand) == 0 and len(p.at_last_seen) == 0


def test_no_evidence_where_the_prediction_fits_as_well():
    last = [100.0, 100.0, 150.0, 200.0]
    pred = np.array([last])  # it stood still: prediction and last seen box agree
    on = TrackerConfig(resume_last_seen=True)
    p = _problem(on, _table(on, [last], [3]), pred, np.array([last]))
    assert p.cand[:, :2].tolist() == [[0, 0]] and len(p.at_last_seen) == 0


def test_a_detection_another_tracks_prediction_admits_is_not_taken_at_a_last_seen_box():
    last = [100.0, 100.0, 150.0, 200.0]
    # track 0 unseen, predicted far away; track 1 visible, predicted on the detection
    pred = np.array([[400.0, 100.0, 450.0, 200.0], [104.0, 100.0, 154.0, 200.0]])
    on = TrackerConfig(resume_last_seen=True)
    t = _table(on, [last, [104.0, 100.0, 154.0, 200.0]], [8, 0])
    p = _problem(on, t, pred, np.array([[102.0, 100.0, 152.0, 200.0]]))
    assert p.cand[:, :2].tolist() == [[1, 0]] and len(p.at_last_seen) == 0


# ---- the facts -------------------------------------------------------------------------------
def test_the_evidence_reaches_the_components_facts_and_a_fresh_control():
    from sensemaking.abduction.slots import SlotSolver
    from sensemaking.abduction.solver import AbductionSolver

    last = [100.0, 100.0, 150.0, 200.0]
    on = TrackerConfig(resume_last_seen=True)
    p = _problem(
        on,
        _table(on, [last], [8]),
        np.array([[400.0, 100.0, 450.0, 200.0]]),
        np.array([[102.0, 100.0, 152.0, 200.0]]),
    )
    ((component, ids, dets),) = p.components()
    assert component.at_last_seen == ((0, 0),) and ids == [1] and dets == [0]
    facts = {str(f) for f in component.facts()}
    assert "at_last_seen(0,d(0))" in facts
    slots = SlotSolver(AbductionSolver(), misses_per_cell=0)
    assert slots.solve(component) is None  # outside every slot universe
    answer = AbductionSolver().solve_facts(component.facts())
    free = AbductionSolver(constants={"cost_resumes_seen": 0}).solve_facts(component.facts())
    assert answer is not None and free is not None
    assert answer.resume == {0: 0} and free.resume == {0: 0}
    assert answer.cost is not None and free.cost is not None
    assert answer.cost - free.cost == 100  # the encoding's default cost_resumes_seen
