"""Safety-critical situations online (SituationMonitor + situations.lp) on scripted scenes:
for each situation a scene where it occurs and scenes where it must not."""

from __future__ import annotations

import json
import logging

import clingo
import numpy as np
import pytest
from test_scene_helpers import CAR, CYC, PED, TRUCK, Obj, build_results, cyclist_behind_turning_car, linear, piecewise

from sensemaking.reasoning.context import Lane, LaneMap, SceneContext
from sensemaking.reasoning.online import SituationMonitor
from sensemaking.reasoning.situations import ALL_SITUATIONS, Situation, SituationConfig, Warning, answer_of_grounded

SIZE = (1242, 375)


def run(objs, n=None, *, context=None, config=None, **kw) -> list[Warning]:
    mon = SituationMonitor(config, context=context, fps=10.0, image_size=SIZE)
    return mon.run(build_results(objs, n, **kw))


def kinds(warnings: list[Warning]) -> list[tuple[int, str, tuple[int, ...]]]:
    return [(w.frame, w.situation, w.objects) for w in warnings if w.objects]


def only(warnings: list[Warning], situation: str) -> list[tuple[int, str, tuple[int, ...]]]:
    return [k for k in kinds(warnings) if k[1] == situation]


def box(cx: float, bottom: float, w: float, h: float) -> list[float]:
    return [cx - w / 2, bottom - h, cx + w / 2, bottom]


# -- scenes ---------------------------------------------------------------------------------------
def overtaking(a_speed: float = 4.0, b_down: float = -0.5, ids: tuple[int, int] = (1, 2)) -> list[Obj]:
    """Two cars ahead in adjacent lanes; car 1 starts nearer and pulls away faster than car 2."""
    a = piecewise([(0, box(500, 300, 140, 90)), (30, box(560, 300 - 30 * a_speed, 100, 64))])
    b = piecewise([(0, box(680, 280, 120, 78)), (30, box(700, 280 + 30 * b_down, 112, 74))])
    return [Obj(ids[0], CAR, a), Obj(ids[1], CAR, b)]


def cyclist_far_left() -> list[Obj]:
    """The hidden-cyclist scene shifted to the left edge: it reappears outside the corridor."""
    shifted = []
    for o in cyclist_behind_turning_car():
        shifted.append(Obj(o.id, o.cls, {f: np.asarray(b) - [400, 0, 400, 0] for f, b in o.boxes.items()}))
    return shifted


def hidden_behind_a_long_bus() -> list[Obj]:
    """A cyclist rides slowly behind a parked bus 500 px long: it will not come out for 12 s."""
    cyc = Obj(1, CYC, linear(range(60), (380, 180, 428, 254), (4, 0, 4, 0)))
    bus = Obj(2, TRUCK, linear(range(60), (480, 120, 980, 300)))
    return [cyc, bus]


def stopping_car(stop_frames: int) -> list[Obj]:
    """A car in front moving right at 8 px/frame, then braking to a stop over ``stop_frames``."""
    keys, x, v = {}, 560.0, 8.0
    for f in range(40):
        if f >= 10:
            v = max(0.0, v - 8.0 / stop_frames)
        x += v
        keys[f] = np.array(box(x, 300, 140, 80))
    return [Obj(1, CAR, keys)]


def looming_car(calm_first: bool) -> list[Obj]:
    """A car ahead that keeps its distance, then grows fast (it brakes); or grows all along."""
    keys, h = {}, 60.0
    for f in range(30):
        if f >= (10 if calm_first else 0):
            h *= 1.08
        keys[f] = np.array(box(620, 200 + h, 1.6 * h, h))
    return [Obj(1, CAR, keys)]


def parked_car_and_person(appear_at: tuple[float, float, float, float], start: int = 10,
                          car_speed: float = 0.0) -> list[Obj]:
    car = Obj(1, CAR, linear(range(30), (700, 200, 880, 300), (car_speed, 0, car_speed, 0)))
    ped = Obj(2, PED, linear(range(start, 30), appear_at, (1, 0, 1, 0)))
    return [car, ped]


