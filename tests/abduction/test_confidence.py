"""How sure a hiding is: ``confidence.lp`` (tiny programs) and its use after a frame's optimum."""

from __future__ import annotations

import clingo
import numpy as np
import pytest
from helpers import problem

from sensemaking.abduction.components import SolverCache
from sensemaking.abduction.confidence import HideConfidence
from sensemaking.abduction.problem import FrameProblem
from sensemaking.abduction.solver import AbductionSolver, Answer, Det, load_encoding
from sensemaking.classes import CLASS_IDS
from sensemaking.detections import Detections
from sensemaking.errors import InputError
from sensemaking.tracker import Tracker, TrackerConfig

PROGRAM = load_encoding("confidence.lp")


def shown(facts: str, consts: dict[str, int] | None = None, program: str = PROGRAM) -> list[str]:
    """The sorted shown atoms of the program with ``facts`` (one answer set)."""
    ctl = clingo.Control(["--warn=none"] + [f"-c{k}={v}" for k, v in (consts or {}).items()])
    ctl.add("base", [], program + "\n" + facts)
    ctl.ground([("base", [])])
    out: list[list[str]] = []
    ctl.solve(on_model=lambda m: out.append(sorted(str(s) for s in m.symbols(shown=True))))
    assert len(out) == 1
    return out[0]


def hiding(share: int, depth: int = 1000, late: bool = False) -> str:
    name = "may_hide_behind" if late else "hides_behind"
    return (
        f"hide(1,2). said_hide({name}(1,2),1,2). occluder_share(1,2,{share}). "
        f"occluder_depth(1,2,{depth})." + (" late_hide(1,2)." if late else "")
    )


# ---- the rules, as tiny programs ----------------------------------------------------------
def test_confidence_is_the_occluders_cover_share():
    assert shown(hiding(750)) == ["confidence(hides_behind(1,2),750)"]


def test_late_hiding_weighs_late_confidence():
    assert shown(hiding(750, late=True)) == ["confidence(may_hide_behind(1,2),375)"]
    late = shown(hiding(750, late=True), {"late_confidence": 300})
    assert late == ["confidence(may_hide_behind(1,2),225)"]  # 750 x 300 / 1000


def test_unclear_depth_order_weighs_depth_confidence():
    assert shown(hiding(1000, depth=0)) == ["confidence(hides_behind(1,2),500)"]
    assert shown(hiding(1000, depth=0), {"depth_confidence": 800}) == [
        "confidence(hides_behind(1,2),800)"
    ]
    assert shown(hiding(1000, depth=100), {"depth_clear": 100}) == [
        "confidence(hides_behind(1,2),1000)"
    ]


def test_no_hiding_no_confidence():
    assert shown("occluder_share(1,2,750). occluder_depth(1,2,1000).") == []


# ---- after the frame's optimum ------------------------------------------------------------
def _problem(share: float, clear: float, halted: bool = False) -> FrameProblem:
    """Track 5 unobserved now (``halted``: already last frame); track 6 takes detection 0,
    which covers ``share`` of 5's predicted box and stands in front (``clear``: 1 or 0)."""
    return problem(
        [5, 6],
        1,
        active=[not halted, True],
        cand=[[1, 0, 900]],
        covers=[[0, 0]],
        covers_exact=[share],
        covers_margin=[clear],
    )


@pytest.mark.parametrize(
    ("share", "clear", "halted", "event", "level"),
    [
        (0.8, 1.0, False, "hides_behind", 750),  # quarters, rounded down
        (0.8, 0.0, False, "hides_behind", 375),
        (1.0, 1.0, True, "may_hide_behind", 500),
        (0.6, 0.0, True, "may_hide_behind", 125),
    ],
)
def test_levels_read_the_problem_the_frame_was_solved_with(share, clear, halted, event, level):
    problem = _problem(share, clear, halted)
    solver = AbductionSolver()
    answer = solver.solve(problem)
    assert answer is not None and (event, (5, 6)) in answer.events
    assert answer.confidence == []  # tracking.lp says no confidence any more
    # the tracker's frame facts no longer carry the numbers the confidence reads
    uses = Tracker().solver.solver.uses
    assert not {s.name for s in problem.whole()[0].facts(uses)} & {"cover_share", "cover_depth"}
    conf = HideConfidence()
    assert conf.levels(problem, answer) == {(event, (5, 6)): level}


