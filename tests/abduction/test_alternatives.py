"""``AbductionSolver.alternatives``: the next-best explanations of an event, with their costs."""

from __future__ import annotations

import numpy as np
import pytest

from sensemaking.abduction.problem import FrameProblem
from sensemaking.abduction.solver import AbductionSolver, Det, encoding_constants

C = encoding_constants()


def hiding_frame(at_border: bool = True) -> FrameProblem:
    """Track 10 (behind) is covered by the detection that continues track 11 (in front)."""
    return FrameProblem(
        track_id=np.array([10, 11]),
        active=np.array([True, True]),
        tentative=np.array([False, False]),
        expired=np.array([False, False]),
        outside=np.array([False, False]),
        at_border=np.array([at_border, False]),
        overlapped=np.array([True, False]),
        track_class=np.array([1, 1]),
        det_conf=np.array([900]),
        det_class=np.array([1]),
        det_border=np.array([False]),
        det_overlapped=np.array([False]),
        cand=np.array([[1, 0, 900]]),
        covers=np.array([[0, 0]]),
    )


def test_hiding_against_leaving_missing_and_lost_with_the_encodings_costs():
    solver = AbductionSolver()
    found = solver.alternatives(hiding_frame(), ("hides_behind", (10, 11)), k=3)
    assert found.holds and found.chosen is not None
    assert ("hides_behind", (10, 11)) in found.chosen.events
    alts = found.alternatives
    assert [a.instead for a in alts] == [
        (("end", (10,)), ("leaves_fov", (10,))),
        (("missing_detections", (10,)),),
        (("end", (10,)), ("ends", (10,))),
    ]
    assert [a.delta for a in alts] == [
        C["cost_leaves"] - C["cost_hides"],
        C["cost_missing"] - C["cost_hides"],
        C["cost_lost"] - C["cost_hides"],
    ]
    assert all(a.cost == found.chosen.cost + a.delta for a in alts)
    # what the chosen answer held about the subject and the alternative does not
    assert alts[0].rather == (("halt", (10,)), ("hides_behind", (10, 11)))
    assert alts[1].rather == (("hides_behind", (10, 11)),)


def test_costs_follow_the_solvers_constants_and_the_border():
    solver = AbductionSolver(constants={"cost_missing": 70})
    found = solver.alternatives(hiding_frame(at_border=False), ("hides_behind", (10, 11)), k=2)
    # away from the border there is no leaving; missing detections now cost 70
    assert [a.instead for a in found.alternatives][0] == (("missing_detections", (10,)),)
    assert found.alternatives[0].delta == 70 - C["cost_hides"]
    assert found.alternatives[1].delta == C["cost_lost"] - C["cost_hides"]


def test_each_alternative_is_an_answer_of_the_encoding_with_that_cost():
    component, _, _ = hiding_frame().whole()
    facts = component.facts()
    found = AbductionSolver().alternatives_facts(facts, ("hides_behind", (0, 1)), k=3)
    assert len(found.alternatives) == 3
    for alt in found.alternatives:
        # fix every shown atom of the alternative: the encoding gives exactly that cost
        fixed = []
        for atom in alt.answer.atoms():
            name = atom.split("(")[0]
            fixed.append(
                f":- not {atom}."
                if name in ("assign", "resume", "start", "end", "halt", "ignore_trk", "ignore_det")
                else f":- not occurs({atom})."
            )
        again = AbductionSolver(rules=fixed).solve_facts(facts)
        assert again is not None and again.optimal
        assert again.cost == alt.cost
        assert again.atoms() == alt.answer.atoms()


def test_new_track_alternatives_and_bad_events():
    problem = FrameProblem(
        track_id=np.zeros(0, dtype=np.int64),
        active=np.zeros(0, dtype=bool),
        tentative=np.zeros(0, dtype=bool),
        expired=np.zeros(0, dtype=bool),
        outside=np.zeros(0, dtype=bool),
        at_border=np.zeros(0, dtype=bool),
        overlapped=np.zeros(0, dtype=bool),
        track_class=np.zeros(0, dtype=np.int64),
        det_conf=np.array([900]),
        det_class=np.array([1]),
        det_border=np.array([True]),
        det_overlapped=np.array([False]),
        cand=np.zeros((0, 3), dtype=np.int64),
    )
    found = AbductionSolver().alternatives(problem, ("enters_fov", (Det(0),)), k=5)
    assert found.holds
    kinds = [a.instead for a in found.alternatives]
    assert kinds == [(("starts", (Det(0),)),), (("ignore_det", (Det(0),)),)]
    assert found.alternatives[0].delta == C["cost_appears"] - C["cost_enters"]
    assert found.alternatives[1].delta == C["cost_ignore"] * 900 // 1000 - C["cost_enters"]
    with pytest.raises(ValueError, match="does not have"):
        AbductionSolver().alternatives(problem, ("leaves_fov", (5,)))
    # an event the answer does not hold has no alternatives to it
    other = AbductionSolver().alternatives(problem, ("starts", (Det(0),)))
    assert not other.holds and other.alternatives == []


def test_the_normal_solve_is_unchanged_by_the_alternatives_api():
    solver = AbductionSolver()
    problem = hiding_frame()
    plain = solver.solve(problem)
    assert plain is not None
    found = solver.alternatives(problem, ("hides_behind", (10, 11)))
    assert found.chosen is not None
    assert found.chosen.atoms() == plain.atoms() and found.chosen.cost == plain.cost


def test_an_unseen_track_found_hiding_against_staying_unseen():
    """With late hidings said as hides_behind (by default may_hide_behind), a track already
    unseen (missing) that a visible track now covers is found to hide behind it for free; the
    alternative, staying unseen, holds nothing the chosen answer lacks."""
    problem = hiding_frame(at_border=False)
    problem.active[0] = False  # track 10 was not seen in the previous frame
    solver = AbductionSolver(constants={"late_maybe": 0})
    found = solver.alternatives(problem, ("hides_behind", (10, 11)), k=1)
    assert found.holds and found.chosen is not None
    assert "ignore_trk(10)" in found.chosen.atoms()
    (alt,) = found.alternatives
    assert alt.instead == () and alt.about == (("ignore_trk", (10,)),)
    assert alt.rather == (("hides_behind", (10, 11)),)
    assert alt.delta == C["cost_unseen"]
