"""Reviving a track that ended a moment ago (``revive_s``, issue 27): the rules of tracking.lp
on tiny programs, the facts the problem writes, and components with ended tracks."""

from __future__ import annotations

import pytest
from helpers import optimal, problem

from sensemaking.abduction.components import ComponentSolver, SolverCache
from sensemaking.abduction.problem import FrameProblem
from sensemaking.abduction.slots import SlotSolver
from sensemaking.abduction.solver import AbductionSolver


def solve(facts: str) -> list[str]:
    models = optimal(facts)
    assert len(models) == 1, f"optimum not unique: {models}"
    return models[0][1]


def det(j: int, conf: int = 900, cls: int = 1, border: bool = False) -> str:
    at = f"det_border(d({j}))." if border else ""
    return f"det(d({j}),{conf}). dtype(d({j}),{cls}). {at}"


def gone(r: int, how: str = "leaves_fov", cls: int = 1) -> str:
    return f"gone({r},{how}). ttype({r},{cls}). "


# ---- the rule ------------------------------------------------------------------------------
def test_an_ended_track_that_left_re_enters_instead_of_a_new_track():
    facts = gone(5) + det(0, border=True) + "back(5,d(0),700)."
    assert solve(facts) == [
        "occurs(reenters_fov(5))",
        "resume(5,d(0))",  # shown as a resume: the caller revives the ended track
        "value(in_fov(5),true)",
        "value(visibility(5),fully_visible)",
    ]
    # the same detection without the ended track enters as a new track
    assert "occurs(enters_fov(d(0)))" in solve(det(0, border=True))


def test_a_lost_track_returns():
    facts = gone(2, "ends") + det(0) + "det_overlapped(d(0)). back(2,d(0),500)."
    atoms = solve(facts)
    assert "occurs(returns(2))" in atoms and "resume(2,d(0))" in atoms
    assert "value(visibility(2),partially_occluded)" in atoms
    assert not any("starts" in a or "reenters" in a for a in atoms)


def test_reviving_costs_cost_returns_so_a_new_track_at_the_border_can_be_cheaper():
    facts = gone(5) + det(0, border=True) + "back(5,d(0),700)."
    # cost_returns, plus the lowest-priority tie-break on the fit (the helper sums priorities)
    assert optimal(facts)[0][0] == 50 + (1000 - 700)
    atoms = optimal(facts, {"cost_returns": 150})[0][1]
    assert "occurs(enters_fov(d(0)))" in atoms and "resume(5,d(0))" not in atoms


@pytest.mark.parametrize(
    "facts",
    [
        gone(5) + det(0) + "back(5,d(0),50).",  # fits less than iou_resume (100)
        gone(5, cls=2) + det(0) + "back(5,d(0),700).",  # another class
        gone(5) + det(0, conf=0) + "back(5,d(0),700).",  # too weak to start a track
    ],
)
def test_the_gate_is_restated_in_the_encoding(facts):
    assert not any("resume" in a for a in solve(facts))


def test_one_detection_per_ended_track_and_the_best_fit_first():
    facts = gone(5) + gone(6) + det(0) + det(1) + "back(5,d(0),600). back(6,d(0),800)."
    atoms = solve(facts)  # d(0) revives 6 (fits better), d(1) starts
    assert "resume(6,d(0))" in atoms and "occurs(starts(d(1)))" in atoms
    assert not any(a.startswith("resume(5") for a in atoms)
    two = gone(5) + det(0) + det(1) + "back(5,d(0),600). back(5,d(1),700)."
    atoms = solve(two)
    assert "resume(5,d(1))" in atoms and "occurs(starts(d(0)))" in atoms


def test_a_live_track_keeps_its_detection():
    facts = (
        "track(1). ttype(1,1). active(1). holds(in_fov(1),true,0). "
        "holds(visibility(1),fully_visible,0). cand(1,d(0),600). "
    )
    facts += gone(5) + det(0) + "back(5,d(0),900)."
    atoms = solve(facts)
    assert "assign(1,d(0))" in atoms and not any("resume" in a for a in atoms)


# ---- the facts and the components ----------------------------------------------------------
def _problem() -> FrameProblem:
    """Two independent parts: live track 1 with d(0); ended tracks 7 (left) and 9 (lost) that
    d(1) and d(2) may revive."""
    return problem(
        [1],
        3,
        det_border=[False, True, False],
        cand=[[0, 0, 800]],
        visibility=[0],
        gone_id=[7, 9],
        gone_how=[0, 1],
        gone_class=[1, 1],
        back=[[0, 1, 700], [1, 2, 600]],
    )


def test_components_number_ended_tracks_after_the_live_ones():
    parts = _problem().components()
    assert [ids for _, ids, _ in parts] == [[1], [7], [9]]
    facts = [sorted(str(s) for s in c.facts()) for c, _, _ in parts]
    assert "gone(0,leaves_fov)" in facts[1] and "back(0,d(0),700)" in facts[1]
    assert "gone(0,ends)" in facts[2] and not any("track(" in f for f in facts[2])
    whole, ids, _ = _problem().whole()
    assert ids == [1, 7, 9] and whole.n_refs == 3


def test_solved_apart_or_together_the_answer_is_the_whole_frames():
    whole = AbductionSolver().solve(_problem())
    assert whole is not None
    assert whole.resume == {7: 1, 9: 2} and whole.assign == {1: 0}
    assert ("reenters_fov", (7,)) in whole.events and ("returns", (9,)) in whole.events
    # no slots: the parts are solved together in one program (numbered apart by n_refs)
    together = ComponentSolver(AbductionSolver(), slots=False, cache=SolverCache())
    answer = together.solve(_problem())
    assert answer is not None and answer.atoms() == whole.atoms()


def test_the_slots_leave_components_with_ended_tracks_to_a_fresh_control():
    slots = SlotSolver(AbductionSolver(), misses_per_cell=0)
    component = _problem().components()[1][0]
    assert slots.solve(component) is None
    plain = _problem().components()[0][0]
    assert slots.solve(plain) is not None
