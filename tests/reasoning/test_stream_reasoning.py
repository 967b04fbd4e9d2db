"""Stream reasoning (StreamSolver: one long-lived Control, each frame's facts once) gives the
warnings of the reference (a fresh Control grounding the whole window every frame)."""

from __future__ import annotations

import json
import re

import pytest
from conftest import SHARED_DATA
from test_scene_helpers import build_results, cyclist_behind_turning_car
from test_situations import (
    LANES,
    SIZE,
    STOPPED_AHEAD,
    hidden_behind_a_long_bus,
    looming_car,
    overtaking,
    parked_car_and_person,
    stopping_car,
)

from sensemaking.reasoning import online
from sensemaking.reasoning.context import SceneContext
from sensemaking.reasoning.egomotion import CameraModel
from sensemaking.reasoning.online import SituationMonitor
from sensemaking.reasoning.situations import StreamSolver


def _records(mon: SituationMonitor, results) -> list:
    """Every start, end and active warning of a run, as JSON."""
    out: list = []
    mon.reset()
    for r in results:
        out += [("start", w.to_json()) for w in mon.update(r)]
        out += [("end", e.to_json()) for e in mon.ended]
        out += [("active", w.to_json()) for w in mon.active]
    out += [("end", e.to_json()) for e in mon.finish()]
    return out


def _same(results, **kw) -> list:
    stream = _records(SituationMonitor(stream=True, **kw), results)
    fresh = _records(SituationMonitor(stream=False, **kw), results)
    assert stream == fresh
    return stream


def _lanes() -> SceneContext:
    return SceneContext(lanes=LANES)


SCENES = {
    "overtaking": (overtaking(), {}),
    "hidden": (cyclist_behind_turning_car(), {}),
    "bus": (hidden_behind_a_long_bus(), {}),
    "stopping": (stopping_car(2), {}),
    "looming": (looming_car(True), {}),
    "exiting": (parked_car_and_person((860, 190, 900, 300)), {}),
    "blocked": (stopping_car(2), {"context": _lanes()}),
    # with a camera model: positions, world motion, hidden tracks' paths
    "hidden-world": (cyclist_behind_turning_car(), {"camera": CameraModel.kitti()}),
    "overtaking-world": (overtaking(), {"camera": CameraModel.kitti()}),
}


@pytest.mark.slow
@pytest.mark.parametrize(("restart", "stage"), [(1, 10), (40, 10), (12, 4), (9, 1)])
@pytest.mark.parametrize("name", sorted(SCENES))
def test_stream_gives_the_references_warnings_on_each_scripted_scene(
    name, restart, stage, monkeypatch
):
    """Restarting every answer and every 40, the next Control fed ahead over 4 answers of 12,
    or given the window at the restart frame (stage 1)."""
    monkeypatch.setattr(online, "STREAM_RESTART_FRAMES", restart)
    monkeypatch.setattr(online, "STREAM_STAGE_FRAMES", stage)
    objs, kw = SCENES[name]
    for profile in ("driving", "fixed"):
        _same(build_results(objs), fps=10.0, image_size=SIZE, profile=profile, **kw)


@pytest.mark.slow
def test_the_scripted_scenes_raise_warnings_at_all():
    """The comparison above is not vacuous: the scenes warn."""
    kinds = set()
    for objs, kw in SCENES.values():
        mon = SituationMonitor(fps=10.0, image_size=SIZE, **kw)
        kinds |= {w.situation for w in mon.run(build_results(objs))}
    assert {"OVERTAKING", "HIDDEN_ENTITY", "SUDDEN_STOP", "EXITING_VEHICLE"} <= kinds


@pytest.mark.parametrize("name", ["hidden", "bus", "overtaking-world"])
def test_a_restart_fed_ahead_over_frames_with_gaps(name, monkeypatch):
    """Frames missing from the input (every third): the standby's frames leave the window as
    the active Control's do, and the warnings stay the reference's."""
    monkeypatch.setattr(online, "STREAM_RESTART_FRAMES", 7)
    monkeypatch.setattr(online, "STREAM_STAGE_FRAMES", 4)
    objs, kw = SCENES[name]
    results = [r for r in build_results(objs) if r.frame % 3 != 1]
    records = _same(results, fps=10.0, image_size=SIZE, **kw)
    assert any(kind == "start" for kind, _ in records)


