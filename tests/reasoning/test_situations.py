"""Safety-critical situations online (SituationMonitor + situations.lp) on scripted scenes:
for each situation a scene where it occurs and scenes where it must not."""

from __future__ import annotations

import dataclasses
import json
import logging

import numpy as np
import pytest
from test_scene_helpers import (
    CAR,
    CYC,
    PED,
    TRUCK,
    Obj,
    build_results,
    cyclist_behind_turning_car,
    linear,
    piecewise,
)

from sensemaking.errors import InputError
from sensemaking.reasoning.context import Lane, LaneMap, SceneContext
from sensemaking.reasoning.online import SituationMonitor
from sensemaking.reasoning.situations import (
    ALL_SITUATIONS,
    Situation,
    SituationConfig,
    SituationWarning,
)
from sensemaking.records import start_record

SIZE = (1242, 375)


def run(objs, n=None, *, context=None, config=None, **kw) -> list[SituationWarning]:
    mon = SituationMonitor(config, context=context, fps=10.0, image_size=SIZE)
    return mon.run(build_results(objs, n, **kw))


def kinds(warnings: list[SituationWarning]) -> list[tuple[int, str, tuple[int, ...]]]:
    return [(w.frame, w.situation, w.objects) for w in warnings if w.objects]


def only(
    warnings: list[SituationWarning], situation: str
) -> list[tuple[int, str, tuple[int, ...]]]:
    return [k for k in kinds(warnings) if k[1] == situation]


def box(cx: float, bottom: float, w: float, h: float) -> list[float]:
    return [cx - w / 2, bottom - h, cx + w / 2, bottom]


# -- scenes ---------------------------------------------------------------------------------------
def overtaking(
    a_speed: float = 4.0, b_down: float = -0.5, ids: tuple[int, int] = (1, 2)
) -> list[Obj]:
    """Two cars ahead in adjacent lanes; car 1 starts nearer and pulls away faster than car 2."""
    a = piecewise([(0, box(500, 300, 140, 90)), (30, box(560, 300 - 30 * a_speed, 100, 64))])
    b = piecewise([(0, box(680, 280, 120, 78)), (30, box(700, 280 + 30 * b_down, 112, 74))])
    return [Obj(ids[0], CAR, a), Obj(ids[1], CAR, b)]


def cyclist_far_left() -> list[Obj]:
    """The hidden-cyclist scene shifted to the left edge: it reappears outside the corridor."""
    shifted = []
    for o in cyclist_behind_turning_car():
        shifted.append(
            Obj(o.id, o.cls, {f: np.asarray(b) - [400, 0, 400, 0] for f, b in o.boxes.items()})
        )
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


def parked_car_and_person(
    appear_at: tuple[float, float, float, float], start: int = 10, car_speed: float = 0.0
) -> list[Obj]:
    car = Obj(1, CAR, linear(range(30), (700, 200, 880, 300), (car_speed, 0, car_speed, 0)))
    ped = Obj(2, PED, linear(range(start, 30), appear_at, (1, 0, 1, 0)))
    return [car, ped]


LANES = LaneMap(
    (Lane(1, np.array([[560.0, 200], [400, 375]]), np.array([[680.0, 200], [840, 375]])),)
)


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


#: a lead long enough for the scripted cyclist's 1.3 s (the default he_lead_ms is 1 s)
LONG_LEAD = SituationConfig(constants={"he_lead_ms": 5000})


def test_hidden_entity_occurs_while_hidden():
    w = only(run(cyclist_behind_turning_car(), config=LONG_LEAD), "HIDDEN_ENTITY")
    assert w == [(21, "HIDDEN_ENTITY", (1, 2))]  # hidden from frame 21, back at 34


def test_hidden_entity_not_when_reappearing_outside_the_corridor():
    warnings = run(cyclist_far_left())
    assert only(warnings, "HIDDEN_ENTITY") == []
    assert any(k[1] == "REDUCED_VISIBILITY" for k in kinds(warnings)) is False


def test_hidden_entity_not_when_it_will_not_come_out_soon():
    assert only(run(hidden_behind_a_long_bus()), "HIDDEN_ENTITY") == []
    # and not with a lead time shorter than the anticipated one: by default (1 s) from frame
    # 24, when the reappearance at 34 is within 1 s
    assert only(run(cyclist_behind_turning_car()), "HIDDEN_ENTITY") == [
        (24, "HIDDEN_ENTITY", (1, 2))
    ]


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


@pytest.mark.slow
def test_each_situation_is_found_by_some_scene():
    found = set()
    for objs, ctx in SCENES.values():
        found |= {w.situation for w in run(objs, context=ctx) if w.objects}
    assert found == ALL_SITUATIONS