LANES = LaneMap((Lane(1, np.array([[560.0, 200], [400, 375]]), np.array([[680.0, 200], [840, 375]])),))


# -- OVERTAKING -----------------------------------------------------------------------------------
def test_overtaking_occurs():
    w = only(run(overtaking()), "OVERTAKING")
    assert len(w) == 1 and w[0][2] == (1, 2) and 5 <= w[0][0] <= 12


def test_overtaking_not_when_both_keep_their_order():
    assert only(run(overtaking(a_speed=0.3, b_down=-0.3)), "OVERTAKING") == []


def test_overtaking_not_for_oncoming_traffic():
    # car 1 stays, car 2 comes towards the ego fast (bottom moves down): the order flips
    a = linear(range(30), box(500, 290, 120, 80))
    b = piecewise([(0, box(720, 260, 90, 60)), (29, box(760, 330, 150, 100))])
    assert only(run([Obj(1, CAR, a), Obj(2, CAR, b)]), "OVERTAKING") == []


@pytest.mark.parametrize("name", ["oncoming", "overtaking", "hidden_late", "reduced", "stop", "loom"])
def test_exact_situations_are_answered_from_the_snapshot_as_the_solver_would(name):
    # OVERTAKING, HIDDEN_ENTITY, REDUCED_VISIBILITY and SUDDEN_STOP candidates pass every condition
    # of their rules (side by side, B not approaching, lead within he_lead_ms, ...): the monitor
    # answers them, details included, without a solver call; grounding everything agrees frame
    # by frame
    a = linear(range(30), box(500, 290, 120, 80))
    b = piecewise([(0, box(650, 260, 90, 60)), (29, box(690, 330, 150, 100))])  # near, oncoming
    objs, config = {
        "oncoming": ([Obj(1, CAR, a), Obj(2, CAR, b)], {"situations": {"OVERTAKING"}}),
        "overtaking": (overtaking(), {"situations": {"OVERTAKING"}}),
        "hidden_late": (cyclist_behind_turning_car(), {"situations": {"HIDDEN_ENTITY"}, "constants": {"he_lead_ms": 1000}}),
        "reduced": (cyclist_behind_turning_car(), {"situations": {"REDUCED_VISIBILITY"}}),
        "stop": (stopping_car(2), {"situations": {"SUDDEN_STOP"}}),
        "loom": (looming_car(True), {"situations": {"SUDDEN_STOP"}}),
    }[name]
    mon = SituationMonitor(SituationConfig(**config), fps=10.0, image_size=SIZE)
    full = SituationMonitor(SituationConfig(**config, prefilter=False), fps=10.0, image_size=SIZE)
    held = 0
    for r in build_results(objs):
        assert [w.to_json() for w in mon.update(r)] == [w.to_json() for w in full.update(r)]
        got = [w.to_json() for w in mon.active]
        assert got == [w.to_json() for w in full.active]
        assert all(w["frame"] == r.frame for w in got)
        held += bool(got)
    assert mon.stats["solver_calls"] == 0 and full.stats["solver_calls"] == mon.stats["frames"]
    assert (held > 0) == (name != "oncoming")


def test_situations_only_prefiltered_still_ask_the_solver():
    # BLOCKED_LANE (how long on the lane) and EXITING_VEHICLE (touching) are grounded when they
    # have candidates, and only then
    lanes = ([Obj(1, CAR, linear(range(20), (560, 230, 700, 310)))], SceneContext(lanes=LANES))
    exits = (parked_car_and_person((860, 190, 900, 300)), None)
    for (objs, ctx), name in ((lanes, "BLOCKED_LANE"), (exits, "EXITING_VEHICLE")):
        mon = SituationMonitor(SituationConfig(situations={name}), ctx, fps=10.0, image_size=SIZE)
        warnings = mon.run(build_results(objs))
        assert [w.situation for w in warnings if w.objects] == [name]
        assert 0 < mon.stats["solver_calls"] < mon.stats["frames"]