def _frames_per_ground(monkeypatch, stage: int, results) -> list[int]:
    """The number of ``frame(f)`` parts of each of clingo's ground calls over a run."""
    import clingo

    monkeypatch.setattr(online, "STREAM_RESTART_FRAMES", 12)
    monkeypatch.setattr(online, "STREAM_STAGE_FRAMES", stage)
    counts: list[int] = []
    ground = clingo.Control.ground

    def counted(self, parts=(("base", ()),), context=None):
        counts.append(sum(1 for name, _ in parts if name == "frame"))
        return ground(self, parts, context)

    monkeypatch.setattr(clingo.Control, "ground", counted)
    mon = SituationMonitor(fps=10.0, image_size=SIZE, stream=True)
    counts.clear()  # the solver's own start
    mon.run(results)
    monkeypatch.undo()
    assert mon._stream is not None and mon._stream.restarts >= 3
    return counts


def test_a_restart_hands_no_whole_window_to_clingo(monkeypatch):
    """Fed ahead over 4 answers, the Control that takes over at a restart never grounds more
    than a share of the window at once; given the window at the restart frame it does."""
    results = build_results(hidden_behind_a_long_bus())  # 60 frames, a 16-frame window
    ahead = _frames_per_ground(monkeypatch, 4, results)
    at_once = _frames_per_ground(monkeypatch, 1, results)
    assert max(at_once) == 16
    assert max(ahead) <= 16 // 4 + 2


def test_a_users_situation_is_warned_in_the_stream_as_in_the_reference(tmp_path):
    rule = tmp_path / "stopped_ahead.lp"
    rule.write_text(STOPPED_AHEAD)
    records = _same(
        build_results(stopping_car(2) + overtaking(ids=(3, 4))),
        fps=10.0,
        image_size=SIZE,
        extra_encodings=[rule],
    )
    assert any(kind == "start" and w["situation"] == "STOPPED_AHEAD" for kind, w in records)


def test_a_users_rule_that_adds_vehicles_counts_with_the_given_ones(tmp_path):
    """A user's rule for an input predicate (vehicle/1) keeps the facts of that predicate."""
    rule = tmp_path / "more_vehicles.lp"
    rule.write_text("vehicle(T) :- track(T,pedestrian).\n")
    _same(build_results(overtaking()), fps=10.0, image_size=SIZE, extra_encodings=[rule])


def _atoms_named(mon: SituationMonitor, names: set[str]) -> int:
    solver = mon._stream
    assert solver is not None
    return sum(1 for a in solver._ctl.symbolic_atoms if a.symbol.name in names)


def test_profile_fixed_grounds_no_ego_vehicle_rule():
    """With no ego vehicle the helpers of SUDDEN_STOP are not grounded at all (they are with
    one, on the same frames)."""
    results = build_results(looming_car(True))
    ego = {"kept_distance", "moved", "braked", "braked_at", "contact_soon"}
    counts = {}
    for profile in ("driving", "fixed"):
        mon = SituationMonitor(fps=10.0, image_size=SIZE, profile=profile, stream=True)
        n = 0
        for r in results:
            mon.update(r)
            n += _atoms_named(mon, ego)
        counts[profile] = n
    assert counts["driving"] > 0 and counts["fixed"] == 0


def test_rules_about_one_frame_are_grounded_per_frame():
    static = [("frame_ms", 100), ("profile", "driving"), ("camera",)]
    layers = StreamSolver(static_facts=static).layers
    assert {("ra", 5), ("touching", 3), ("still", 2), ("nearer_world", 3)} <= layers.frame_preds
    assert {("warn", 2), ("info", 4), ("world", 0)} <= layers.now_preds
    assert {("ego_vehicle", 0), ("inverse", 2)} <= layers.static


def _rules(mon: SituationMonitor) -> list[str]:
    solver = mon._stream
    assert solver is not None
    return [str(s) for s in solver._program if ":-" in str(s)]