def test_warning_once_per_episode_and_active_list():
    truck = Obj(
        1,
        TRUCK,
        {
            **linear(range(0, 10), (420, 170, 820, 370)),
            **linear(range(25, 30), (420, 170, 820, 370)),
        },
    )
    mon = SituationMonitor(
        SituationConfig(situations={"REDUCED_VISIBILITY"}), fps=10.0, image_size=SIZE
    )
    frames = []
    for r in build_results([truck], 30):
        if mon.update(r):
            frames.append(r.frame)
        if r.frame == 5:
            assert [w.situation for w in mon.active] == ["REDUCED_VISIBILITY"]
    assert frames == [0, 25]  # again after more than rearm_s (1 s) without it


def test_warning_json_round_trip():
    (w,) = [
        w
        for w in run(cyclist_behind_turning_car(), config=LONG_LEAD)
        if w.situation == "HIDDEN_ENTITY"
    ]
    record = w.to_json()
    assert set(record) == {"frame", "situation", "objects", "message", "details"}
    text = json.dumps(record)
    back = SituationWarning.from_json(json.loads(text))
    assert back == w and back.details == w.details
    assert str(w).startswith(
        "[21] HIDDEN_ENTITY: track 1 (cyclist) is hidden behind track 2 (car)"
    )


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
    # the two that look ahead, not back, do not widen it
    ahead = SituationConfig(constants={"he_lead_ms": 9000, "he_path_ms": 9000})
    assert ahead.window_frames(10.0) == 16
    assert SituationConfig(constants={"ev_ms": 9000}).window_frames(10.0) == 91


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

    mon = SituationMonitor(SituationConfig())
    assert [w.situation for w in mon.update(FrameResult(0, Detections.empty()))] == [
        "BLOCKED_LANE"
    ]
    odd = Obj(1, 18, linear(range(5), (420, 170, 820, 370)))  # misc: neither vehicle nor person
    warnings = mon.run(build_results([odd]))
    assert [k[1] for k in kinds(warnings)] == ["REDUCED_VISIBILITY"]


def test_without_image_size_corridor_situations_are_skipped():
    mon = SituationMonitor(fps=10.0, image_size=None)
    assert set(mon.skipped) == {
        "BLOCKED_LANE",
        "HIDDEN_ENTITY",
        "REDUCED_VISIBILITY",
        "SUDDEN_STOP",
    }
    warnings = mon.run(build_results(cyclist_behind_turning_car() + overtaking(ids=(3, 4))))
    notes = {w.situation: w.details["skipped"] for w in warnings if not w.objects}
    assert notes["HIDDEN_ENTITY"] == "needs the image size (for the ego corridor)"
    assert {k[1] for k in kinds(warnings)} == {"OVERTAKING"}


# -- user encodings -------------------------------------------------------------------------------
STOPPED_AHEAD = """
warn(stopped_ahead,(T,)) :- now(N), vehicle(T), in_corridor(T,N), motion(T,N,stopped).
info(stopped_ahead,(T,),since,frame(F)) :- warn(stopped_ahead,(T,)),
                                           F = #min{ G : motion(T,G,stopped) }.
"""


def test_a_new_situation_in_a_user_encoding_is_warned_on_every_frame_where_it_holds(tmp_path):
    """A car in front drives, stands still from frame 10 to 19, drives on: STOPPED_AHEAD (a rule
    of the user's file, nothing in Python) holds exactly while its motion is ``stopped``."""
    rule = tmp_path / "stopped_ahead.lp"
    rule.write_text(STOPPED_AHEAD)
    car = Obj(
        1,
        CAR,
        piecewise(
            [
                (0, (560, 200, 700, 290)),
                (10, (560, 240, 700, 330)),
                (20, (560, 240, 700, 330)),
                (30, (560, 280, 700, 370)),
            ]
        ),
    )
    mon = SituationMonitor(fps=10.0, image_size=SIZE, extra_encodings=[rule])
    plain = SituationMonitor(fps=10.0, image_size=SIZE)
    held, stopped = [], []
    for r in build_results([car], 30):
        mon.update(r)
        plain.update(r)
        if any(w.situation == "STOPPED_AHEAD" for w in mon.active):
            held.append(r.frame)
        if "stopped" in mon._frames[-1].motion.get(1, ()):
            stopped.append(r.frame)
        # the built-in situations are untouched by the extra rules
        assert [w.to_json() for w in mon.active if w.situation != "STOPPED_AHEAD"] == [
            w.to_json() for w in plain.active
        ]
    assert held == stopped and len(held) >= 5
    w = next(w for w in mon.run(build_results([car], 30)) if w.situation == "STOPPED_AHEAD")
    assert w.objects == (1,) and w.details["since"] == w.frame and "stopped ahead" in w.message