# -- HIDDEN_ENTITY --------------------------------------------------------------------------------
def test_hidden_entity_occurs_while_hidden():
    w = only(run(cyclist_behind_turning_car()), "HIDDEN_ENTITY")
    assert w == [(21, "HIDDEN_ENTITY", (1, 2))]


def test_hidden_entity_not_when_reappearing_outside_the_corridor():
    warnings = run(cyclist_far_left())
    assert only(warnings, "HIDDEN_ENTITY") == []
    assert any(k[1] == "REDUCED_VISIBILITY" for k in kinds(warnings)) is False


def test_hidden_entity_not_when_it_will_not_come_out_soon():
    assert only(run(hidden_behind_a_long_bus()), "HIDDEN_ENTITY") == []
    # and not with a lead time shorter than the anticipated one
    config = SituationConfig(constants={"he_lead_ms": 1000})
    assert only(run(cyclist_behind_turning_car(), config=config), "HIDDEN_ENTITY") == [
        (24, "HIDDEN_ENTITY", (1, 2))]  # from frame 24 the reappearance at 34 is within 1 s


# -- REDUCED_VISIBILITY ---------------------------------------------------------------------------
def test_reduced_visibility_occurs_for_a_large_object_in_front():
    truck = Obj(1, TRUCK, linear(range(10), (420, 170, 820, 370)))
    warnings = run([truck])
    assert only(warnings, "REDUCED_VISIBILITY") == [(0, "REDUCED_VISIBILITY", (1,))]
    w = next(w for w in warnings if w.situation == "REDUCED_VISIBILITY")
    assert w.details["area_permille"] == 172 and "takes 17% of the image" in w.message


def test_reduced_visibility_occurs_for_an_object_that_hides_another():
    w = only(run(cyclist_behind_turning_car()), "REDUCED_VISIBILITY")
    assert w == [(21, "REDUCED_VISIBILITY", (2,))]


def test_reduced_visibility_not_for_small_or_side_objects():
    small = Obj(1, CAR, linear(range(10), (560, 220, 710, 320)))
    side = Obj(2, TRUCK, linear(range(10), (0, 60, 250, 370)))
    assert only(run([small, side]), "REDUCED_VISIBILITY") == []


# -- SUDDEN_STOP ----------------------------------------------------------------------------------
def test_sudden_stop_occurs_when_the_car_in_front_stops_abruptly():
    w = only(run(stopping_car(stop_frames=2)), "SUDDEN_STOP")
    assert len(w) == 1 and 11 <= w[0][0] <= 15 and w[0][2] == (1,)


def test_sudden_stop_not_when_braking_gently():
    assert only(run(stopping_car(stop_frames=30)), "SUDDEN_STOP") == []


def test_sudden_stop_when_the_car_ahead_looms_after_keeping_its_distance():
    warnings = run(looming_car(calm_first=True))
    w = only(warnings, "SUDDEN_STOP")
    assert len(w) == 1 and 10 <= w[0][0] <= 14
    full = next(x for x in warnings if x.situation == "SUDDEN_STOP")
    assert full.details["cause"] == "looming" and full.details["ttc_s"] > 0


def test_sudden_stop_not_for_a_car_looming_all_along():
    assert only(run(looming_car(calm_first=False)), "SUDDEN_STOP") == []


# -- BLOCKED_LANE ---------------------------------------------------------------------------------
def test_blocked_lane_occurs_for_an_object_standing_on_a_lane():
    stopped = Obj(1, CAR, linear(range(20), (560, 230, 700, 310)))
    warnings = run([stopped], context=SceneContext(lanes=LANES))
    # motion is measured from frame 3 (lag 0.3 s); stopped for bl_ms = 0.5 s: frames 3..7
    assert only(warnings, "BLOCKED_LANE") == [(7, "BLOCKED_LANE", (1,))]
    w = next(w for w in warnings if w.situation == "BLOCKED_LANE")
    assert w.details["lane"] == 1 and "lane 1 is blocked by track 1 (car)" in w.message


