"""The tracker's frame made cheaper without changing its answers (issue 23): a frame's
components as plain field tuples, the last model read once."""

from __future__ import annotations

import random

import clingo
import pytest

from sensemaking import asp
from sensemaking.abduction import slots as slots_module
from sensemaking.abduction.components import SolverCache
from sensemaking.abduction.problem import Component, FrameProblem
from sensemaking.config import AbductionCosts
from sensemaking.synthetic import make_scene
from sensemaking.tracker import Tracker, TrackerConfig

SCENE = make_scene(30, n_frames=60, overlap=0.6, miss_rate=0.1, false_positive_rate=0.05, seed=4)
# a cost no other test uses: a program (and so a cache key) of this module's own
CONFIG = TrackerConfig(
    fps=SCENE.fps, image_size=(SCENE.width, SCENE.height), costs=AbductionCosts(ignore=603)
)


def _problems(n: int = 60) -> list[FrameProblem]:
    tracker = Tracker(CONFIG, solver_cache=SolverCache())
    out = []
    for f, d in list(SCENE.frames())[:n]:
        _, _, problem = tracker.decide(d, frame=f, keep_problem=True)
        assert problem is not None
        out.append(problem)
    return out


def _run(tracker: Tracker) -> list[tuple[int, list[int], list[list[float]], list[str]]]:
    out = []
    for f, d in SCENE.frames():
        r = tracker.update(d, frame=f)
        events = [f"{e.name}{e.args}" for e in r.events]
        out.append((f, r.tracks.tracker_id.tolist(), r.tracks.xyxy.tolist(), events))
    return out


def _global(problem: FrameProblem) -> dict[str, set[tuple]]:
    """The frame's relations in its own terms (track ids, detection rows)."""
    ids = problem.track_id.tolist()
    return {
        "cand": {(ids[t], d, lik) for t, d, lik in problem.cand.tolist()},
        "covers": {(d, ids[t]) for d, t in problem.covers.tolist()},
        "fits": {(ids[t], d) for t, d in problem.fits.tolist()},
        "keeps_covering": {(d, ids[t]) for d, t in problem.keeps_covering.tolist()},
        "hidden_by": {tuple(r) for r in problem.hidden_by.tolist()},
    }


def test_component_fields_map_back_to_the_frame_and_are_the_components() -> None:
    problems = _problems()
    assert sum(len(p.covers) for p in problems) > 0 and sum(len(p.cand) for p in problems) > 50
    for problem in problems:
        parts = problem.component_fields()
        assert [(Component(*f), i, r) for f, i, r in parts] == problem.components()
        seen: dict[str, set[tuple]] = {k: set() for k in _global(problem)}
        tracks, dets = [], []
        for fields, track_ids, det_rows in parts:
            c = Component(*fields)
            own = track_ids[: len(c.tracks)]
            tracks += own
            dets += det_rows
            seen["cand"] |= {(track_ids[t], det_rows[d], lik) for t, d, lik, _ in c.cand}
            seen["covers"] |= {(det_rows[d], track_ids[t]) for d, t, *_ in c.covers}
            seen["fits"] |= {(track_ids[t], det_rows[d]) for t, d in c.fits}
            seen["keeps_covering"] |= {(det_rows[d], track_ids[t]) for d, t in c.keeps_covering}
            seen["hidden_by"] |= {(track_ids[t], track_ids[o]) for t, o in c.hidden_by}
            # each track's and detection's own row, in the frame's order
            index = {t: i for i, t in enumerate(problem.track_id.tolist())}
            assert [row[-3] for row in c.tracks] == [
                int(problem.track_class[index[t]]) for t in own
            ]
            assert [row[0] for row in c.dets] == [int(problem.det_conf[d]) for d in det_rows]
        # every track and detection in exactly one component, every relation row once
        assert sorted(tracks) == sorted(problem.track_id.tolist())
        assert sorted(dets) == list(range(problem.n_dets))
        assert seen == _global(problem)
        whole, ids, rows = problem.whole_fields()
        assert (Component(*whole), ids, rows) == problem.whole()


def test_a_slot_solve_that_comes_short_joins_the_fresh_program(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A slot search cut by the conflict budget leaves its component to the frame's fresh
    program: every component is still answered, and the tracks are those of a run whose slot
    searches all complete (on this scene; where optima tie the two paths may differ)."""
    run = slots_module._Grounded.solve
    calls = {"n": 0, "short": 0}

    def short(self, true, budget_ms):  # type: ignore[no-untyped-def]
        calls["n"] += 1
        if calls["n"] % 3 == 0:
            calls["short"] += 1
            return None
        return run(self, true, budget_ms)

    monkeypatch.setattr(slots_module._Grounded, "solve", short)
    cut = Tracker(CONFIG, solver_cache=SolverCache())
    mine = _run(cut)
    assert calls["short"] > 0 and cut.solver.stats["slot_calls"] > 0
    monkeypatch.undo()
    plain = Tracker(CONFIG, solver_cache=SolverCache())
    assert mine == _run(plain)


def _program(rng: random.Random) -> str:
    """A small optimisation program with several models on the way to the optimum."""
    n = rng.randint(4, 9)
    weights = " ".join(f"w({i},{rng.randint(1, 9)})." for i in range(n))
    return (
        f"{weights} {{ p(I) : w(I,_) }}. :- #count {{ I : p(I) }} < {n // 2}."
        " :~ p(I), w(I,W). [W@1,I] :~ not p(I), w(I,W). [1@0,I] #show p/1."
    )


def test_the_last_model_is_the_one_the_model_callback_saw_last() -> None:
    rng = random.Random(8)
    for _ in range(20):
        text = _program(rng)
        answers = []
        for budget in (None, 60_000.0):  # without a budget: on_last; with one: on_model
            ctl = clingo.Control(["--opt-strategy=bb", "--warn=none"])
            ctl.add("base", [], text)
            ctl.ground([("base", [])])
            solved = asp.solve(ctl, budget)
            assert solved is not None
            answers.append((sorted(map(str, solved.symbols)), solved.cost, solved.exhausted))
        assert answers[0] == answers[1]
    # no model: None, as before
    ctl = clingo.Control(["--warn=none"])
    ctl.add("base", [], "a. :- a.")
    ctl.ground([("base", [])])
    assert asp.solve(ctl) is None