def test_user_encoding_errors_name_the_file_and_line(tmp_path):
    bad = tmp_path / "bad.lp"
    bad.write_text("warn(x,(T,)) :- vehicle(T)\n")  # no closing dot
    with pytest.raises(InputError, match="bad.lp:2"):
        SituationMonitor(extra_encodings=[bad])
    unsafe = tmp_path / "unsafe.lp"
    unsafe.write_text("warn(x,(T,)) :- not vehicle(T).\n")
    with pytest.raises(InputError, match="unsafe"):
        SituationMonitor(extra_encodings=[unsafe])
    with pytest.raises(InputError, match="no such situation encoding file"):
        SituationMonitor(extra_encodings=[tmp_path / "missing.lp"])


def test_facts_are_relative_to_now_and_answers_come_back_in_frames_and_ids():
    """Tracks 7 and 9 become indices 0 and 1, frames count back from 0; the answer of a frame is
    read back with ids and frame numbers; the same scene later hits clingo's cached answer."""
    truck = Obj(7, TRUCK, linear(range(100, 104), (420, 170, 820, 370)))
    far = Obj(9, CAR, linear(range(100, 104), (40, 170, 100, 200)))
    results = [r for r in build_results([truck, far], 104) if r.frame >= 100]
    config = SituationConfig(situations={"REDUCED_VISIBILITY"})
    mon = SituationMonitor(config, fps=10.0, image_size=SIZE)
    for r in results:
        mon.update(r)
    facts, tracks = mon._facts()
    assert tracks == [7, 9] and ("now", 0) in facts and ("state", 0, -3, "visible") in facts
    assert ("seq_start", -3) in facts and all(f[2] <= 0 for f in facts if f[0] == "state")
    assert [(w.situation, w.objects) for w in mon.active] == [("REDUCED_VISIBILITY", (7,))]
    assert mon.stats["solver_calls"] + mon.stats["cache_hits"] == 4


def test_a_monitor_pickles_mid_sequence_and_goes_on_with_the_same_warnings(tmp_path):
    import pickle

    rule = tmp_path / "stopped_ahead.lp"
    rule.write_text(STOPPED_AHEAD)
    results = build_results(cyclist_behind_turning_car() + overtaking(ids=(3, 4)))
    mon = SituationMonitor(fps=10.0, image_size=SIZE, extra_encodings=[rule])
    frames = [w.frame for w in SituationMonitor(fps=10.0, image_size=SIZE).run(results)]
    half = next(
        i for i, r in enumerate(results) if r.frame == max(frames)
    )  # before the last warning
    for r in results[:half]:
        mon.update(r)
    copy = pickle.loads(pickle.dumps(mon))
    a = [w.to_json() for r in results[half:] for w in mon.update(r)]
    b = [w.to_json() for r in results[half:] for w in copy.update(r)]
    assert a == b and a


def _with_hiding_confidence(results, level: float):
    """The results with every hides_behind event carrying ``level`` as its confidence."""
    for r in results:
        for i, e in enumerate(r.events):
            if e.name == "hides_behind":
                r.events[i] = dataclasses.replace(e, confidence=level)
    return results


@pytest.mark.parametrize("stream", [True, False])
def test_hidden_entity_carries_its_hidings_confidence(stream):
    results = _with_hiding_confidence(build_results(cyclist_behind_turning_car()), 0.5)
    assert any(e.name == "hides_behind" for r in results for e in r.events)

    def he(conf: int) -> list[SituationWarning]:
        config = SituationConfig(constants={"he_conf": conf})
        mon = SituationMonitor(config, fps=10.0, image_size=SIZE, stream=stream)
        return [w for w in mon.run(results) if w.situation == "HIDDEN_ENTITY"]

    (w,) = he(0)
    assert (w.frame, w.objects) == (24, (1, 2))  # the hiding (frame 21) is in the window
    assert w.details["confidence"] == 0.5 and "confidence_permille" not in w.details
    assert start_record(w)["confidence"] == 0.5
    assert he(500) == [w]  # at the threshold: kept
    assert he(501) == []  # a weaker hiding than asked for: no warning
    # without a confidence on the event: no detail, no record field, not ruled out
    (plain,) = [
        w
        for w in run(
            cyclist_behind_turning_car(), config=SituationConfig(constants={"he_conf": 900})
        )
        if w.situation == "HIDDEN_ENTITY"
    ]
    assert "confidence" not in plain.details and "confidence" not in start_record(plain)