def test_blocked_lane_not_for_moving_or_off_lane_objects():
    moving = Obj(1, CAR, linear(range(20), (560, 230, 700, 310), (5, 0, 5, 0)))
    beside = Obj(2, CAR, linear(range(20), (1000, 230, 1140, 310)))
    assert only(run([moving, beside], context=SceneContext(lanes=LANES)), "BLOCKED_LANE") == []


def test_blocked_lane_without_lanes_is_skipped_with_a_note(caplog):
    stopped = Obj(1, CAR, linear(range(20), (560, 230, 700, 310)))
    with caplog.at_level(logging.INFO, logger="sensemaking.reasoning.online"):
        warnings = run([stopped])
    notes = [w for w in warnings if w.situation == "BLOCKED_LANE"]
    assert len(notes) == 1 and notes[0].objects == () and notes[0].frame == 0
    assert notes[0].details == {"skipped": "needs lanes (no lanes file given)"}
    assert "BLOCKED_LANE not checked" in caplog.text
    mon = SituationMonitor()
    assert mon.skipped == {"BLOCKED_LANE": "needs lanes (no lanes file given)"}
    assert SituationMonitor(context=SceneContext(lanes=LANES)).skipped == {}


# -- EXITING_VEHICLE ------------------------------------------------------------------------------
def test_exiting_vehicle_occurs_for_a_person_appearing_at_a_parked_car():
    w = only(run(parked_car_and_person((860, 190, 900, 300))), "EXITING_VEHICLE")
    assert w == [(10, "EXITING_VEHICLE", (2, 1))]


def test_exiting_vehicle_not_for_people_walking_in_or_appearing_elsewhere():
    walking_in = parked_car_and_person((1205, 190, 1245, 300))  # enters at the right border
    assert only(run(walking_in), "EXITING_VEHICLE") == []
    far = parked_car_and_person((200, 190, 240, 300))
    assert only(run(far), "EXITING_VEHICLE") == []
    moving_car = parked_car_and_person((860, 190, 900, 300), car_speed=6.0)
    assert only(run(moving_car), "EXITING_VEHICLE") == []
    at_start = parked_car_and_person((860, 190, 900, 300), start=0)  # there from the first frame
    assert only(run(at_start), "EXITING_VEHICLE") == []


# -- monitor behaviour ----------------------------------------------------------------------------
SCENES = {
    "overtaking": (overtaking(), None),
    "hidden": (cyclist_behind_turning_car(), None),
    "hidden_left": (cyclist_far_left(), None),
    "stop": (stopping_car(2), None),
    "loom": (looming_car(True), None),
    "lane": ([Obj(1, CAR, linear(range(20), (560, 230, 700, 310)))], SceneContext(lanes=LANES)),
    "exit": (parked_car_and_person((860, 190, 900, 300)), None),
    "noisy": (cyclist_behind_turning_car() + overtaking(ids=(3, 4)), None),
}


@pytest.mark.parametrize("name", sorted(SCENES))
def test_prefilter_gives_the_same_warnings_as_grounding_everything(name):
    objs, ctx = SCENES[name]
    noise = 1.0 if name == "noisy" else 0.0
    fast = SituationMonitor(SituationConfig(prefilter=True), ctx, 10.0, SIZE)
    full = SituationMonitor(SituationConfig(prefilter=False), ctx, 10.0, SIZE)
    for r in build_results(objs, noise_px=noise):
        a, b = fast.update(r), full.update(r)
        assert [w.to_json() for w in a] == [w.to_json() for w in b]
        assert [w.to_json() for w in fast.active] == [w.to_json() for w in full.active]
    assert fast.stats["solver_calls"] <= full.stats["solver_calls"]


def test_each_situation_is_found_by_some_scene():
    found = set()
    for objs, ctx in SCENES.values():
        found |= {w.situation for w in run(objs, context=ctx) if w.objects}
    assert found == ALL_SITUATIONS