@pytest.mark.parametrize("name", ["overtaking-world", "looming"])
def test_rules_the_monitor_can_never_fire_are_not_given_to_clingo(name, monkeypatch):
    """With a camera model no rule needs ``image``; without one (and profile fixed) no rule
    needs the world motion or ``ego_vehicle``: such rules are left out of the Control, and the
    warnings stay the reference's."""
    objs, kw = SCENES[name]
    profile = "driving" if "camera" in kw else "fixed"
    results = build_results(objs)
    mon = SituationMonitor(fps=10.0, image_size=SIZE, profile=profile, stream=True, **kw)
    rules = _rules(mon)
    monkeypatch.setattr(SituationMonitor, "_absent", lambda self: set())
    monkeypatch.setattr(StreamSolver, "_empty_static", lambda self: set())
    whole = _rules(SituationMonitor(fps=10.0, image_size=SIZE, profile=profile, stream=True, **kw))
    monkeypatch.undo()
    assert len(rules) < len(whole)
    gone = {"image"} if "camera" in kw else {"ego_vehicle", "camera", "world_speed"}
    assert {name for name, _ in mon._stream.empty} >= gone  # type: ignore[union-attr]
    needs = [
        r for r in rules if any(re.search(rf"(?<!not )\b{g}\b", r.split(":-")[1]) for g in gone)
    ]
    assert not [r for r in needs if "#" not in r]  # only inside aggregates, which are kept
    _same(results, fps=10.0, image_size=SIZE, profile=profile, **kw)


def test_a_users_rule_for_an_input_never_given_keeps_the_rules_that_read_it(tmp_path):
    """Without a camera model the monitor gives no ``position/4``; a user's rule that derives
    it keeps the rules that read it (``in_ego_lane``) and its own situation."""
    rule = tmp_path / "positions.lp"
    rule.write_text(
        "position(T,F,1000,0) :- state(T,F,visible).\n"
        "warn(in_lane,(T,)) :- now(N), in_ego_lane(T,N), vehicle(T).\n"
    )
    mon = SituationMonitor(fps=10.0, image_size=SIZE, extra_encodings=[rule], stream=True)
    assert mon._stream is not None and ("position", 4) not in mon._stream.empty
    assert any(r.startswith("in_ego_lane(") for r in _rules(mon))
    records = _same(build_results(overtaking()), fps=10.0, image_size=SIZE, extra_encodings=[rule])
    assert any(kind == "start" and w["situation"] == "IN_LANE" for kind, w in records)


def test_a_users_rule_dropped_for_an_input_never_given_keeps_the_given_facts(tmp_path):
    """A user's rule for an input predicate (vehicle/1) that needs the world motion is left out
    without a camera model; the vehicles the monitor gives still count."""
    rule = tmp_path / "world_vehicles.lp"
    rule.write_text("vehicle(T) :- track(T,pedestrian), position(T,_,_,_).\n")
    mon = SituationMonitor(fps=10.0, image_size=SIZE, extra_encodings=[rule], stream=True)
    assert not any(r.startswith("vehicle(") for r in _rules(mon))
    records = _same(build_results(overtaking()), fps=10.0, image_size=SIZE, extra_encodings=[rule])
    assert any(kind == "start" and w["situation"] == "OVERTAKING" for kind, w in records)


def test_pruning_drops_only_rules_whose_body_cannot_hold():
    """A body atom whose constant first argument no rule left gives is dead; a ``#const`` name
    or an input the monitor gives never is."""
    from clingo import ast

    from sensemaking.reasoning.situations import _pruned

    stmts: list = []
    ast.parse_string(
        "#const k = 3. p(x) :- a. w(k) :- b. q :- p(y). r :- w(3). s :- p(x)."
        " t :- vehicle(1), c. u :- d. d :- e.",
        stmts.append,
    )
    kept = {str(s).split(" :-")[0] for s in _pruned(stmts, [("e", 0)])}
    assert {"p(x)", "w(k)", "r", "s", "t"} <= kept
    assert not {"q", "u", "d"} & kept


# -- a warning's details grounded only when it holds ---------------------------------------------
_TINY = (
    "warn(a,(X,)) :- p(X). warn(b,(X,)) :- q(X)."
    " info(a,(X,),k,1) :- warn(a,(X,))."
    " g(X,V) :- warn(a,(X,)), r(X,V)."  # a chain: g is derived from the warning
    " info(a,(X,),v,V) :- warn(a,(X,)), g(X,V)."
    " info(b,(X,),k,2) :- warn(b,(X,))."
)