def test_a_started_occluder_is_seen_as_its_own_detection():
    conf = HideConfidence()
    problem = _problem(1.0, 0.0)
    answer = Answer(halt=[5], events=[("hides_behind", (5, Det(0)))], start=[0])
    assert conf.levels(problem, answer) == {("hides_behind", (5, Det(0))): 500}


def test_each_distinct_hiding_is_solved_once():
    conf = HideConfidence()
    for _ in range(3):
        assert conf.level("hides_behind", False, ((750, 1000),)) == 750
        assert conf.level("hides_behind", True, ((750, 1000),)) == 375
    assert conf.calls == 2


def test_an_edited_rule_changes_the_confidence():
    edited = PROGRAM.replace(
        "C = #max { S * W / 1000 : occluder_share(T,O,S), depth_weight(T,O,W) }",
        "C = #min { S * W / 2000 : occluder_share(T,O,S), depth_weight(T,O,W) }",
    )
    assert edited != PROGRAM
    assert HideConfidence(program=edited).level("hides_behind", False, ((750, 1000),)) == 375
    # a program that fails to ground on the facts is an input error, not a traceback
    broken = "#show confidence(E,C) : said_hide(E,T,O), C = 1 / X."
    with pytest.raises(InputError):
        HideConfidence(program=broken).level("hides_behind", False, ((750, 1000),))


# ---- in the tracker ------------------------------------------------------------------------
CAR = CLASS_IDS["car"]


def _hiding_events(
    tracker: Tracker | None = None, **kwargs
) -> list[tuple[int, str, tuple, float | None]]:
    """A car that a nearer car (lower box bottom) drives in front of and covers: it hides."""
    t = tracker or Tracker(TrackerConfig(fps=10, image_size=(1242, 375)), **kwargs)
    far = [600.0, 120.0, 840.0, 300.0]
    out = []
    for f in range(8):
        near = [200.0 + 60 * f, 110.0, 440.0 + 60 * f, 320.0]
        boxes = [near] if f >= 6 else [far, near]
        dets = Detections(np.array(boxes), confidence=0.9, class_id=CAR)
        out += [(f, e.name, e.args, e.confidence) for e in t.update(dets, frame=f).events]
    return [e for e in out if e[1] in ("hides_behind", "may_hide_behind")]


def test_the_tracker_reports_the_confidence_of_its_confidence_rules(tmp_path):
    packaged = _hiding_events()
    assert packaged and all(c is not None and 0 < c <= 1 for *_, c in packaged)
    rules = tmp_path / "halved.lp"
    rules.write_text(
        PROGRAM.replace("C = #max { S * W / 1000 :", "C = #max { S * W / 2000 :"),
        encoding="utf-8",
    )
    halved = _hiding_events(confidence=rules)
    assert [e[:3] for e in halved] == [e[:3] for e in packaged]  # the same events
    assert all(abs(h[3] - p[3] / 2) <= 0.001 for h, p in zip(halved, packaged, strict=True))


def test_shares_are_facts_where_the_evidence_constants_read_them():
    assert "cover_depth" not in AbductionSolver().uses  # tracking.lp does not read it
    assert "cover_share" not in Tracker().solver.solver.uses  # every share admitted
    assert "cover_share" in Tracker(hide_sure_cover=0.5).solver.solver.uses
    assert "cover_share" in Tracker(late_hide_cover=0.5).solver.solver.uses
    assert "cover_share" not in Tracker(late_hides=False).solver.solver.uses
    reads = "occurs(wide(T)) :- cover_share(_,T,S), S > 500."
    assert "cover_share" in Tracker(rules=reads).solver.solver.uses


def test_answers_from_the_cache_carry_the_same_confidence():
    cache = SolverCache()
    solved = _hiding_events(solver_cache=cache)
    tracker = Tracker(TrackerConfig(fps=10, image_size=(1242, 375)), solver_cache=cache)
    again = _hiding_events(solver_cache=cache, tracker=tracker)
    assert tracker.solver.stats["cache_hits"] > 0  # the second run is answered from the cache
    assert solved and again == solved  # confidence included