def test_warning_once_per_episode_and_active_list():
    truck = Obj(1, TRUCK, {**linear(range(0, 10), (420, 170, 820, 370)), **linear(range(25, 30), (420, 170, 820, 370))})
    mon = SituationMonitor(SituationConfig(situations={"REDUCED_VISIBILITY"}), fps=10.0, image_size=SIZE)
    frames = []
    for r in build_results([truck], 30):
        if mon.update(r):
            frames.append(r.frame)
        if r.frame == 5:
            assert [w.situation for w in mon.active] == ["REDUCED_VISIBILITY"]
    assert frames == [0, 25]  # again after more than rearm_s (1 s) without it


def test_warning_json_round_trip():
    (w,) = [w for w in run(cyclist_behind_turning_car()) if w.situation == "HIDDEN_ENTITY"]
    record = w.to_json()
    assert set(record) == {"frame", "situation", "objects", "message", "details"}
    text = json.dumps(record)
    back = Warning.from_json(json.loads(text))
    assert back == w and back.details == w.details
    assert str(w).startswith("[21] HIDDEN_ENTITY: track 1 (cyclist) is hidden behind track 2 (car)")


def test_config_selects_situations_and_validates():
    config = SituationConfig(situations={"hidden-entity", "OVERTAKING"})
    assert config.situations == frozenset({"HIDDEN_ENTITY", "OVERTAKING"})
    got = {w.situation for w in run(cyclist_behind_turning_car(), config=config)}
    assert got == {"HIDDEN_ENTITY"}
    with pytest.raises(ValueError, match="unknown situation"):
        SituationConfig(situations={"FLYING_CAR"})
    with pytest.raises(ValueError, match="unknown situation parameter"):
        SituationConfig(constants={"speed": 3})
    assert Situation.parse("sudden-stop") is Situation.SUDDEN_STOP


def test_window_covers_the_duration_parameters():
    assert SituationConfig().window_frames(10.0) == 16  # ov_ms = 1.5 s at 10 fps, + 1
    assert SituationConfig(window_s=3.0).window_frames(30.0) == 91


def test_reset_and_frame_order():
    results = build_results(cyclist_behind_turning_car())
    mon = SituationMonitor()
    first = [w.to_json() for r in results for w in mon.update(r)]
    with pytest.raises(ValueError, match="frames must increase"):
        mon.update(results[3])
    mon.reset()
    again = [w.to_json() for r in results for w in mon.update(r)]
    assert first == again


def test_empty_frames_and_unknown_classes():
    from sensemaking.detections import Detections
    from sensemaking.results import FrameResult

    mon = SituationMonitor(SituationConfig(prefilter=False))
    assert [w.situation for w in mon.update(FrameResult(0, Detections.empty()))] == ["BLOCKED_LANE"]
    odd = Obj(1, 18, linear(range(5), (420, 170, 820, 370)))  # misc: neither vehicle nor person
    warnings = mon.run(build_results([odd]))
    assert [k[1] for k in kinds(warnings)] == ["REDUCED_VISIBILITY"]


def test_without_image_size_corridor_situations_are_skipped():
    mon = SituationMonitor(fps=10.0, image_size=None)
    assert set(mon.skipped) == {"BLOCKED_LANE", "HIDDEN_ENTITY", "REDUCED_VISIBILITY", "SUDDEN_STOP"}
    warnings = mon.run(build_results(cyclist_behind_turning_car() + overtaking(ids=(3, 4))))
    notes = {w.situation: w.details["skipped"] for w in warnings if not w.objects}
    assert notes["HIDDEN_ENTITY"] == "needs the image size (for the ego corridor)"
    assert {k[1] for k in kinds(warnings)} == {"OVERTAKING"}


