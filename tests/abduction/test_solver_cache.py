"""Solver caches are objects: a tracker remembers its answers where it is told to."""

from __future__ import annotations

from sensemaking.abduction.components import SHARED, SolverCache
from sensemaking.config import AbductionCosts
from sensemaking.synthetic import crossing_scene
from sensemaking.tracker import Tracker, TrackerConfig

SCENE = crossing_scene(seed=3)
# a cost no other test uses: a program (and so a cache key) of this module's own
CONFIG = TrackerConfig(
    fps=SCENE.fps, image_size=(SCENE.width, SCENE.height), costs=AbductionCosts(ignore=601)
)


def _run(tracker: Tracker) -> list[tuple[int, list[int], list[str]]]:
    out = []
    for f, d in SCENE.frames():
        r = tracker.update(d, frame=f)
        out.append((f, r.tracks.tracker_id.tolist(), [e.name for e in r.events]))
    return out


def test_a_tracker_with_its_own_cache_leaves_the_shared_one_alone():
    shared_before = len(SHARED)
    own = SolverCache()
    tracker = Tracker(CONFIG, solver_cache=own)
    results = _run(tracker)
    assert tracker.solver.cache is own
    assert len(own) > 0 and len(SHARED) == shared_before
    # a second tracker on the same cache is answered from it; the answers are the same
    again = Tracker(CONFIG, solver_cache=own)
    assert _run(again) == results
    assert again.solver.stats["cache_hits"] > tracker.solver.stats["cache_hits"]
    own.clear()
    assert len(own) == 0


def test_the_default_cache_is_the_shared_one():
    assert Tracker(CONFIG).solver.cache is SHARED


def test_an_answer_from_the_cache_equals_the_solved_one():
    from sensemaking.abduction.components import ComponentSolver
    from sensemaking.abduction.solver import Det

    own = SolverCache()
    tracker = Tracker(CONFIG, solver_cache=own)
    problems = []
    solve = tracker.solver.solve

    def keep(problem, budget_ms=None):  # type: ignore[no-untyped-def]
        problems.append(problem)
        return solve(problem, budget_ms)

    tracker.solver.solve = keep  # type: ignore[method-assign]
    _run(tracker)
    assert len(problems) > 10
    solver = ComponentSolver(tracker.solver.solver, cache=SolverCache(), slots=False)
    solved = [solver.solve(problem) for problem in problems]
    hits = solver.stats["cache_hits"]
    with_det = 0
    for problem, a in zip(problems, solved, strict=True):
        b = solver.solve(problem)  # every component from the cache now
        assert a is not None and b is not None
        b.solve_ms = a.solve_ms = 0.0
        assert b == a  # every field, in order (events and fluents name detections as Det)
        with_det += any(isinstance(x, Det) for _, args in a.events for x in args)
    assert solver.stats["cache_hits"] - hits == solver.stats["components"] // 2 > 0
    assert with_det > 0


def test_shapes_ground_ahead_give_the_tracks_of_shapes_ground_at_once():
    ahead, now = (
        Tracker(CONFIG, solver_cache=SolverCache()),
        Tracker(CONFIG, solver_cache=SolverCache(lead=0)),
    )
    assert _run(ahead) == _run(now)
    slots_ahead, slots_now = ahead.solver._slots, now.solver._slots
    assert slots_ahead is not None and slots_now is not None
    assert slots_ahead.stats["ahead"] > 0 and slots_now.stats["ahead"] == 0
    assert slots_ahead.stats["grounded"] == slots_now.stats["grounded"]
    assert slots_ahead.stats["answered"] == slots_now.stats["answered"]


def test_cache_keys_are_compact_bytes_equal_exactly_when_the_components_are():
    # a key is the component's fields as bytes (issue 23: ~330 B where the nested tuples took
    # ~1.5 kB, and the cache holds up to 20,000): equal keys exactly for equal components
    import sys

    from sensemaking.abduction import components

    seen: dict[bytes, tuple] = {}
    fields_seen: dict[tuple, bytes] = {}
    plain = components._plain_fields

    def record(fields, levels=True):  # type: ignore[no-untyped-def]
        key = plain(fields, levels)
        if not levels:  # the covers rows without their share and depth
            at = components._COVERS
            fields = (*fields[:at], tuple(r[:3] for r in fields[at]), *fields[at + 1 :])
        assert seen.setdefault(key, fields) == fields
        assert fields_seen.setdefault(fields, key) == key
        return key

    components._plain_fields = record
    try:
        _run(Tracker(CONFIG, solver_cache=SolverCache()))
    finally:
        components._plain_fields = plain
    assert len(seen) > 5 and all(isinstance(k, bytes) for k in seen)

    def deep(x: object) -> int:
        return sys.getsizeof(x) + (sum(map(deep, x)) if isinstance(x, tuple) else 0)

    assert sum(map(sys.getsizeof, seen)) < sum(map(deep, seen.values())) / 2