def _details_of(text: str) -> list[tuple[set[str], set]]:
    """The details' groups of a tiny program: the heads of their rules, their triggers."""
    from clingo import ast

    from sensemaking.reasoning.situations import _atoms, _details, _signature

    rules: list = []
    ast.parse_string(text, lambda s: rules.append(s) if s.ast_type == ast.ASTType.Rule else None)
    preds = {_signature(a) for r in rules for a in _atoms(r.head)} - {None}
    groups = _details(rules, set(), preds, [])
    return [({str(rules[i].head) for i in ix}, set(trig)) for ix, trig in groups]


def test_a_warnings_details_are_split_by_situation():
    """The rules that read ``warn(a,...)`` (and the chain through g) form one group triggered
    by a, those of b another; the warn rules stay in the first call."""
    groups = _details_of(_TINY)
    assert sorted(groups, key=lambda g: sorted(g[1])) == [
        ({"info(a,(X,),k,1)", "g(X,V)", "info(a,(X,),v,V)"}, {"a"}),
        ({"info(b,(X,),k,2)"}, {"b"}),
    ]


def test_a_rule_that_reads_or_defines_the_details_goes_with_them():
    """A rule reading g without a warn literal, or defining info without one, is grounded in
    the second call too, and always (trigger None); a detail for any situation is triggered
    by any warning (``*``); a warn rule that reads a detail leaves no split at all."""
    reads = _details_of(_TINY + " h :- g(_,_).")
    assert ({"info(a,(X,),k,1)", "g(X,V)", "info(a,(X,),v,V)", "h"}, {"a", None}) in reads
    defines = _details_of(_TINY + " info(c,(X,),k,3) :- p(X).")
    assert ({"info(c,(X,),k,3)"}, {None}) in defines
    anyone = _details_of("warn(a,(X,)) :- p(X). info(S,O,k,1) :- warn(S,O).")
    assert anyone == [({"info(S,O,k,1)"}, {"*"})]
    assert _details_of(_TINY + " warn(c,(X,)) :- info(a,(X,),k,_).") == []


_TWO_SITUATIONS = """
warn(seen,(T,)) :- now(N), state(T,N,visible), vehicle(T).
warn(gone,(T,)) :- now(N), state(T,N,hidden), vehicle(T).
big(T,A) :- warn(seen,(T,)), now(N), area(T,N,A), A > 10.
info(seen,(T,),area_permille,A) :- warn(seen,(T,)), big(T,A).
info(gone,(T,),since,frame(N)) :- warn(gone,(T,)), now(N).
"""


def test_a_situations_details_are_grounded_only_when_it_is_warned(tmp_path, monkeypatch):
    """Each frame grounds the details of the situations warned at it and no others; the
    answers (details through a derived predicate included) are the reference's."""
    import clingo

    from sensemaking.reasoning.situations import SituationSolver

    enc = tmp_path / "two.lp"
    enc.write_text(_TWO_SITUATIONS)
    static = [("frame_ms", 100), ("profile", "driving")]
    solver = StreamSolver(parts=(), extra_encodings=[enc], static_facts=static, window=4)
    reference = SituationSolver(parts=(), extra_encodings=[enc], cache_size=0)
    part = {name: next(iter(trig)) for name, trig in solver._details}
    assert sorted(part.values()) == ["gone", "seen"]
    grounded: list[set] = []
    ground = clingo.Control.ground

    def record(self, parts=(("base", ()),), context=None):
        grounded[-1] |= {part[name] for name, _ in parts if name in part}
        return ground(self, parts, context)

    monkeypatch.setattr(clingo.Control, "ground", record)
    states = ["visible", "hidden", "hidden", "visible", "missing", "missing"]
    areas = [5, 0, 0, 30, 0, 0]
    window: list = []
    for f, (st, a) in enumerate(zip(states, areas, strict=True)):
        grounded.append(set())
        facts = [("state", 1, f, st)]
        solver.add_frame(f, facts)
        window += facts
        solver.set_window([("vehicle", 1)])
        current = [("now", f), ("area", 1, f, a)]
        got = solver.answer(f, current)
        want = reference.answer(tuple([*static, ("vehicle", 1), *window, *current]))
        assert sorted(map(str, got)) == sorted(map(str, want))
        if f == 3:  # the warning's detail through big/2
            assert any("area_permille" in str(x) for x in got)
    # (exactly: the frame before's now/1 is not joined, see the next test)
    assert grounded == [{"seen"}, {"gone"}, {"gone"}, {"seen"}, set(), set()]


