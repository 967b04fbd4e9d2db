"""The ground-once slot solver gives optimal answers of the same facts at the same cost."""

from __future__ import annotations

import random

import clingo
import numpy as np
import pytest
from clingo.ast import ProgramBuilder
from conftest import SHARED_DATA

from sensemaking.abduction.components import ComponentSolver
from sensemaking.abduction.observe import quantize
from sensemaking.abduction.problem import TRACK_FLAGS, Component, FrameProblem
from sensemaking.abduction.slots import Shape, SlotSolver, piece_facts, pieces, shape_of
from sensemaking.abduction.solver import AbductionSolver, Answer
from sensemaking.asp import parsed

GRID = [k * 1000 // 40 for k in range(41)]


def random_component(
    rng: random.Random, nt: int, nd: int, no: int, classes: tuple[int, ...] = (1, 2)
) -> Component:
    """Facts on the likelihood grid; relations drawn at random (not all of them physical)."""
    tracks = tuple(
        (
            rng.random() < 0.6,
            *[rng.random() < 0.2 for _ in TRACK_FLAGS],
            rng.choice(classes),
            rng.randrange(3),
            -1,
        )
        for _ in range(nt)
    )
    dets = tuple(
        (rng.choice(GRID + [1]), rng.choice(classes), rng.random() < 0.3, rng.random() < 0.3)
        for _ in range(nd)
    )
    pairs = [(t, d) for t in range(nt) for d in range(nd)]
    cand = tuple(
        (t, d, rng.choice(GRID), rng.random() < 0.4) for t, d in pairs if rng.random() < 0.7
    )
    covers = []
    for t in range(nt):
        ds = [d for d in range(nd) if rng.random() < 0.3]
        covers += [
            (d, t, r if len(ds) > 1 else -1, rng.choice((500, 750, 1000)), rng.choice((0, 1000)))
            for r, d in enumerate(ds)
        ]
    hidden = tuple((t, rng.randrange(nt + no)) for t in range(nt) if rng.random() < 0.4)
    if no and nt and not any(o >= nt for _, o in hidden):
        hidden += ((0, nt + no - 1),)
    fits = tuple((t, d) for d, t, *_ in covers if rng.random() < 0.5)  # a subset of covers
    return Component(
        rng.random() < 0.1,
        tracks,
        dets,
        cand,
        tuple(covers),
        tuple((d, t) for t, d in pairs if rng.random() < 0.3),
        tuple((d, t) for t, d in pairs if rng.random() < 0.3),
        hidden,
        fits,
    )


def optimal_answers(solver: AbductionSolver, component: Component) -> set[tuple[str, ...]]:
    """Every optimal answer's shown atoms (clingo's ``--opt-mode=optN`` on a fresh Control)."""
    ctl = clingo.Control([*solver.options, "--opt-mode=optN", "-n0"])
    with ProgramBuilder(ctl) as builder:
        for statement in parsed(solver.program):
            builder.add(statement)
    with ctl.backend() as backend:
        for fact in component.facts(solver.uses):
            backend.add_rule([backend.add_atom(fact)])
    ctl.ground([("base", [])])
    found: set[tuple[str, ...]] = set()

    def on_model(model: clingo.Model) -> None:
        if model.optimality_proven:
            found.add(tuple(sorted(map(str, model.symbols(shown=True)))))

    ctl.solve(on_model=on_model)
    return found


def readable(answer: Answer) -> tuple[list[str], list[str]]:
    return answer.atoms(), sorted(map(str, answer.fluents))


def check_same_optimum(
    solver: AbductionSolver, slots: SlotSolver, components: list[Component]
) -> dict[str, int]:
    """Slot answer vs fresh solve: same cost always, same atoms where the optimum is unique."""
    counts = {"answered": 0, "same": 0, "ties_broken_otherwise": 0}
    for component in components:
        mine = slots.solve(component)
        fresh = solver.solve_facts(component.facts(solver.uses))
        assert fresh is not None and fresh.optimal
        if mine is None:
            continue
        counts["answered"] += 1
        assert mine.optimal and mine.cost == fresh.cost, component
        if readable(mine) == readable(fresh):
            counts["same"] += 1
            continue
        assert len(optimal_answers(solver, component)) > 1, component
        counts["ties_broken_otherwise"] += 1
    return counts


def test_pieces_write_the_facts_of_the_component() -> None:
    rng = random.Random(3)
    for _ in range(300):
        component = random_component(rng, rng.randint(0, 4), rng.randint(0, 4), rng.randint(0, 2))
        union: set[clingo.Symbol] = set()
        for piece in pieces(component):
            union |= piece_facts(piece, ("speed",))
        assert union == set(component.facts(("speed",)))


def test_random_components_same_cost_and_unique_optima_same_atoms() -> None:
    solver = AbductionSolver()
    slots = SlotSolver(solver, numbers=GRID + [1], max_tracks=3, max_dets=3, misses_per_cell=0)
    rng = random.Random(1)
    components = [
        random_component(rng, rng.randint(1, 3), rng.randint(1, 3), rng.randint(0, 2))
        for _ in range(150)
    ]
    counts = check_same_optimum(solver, slots, components)
    assert counts["answered"] == len(components)
    assert counts["same"] >= 0.9 * len(components)


def test_answers_do_not_depend_on_what_was_solved_before() -> None:
    solver = AbductionSolver()
    rng = random.Random(11)
    components = [
        random_component(rng, rng.randint(1, 3), rng.randint(1, 3), 0, classes=(1,))
        for _ in range(120)
    ]
    first = SlotSolver(solver, numbers=GRID + [1], misses_per_cell=0)
    second = SlotSolver(solver, numbers=GRID + [1], misses_per_cell=0)
    before = {c: readable(first.solve(c)) for c in components}
    shuffled = list(reversed(components))
    assert all(readable(second.solve(c)) == before[c] for c in shuffled)


def test_outside_the_slots_goes_to_the_fresh_control() -> None:
    solver = AbductionSolver()
    slots = SlotSolver(solver, numbers=GRID, max_tracks=2, max_dets=2, misses_per_cell=0)
    rng = random.Random(5)
    assert slots.solve(random_component(rng, 3, 1, 0)) is None  # shape too large
    small = random_component(rng, 1, 1, 0, classes=(1,))
    assert slots.solve(small) is not None and slots.stats["grounded"] == 1
    # a class not seen yet: the shape is ground again with it, then answered
    other = random_component(rng, 1, 1, 0, classes=(7,))
    answer = slots.solve(other)
    assert answer is not None and slots.stats["grounded"] == 2 and 7 in slots.classes
    assert answer.cost == solver.solve_facts(other.facts(solver.uses)).cost
    # facts outside the vocabulary of the universe (speed/2, read by a user's rule)
    user = AbductionSolver(rules=["occurs(stops(T)) :- track(T), speed(T,S), S < 5."])
    moving = Component(
        False, ((True, *[False] * len(TRACK_FLAGS), 1, 0, 3),), (), (), (), (), (), ()
    )
    assert SlotSolver(user, numbers=GRID, misses_per_cell=0).solve(moving) is None


def test_a_shape_ground_ahead_takes_the_same_path_with_the_same_answers() -> None:
    solver = AbductionSolver()
    rng = random.Random(5)
    pool = [random_component(rng, 2, 2, 0, classes=(1,)) for _ in range(12)]
    # a 2 x 2 shape is due at its 5th component; ahead, its grounding starts at the 3rd
    now = SlotSolver(solver, numbers=GRID + [1], misses_per_cell=0.5)
    ahead = SlotSolver(solver, numbers=GRID + [1], misses_per_cell=0.5, lead=0.5)
    for i, component in enumerate(pool):
        mine, theirs = ahead.solve(component), now.solve(component)
        assert (mine is None) == (theirs is None) == (i < 4)
        assert (ahead.stats["grounded"], bool(ahead._pending)) == (
            now.stats["grounded"],
            2 <= i < 4,
        )
        if mine is not None and theirs is not None:
            assert (mine.cost, mine.atoms()) == (theirs.cost, theirs.atoms())
    assert ahead.stats["ahead"] == 1


def test_a_grounding_ahead_with_other_values_is_not_taken() -> None:
    solver = AbductionSolver()
    rng = random.Random(6)
    first, second = random_component(rng, 1, 1, 0), random_component(rng, 1, 1, 0)
    # no numbers expected: each component brings its own, so the one ground ahead (with the
    # first's) is not the one the second is due with (with both): it is ground again at once
    ahead = SlotSolver(solver, misses_per_cell=0.5, lead=0.5)  # 1 x 1: due at the 3rd
    assert ahead.solve(first) is None and ahead.solve(first) is None and ahead._pending
    if ahead._values(second)[1] <= ahead._values(first)[1]:
        pytest.skip("the second component brings no new number")
    answer = ahead.solve(second)
    assert answer is not None and ahead.stats["ahead"] == 0 and not ahead._pending
    fresh = solver.solve_facts(second.facts())
    assert fresh is not None and answer.cost == fresh.cost


def test_a_shape_is_ground_once_met_often_enough() -> None:
    solver = AbductionSolver()
    slots = SlotSolver(solver, numbers=GRID, misses_per_cell=0.5)  # 1 x 1: 4 cells, 2 misses
    component = random_component(random.Random(2), 1, 1, 0)
    assert shape_of(component) == Shape(1, 1, 0)
    assert slots.solve(component) is None and slots.solve(component) is None
    assert slots.stats["grounded"] == 0
    assert slots.solve(component) is not None and slots.stats["grounded"] == 1


def test_component_solver_answers_misses_from_the_slots() -> None:
    solver = AbductionSolver()
    problem = FrameProblem(
        track_id=np.array([4, 9]),
        active=np.array([True, True]),
        tentative=np.zeros(2, bool),
        expired=np.zeros(2, bool),
        outside=np.zeros(2, bool),
        at_border=np.zeros(2, bool),
        overlapped=np.zeros(2, bool),
        track_class=np.array([1, 1]),
        det_conf=np.array([900, 800]),
        det_class=np.array([1, 1]),
        det_border=np.zeros(2, bool),
        det_overlapped=np.zeros(2, bool),
        cand=np.array([[0, 0, 850], [1, 1, 700], [1, 0, 400]]),
    )
    answers = []
    for slots in (True, False):
        components = ComponentSolver(solver, cache_size=0, slots=slots, numbers=GRID)
        for _ in range(6):  # a 2 x 2 shape is ground at its 5th component
            answers.append(components.solve(problem))
        assert (components.stats["slot_calls"] > 0) == slots
    assert len({(a.cost, tuple(readable(a)[0])) for a in answers}) == 1
    assert answers[0].assign == {4: 0, 9: 1}


@pytest.mark.skipif(not (SHARED_DATA / "kitti").is_dir(), reason="needs ../shared/data/kitti")
@pytest.mark.slow
def test_real_kitti_components_same_optimum() -> None:
    from sensemaking.benchmark import datasets
    from sensemaking.benchmark.runner import ours_config
    from sensemaking.detections import Detections
    from sensemaking.tracker import Tracker

    found = datasets.discover(SHARED_DATA, only=["kitti-rrc-car"])
    ((spec, sources),) = found.found
    bench = datasets.load_benchmark(spec, [s for s in sources if s.name == "0000"])
    seq = bench.sequences[0]
    tracker = Tracker(
        ours_config(spec.family, fps=seq.info.fps, image_size=(seq.info.width, seq.info.height))
    )
    seen: dict[Component, None] = {}
    solve = tracker.solver.solve

    def collect(problem: FrameProblem, budget_ms: float | None = None) -> Answer | None:
        seen.update(dict.fromkeys(c for c, _, _ in problem.components()))
        return solve(problem, budget_ms)

    tracker.solver.solve = collect  # type: ignore[method-assign]
    frames = dict(seq.detections.frames())
    for f in seq.frame_numbers:
        tracker.update(frames.get(f, Detections.empty()), frame=f)
    solver = tracker.solver.solver
    grid = quantize(tracker.config, np.linspace(0.0, 1.0, tracker.config.likelihood_levels + 1))
    slots = SlotSolver(solver, numbers=grid.tolist(), misses_per_cell=0)
    components = list(seen)
    counts = check_same_optimum(solver, slots, components)
    assert len(components) > 100 and counts["answered"] >= 0.95 * len(components)
