"""The clingo call pattern of sensemaking.asp on tiny programs."""

from __future__ import annotations

from clingo import Function, Number

from sensemaking import asp

CHOICE = """
#const cost = 3.
{ pick(X) : item(X) } = 1.
:~ pick(X), weight(X, W). [W@1, X]
#show pick/1.
"""


def _ground(facts):
    ctl = asp.control(asp.limits(max_conflicts=1000), asp.parsed(CHOICE), facts)
    ctl.ground([("base", [])])
    return ctl


def _facts(weights: dict[int, int]):
    out = []
    for x, w in weights.items():
        out += [Function("item", [Number(x)]), Function("weight", [Number(x), Number(w)])]
    return out


def test_solve_keeps_the_optimal_model_and_its_cost():
    solved = asp.solve(_ground(_facts({1: 5, 2: 2, 3: 9})))
    assert solved is not None and solved.exhausted and not solved.timed_out
    assert [str(s) for s in solved.symbols] == ["pick(2)"] and solved.cost == 2


def test_solve_without_a_model_is_none():
    assert asp.solve(_ground([])) is None  # nothing to pick: unsatisfiable


def test_forbid_removes_an_answer():
    ctl = _ground(_facts({1: 5, 2: 2}))
    asp.forbid(ctl, [[Function("pick", [Number(2)])]])
    solved = asp.solve(ctl, budget_ms=10_000.0)
    assert solved is not None and [str(s) for s in solved.symbols] == ["pick(1)"]


def test_models_enumerates_or_stops_at_the_first():
    ctl = asp.control(["--models=0"], asp.parsed("{ a; b }. #show a/0. #show b/0."))
    ctl.ground([("base", [])])
    every, sat = asp.models(ctl)
    assert sat and len(every) == 4
    one, sat = asp.models(ctl, first=True)
    assert sat and len(one) == 1


def test_program_facts_helpers():
    assert asp.constants(CHOICE) == (("cost", 3),)
    assert {"pick", "item", "weight"} <= asp.mentioned(CHOICE)
    assert asp.parse_messages(CHOICE) is None and asp.parse_messages("a :-") is not None
    assert asp.limits(max_conflicts=5, max_models=0) == ["--models=0", "--solve-limit=5"]
    assert "#show" in asp.encoding("sensemaking.abduction", "tracking.lp")