def test_an_answer_joins_its_own_frame_only(tmp_path):
    """now/1 reaches clingo as now(N,n), a fact of the answer's own: the rules of an answer
    are never instantiated for the frame before (a released external would still be in
    clingo's domain for the next ground call)."""
    enc = tmp_path / "seen.lp"
    enc.write_text("warn(seen,(T,)) :- now(N), state(T,N,visible).\n")
    solver = StreamSolver(parts=(), extra_encodings=[enc], static_facts=[("frame_ms", 100)])
    got = []
    for f, st in enumerate(["visible", "hidden", "visible"]):
        solver.add_frame(f, [("state", 1, f, st)])
        got.append(solver.answer(f, [("now", f)]))
        warn = solver._ctl.symbolic_atoms.by_signature("warn", 3)
        assert [str(a.symbol) for a in warn if a.symbol.arguments[2].number == f] == (
            [f"warn(seen,(1,),{f})"] if st == "visible" else []
        )
    assert [len(a) for a in got] == [1, 0, 1]


def test_a_stream_monitor_pickles_mid_sequence():
    import pickle

    results = build_results(cyclist_behind_turning_car() + overtaking(ids=(3, 4)))
    whole = [w.to_json() for w in SituationMonitor(fps=10.0, image_size=SIZE).run(results)]
    mon = SituationMonitor(fps=10.0, image_size=SIZE)
    half = len(results) // 2
    got = [w.to_json() for r in results[:half] for w in mon.update(r)]
    copy = pickle.loads(pickle.dumps(mon))
    got += [w.to_json() for r in results[half:] for w in copy.update(r)]
    assert got == whole and whole


def test_a_stream_monitor_pickles_while_the_next_control_is_fed(monkeypatch):
    """A copy taken while the standby is fed drops it (its next restart is a plain one) and
    warns as the original does."""
    import pickle

    monkeypatch.setattr(online, "STREAM_RESTART_FRAMES", 10)
    monkeypatch.setattr(online, "STREAM_STAGE_FRAMES", 5)
    results = build_results(cyclist_behind_turning_car() + overtaking(ids=(3, 4)))
    mon = SituationMonitor(fps=10.0, image_size=SIZE)
    got = [w.to_json() for r in results[:8] for w in mon.update(r)]
    assert mon._next is not None  # fed ahead of the restart at the 10th answer
    copy = pickle.loads(pickle.dumps(mon))
    assert copy._next is None
    rest = [w.to_json() for r in results[8:] for w in mon.update(r)]
    assert [w.to_json() for r in results[8:] for w in copy.update(r)] == rest
    whole = [w.to_json() for w in SituationMonitor(fps=10.0, image_size=SIZE).run(results)]
    assert got + rest == whole and whole


# -- shared sequences, as a user runs them -------------------------------------------------------
def _track_warnings(argv: list[str], out, stream: bool, monkeypatch) -> list[dict]:
    from sensemaking.cli import main

    monkeypatch.setattr(online, "STREAM", stream)
    path = out / f"warnings-{stream}.jsonl"
    argv = [*argv, "--output", str(out / "t.txt"), "--warnings", str(path)]
    assert main(["--quiet", "track", *argv]) == 0
    return [json.loads(line) for line in path.read_text().splitlines()]


KITTI_0001 = SHARED_DATA / "kitti/detections/rrc/car/0001.txt"
MOT17_09 = SHARED_DATA / "mot17/MOT17-09-YOLOX-half/det/det.txt"
SEQUENCES = {
    "kitti-rrc-car-0001": ["--detections", str(KITTI_0001), "--format", "kitti"],
    "mot17-09-yolox-half": [
        *("--detections", str(MOT17_09), "--format", "mot"),
        *("--profile", "driving"),
    ],
}


@pytest.mark.slow
@pytest.mark.integration
@pytest.mark.parametrize("name", sorted(SEQUENCES))
def test_same_warnings_on_shared_sequences(name, tmp_path, monkeypatch):
    """`sensemaking track --warnings` writes the same records with the stream solver as with
    the reference, on KITTI RRC car 0001 (a camera model: motion over the road) and MOT17-09
    (pedestrians, profile driving)."""
    if not SHARED_DATA.is_dir():
        pytest.skip("../shared/data is absent")
    argv = SEQUENCES[name]
    stream = _track_warnings(argv, tmp_path, True, monkeypatch)
    fresh = _track_warnings(argv, tmp_path, False, monkeypatch)
    assert stream == fresh