@pytest.mark.parametrize("name", sorted(SCENES))
def test_leaving_out_rules_that_cannot_matter_changes_no_answer(name, monkeypatch):
    """solve_window grounds only the rules that can fire with the facts at hand and that warn/info
    depend on; on every fact set of a scene (all facts of the window, every situation) the
    answers equal those of the whole program, and rules were left out somewhere."""
    import sensemaking.reasoning.online as online
    from sensemaking.reasoning import situations

    calls: list[tuple[str, list[Situation]]] = []
    monkeypatch.setattr(online, "solve_window",
                        lambda facts, parts, consts=None: calls.append((facts, list(parts))) or [])
    objs, ctx = SCENES[name]
    mon = SituationMonitor(SituationConfig(prefilter=False), ctx, 10.0, SIZE)
    for r in build_results(objs, noise_px=1.0 if name == "noisy" else 0.0):
        mon.update(r)
    consts = tuple(sorted(situations.situation_constants().items()))
    names = tuple(s.value for s in mon._checked)
    pruned = 0
    for facts, parts in calls[::3]:
        got = situations.solve_window(facts, parts)
        with monkeypatch.context() as m:
            m.setattr(situations, "_fact_names", lambda facts: None)
            assert situations.solve_window(facts, parts) == got
        pruned += len(situations._program_text(consts, names, situations._fact_names(facts))) < \
            len(situations._program_text(consts, names))
    assert pruned > 0


# -- reading the answer of a grounded program ---------------------------------------------------
def _grounded(program: str) -> clingo.Control:
    ctl = clingo.Control(["--warn=none"])
    ctl.add("base", [], program)
    ctl.ground([("base", [])])
    return ctl


@pytest.mark.parametrize("program, expected", [
    # stratified: grounding decides everything, the facts are the answer
    ("p(1). p(2). q(X) :- p(X), not r(X). r(2).", ["q(1)"]),
    # a choice leaves atoms open: the solver decides (first answer set: some subset)
    ("{ q(1) }. :- not q(1).", ["q(1)"]),
    # no answer set at all
    ("q(1). :- q(1).", []),
    ("p(1). q(X) :- p(X). :- q(1), not s. s :- not t. t :- not s.", ["q(1)"]),
])
def test_answer_of_grounded_is_the_first_answer_set(program, expected):
    got = sorted(str(s) for s in answer_of_grounded(_grounded(program), [("q", 1)]))
    assert got == expected


def _stmts(program: str) -> list:
    from clingo import ast as clingo_ast

    from sensemaking.reasoning.situations import _stmt

    out: list = []
    clingo_ast.parse_string(program, lambda s: out.append(s) if s.ast_type != clingo_ast.ASTType.Program else None)
    return [_stmt(s) for s in out]


@pytest.mark.parametrize("program, stratified", [
    ("p(1). q(X) :- p(X), not r(X). r(X) :- p(X), X > 1. #show q/1.", True),
    ("p :- not q. q :- not p.", False),            # negative cycle
    ("p(1). q :- p(X), not q.", False),             # through itself
    ("p(1). n(N) :- N = #count { X: p(X) }.", True),  # aggregate over a lower stratum
    ("p(1). p(N+1) :- p(N), N < 3, N = #max { X: p(X) }.", False),  # aggregate in a cycle
    ("p(1). :- p(1).", False),                      # constraint
    ("{ p(1) }.", False),                           # choice
])
def test_stratified_programs_are_recognised(program, stratified):
    from sensemaking.reasoning.situations import _stratified

    assert _stratified(_stmts(program)) is stratified


def test_every_situation_part_is_stratified_so_grounding_decides_it():
    from sensemaking.reasoning import situations

    consts = tuple(sorted(situations.situation_constants().items()))
    for s in Situation:
        assert situations._pruned(consts, (s.value,))[2]
    assert situations._pruned(consts, tuple(s.value for s in Situation))[2]


def test_answer_of_grounded_for_a_stratified_program_reads_the_facts():
    ctl = _grounded("p(1). p(2). q(X) :- p(X), not r(X). r(2).")
    assert sorted(str(s) for s in answer_of_grounded(ctl, [("q", 1)], stratified=True)) == ["q(1)"]
    # atoms left open (a choice, wrongly declared stratified) still go to the solver
    assert [str(s) for s in answer_of_grounded(_grounded("{ q(1) }. :- not q(1)."), [("q", 1)], True)] == ["q(1)"]
