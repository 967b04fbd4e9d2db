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


_THREADS = """
import sys, threading
from sensemaking import asp
from sensemaking.abduction.solver import AbductionSolver

solver = AbductionSolver()
errors = []

def build():
    for _ in range(600):
        try:
            asp.control(list(solver.options), asp.parsed(solver.program))
        except RuntimeError as exc:
            errors.append(str(exc))
            return

threads = [threading.Thread(target=build) for _ in range(4)]
for t in threads:
    t.start()
for t in threads:
    t.join()
print(len(errors), errors[:1])
sys.exit(1 if errors else 0)
"""


def test_threads_build_controls_of_one_program_at_once() -> None:
    """The slot shapes' worker and the tracker's thread build Controls of the same program at
    once: each thread adds its own parsed statements (shared ones were corrupted: "invalid ast",
    or a crash). In a child process, so that a crash is a failure, not a lost test worker."""
    import subprocess
    import sys

    done = subprocess.run(
        [sys.executable, "-c", _THREADS], capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stdout + done.stderr[-500:]
    assert asp.parsed(CHOICE) is asp.parsed(CHOICE)  # still parsed once per thread
