"""Motion in the world: camera geometry, the ego-speed estimate, world velocities, and the
situations that read them (a car driving with the ego car is not stopped, a parked car passed
is not approaching)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_scene_helpers import CAR, PED, Obj, build_results

from sensemaking.io.egomotion import EgoMotion
from sensemaking.reasoning.egomotion import (
    CameraModel,
    EgoMotionConfig,
    WorldMotion,
    estimate_ego_speed,
)
from sensemaking.reasoning.online import SituationMonitor
from sensemaking.reasoning.situations import SituationConfig, SituationSolver

CAM = CameraModel.kitti()
SIZE = (1242, 375)
FPS = 10.0


def car_box(z: float, x: float, width_m: float = 1.7, height_m: float = 1.5) -> list[float]:
    """The image box (px) of a car whose road contact is ``z`` m ahead, ``x`` m to the right."""
    bottom = CAM.horizon_px + CAM.focal_px * CAM.height_m / z
    cx = CAM.cx_px + CAM.focal_px * x / z
    half = CAM.focal_px * width_m / z / 2
    return [cx - half, bottom - CAM.focal_px * height_m / z, cx + half, bottom]


def world_boxes(frames: range, z0: float, x: float, rel_speed: float) -> dict[int, list[float]]:
    """Boxes of an object at lateral ``x`` whose distance changes by ``rel_speed`` m/s, in the
    frames where it is 5 to 30 m ahead."""
    zs = {f: z0 + rel_speed * f / FPS for f in frames}
    return {f: car_box(z, x) for f, z in zs.items() if 5.0 <= z <= 30.0}


def parked_row(frames: range, ego_speed: float, first_id: int = 10) -> list[Obj]:
    """Cars parked every 7 m on both sides of the road, passed at ``ego_speed`` m/s."""
    out = []
    for k in range(8):
        boxes = world_boxes(frames, 12.0 + 7.0 * k, -5.0 if k % 2 else 5.5, -ego_speed)
        if boxes:
            out.append(Obj(first_id + k, CAR, boxes))
    return out


# -- geometry -------------------------------------------------------------------------------------
def test_ground_position_inverts_the_projection():
    boxes = np.array([car_box(z, x) for z, x in [(8.0, -3.0), (20.0, 0.0), (35.0, 4.5)]])
    z, x = CAM.ground_position(boxes, SIZE[1])
    assert np.allclose(z, [8.0, 20.0, 35.0]) and np.allclose(x, [-3.0, 0.0, 4.5])
    # at or above the horizon, beyond the range, or cut by the image's bottom edge: unknown
    odd = np.array([[0, 100, 50, 170], [0, 150, 50, 180], [0, 300, 50, 374.5]], dtype=float)
    assert np.isnan(CAM.ground_position(odd, SIZE[1])[0]).all()


def test_camera_parse_and_bad_values():
    cam = CameraModel.parse("700, 1.5, 180, 600")
    assert (cam.focal_px, cam.height_m, cam.horizon_px, cam.cx_px) == (700, 1.5, 180, 600)
    with pytest.raises(ValueError, match="4 numbers"):
        CameraModel.parse("700,1.5")
    with pytest.raises(ValueError, match="height_m"):
        CameraModel.parse("700,-1,180,600")


# -- the ego-speed estimate -----------------------------------------------------------------------
def test_ego_speed_recovered_from_static_objects_within_0_4_metres_per_second():
    rng = np.random.default_rng(3)
    for speed in (0.0, 4.0, 8.3, 14.0, 25.0):
        static = speed + rng.normal(0.0, 0.5, 7)  # -dZ/dt of parked cars, 0.5 m/s noise
        moving = np.array([speed - 9.0, speed + 12.0, speed - 3.5])  # traffic
        got = estimate_ego_speed(
            np.r_[static, moving], np.full(10, 0.5), bandwidth=0.7, max_speed=45.0
        )
        assert got is not None
        assert abs(got[0] - speed) <= 0.4, (speed, got)  # 2 sd of the mean of 7
        assert got[2] >= 6  # (nearly) all the parked cars agree


def test_no_ego_speed_from_a_single_object_without_a_prior():
    assert estimate_ego_speed(np.array([7.0]), np.array([0.3]), 0.7, 45.0) is None
    kept = estimate_ego_speed(np.array([7.0]), np.array([0.3]), 0.7, 45.0, prior=7.2, reach=1.0)
    assert kept is not None and abs(kept[0] - 7.0) < 0.1


def test_world_motion_estimates_the_ego_speed_and_world_velocities():
    """Ego at 10 m/s past parked cars at the sides, a lead car at constant distance."""
    frames = range(20)
    world = WorldMotion(CAM, FPS, SIZE)
    static = [(30.0, -4.0), (38.0, 5.0), (34.0, -6.0), (40.0, 4.0)]
    ego = motion = None
    for f in frames:
        ids, boxes = [1], [car_box(14.0, 0.3)]  # lead car, 14 m ahead, drives at the ego's speed
        for k, (z0, x) in enumerate(static):
            ids.append(10 + k)
            boxes.append(car_box(z0 - 10.0 * f / FPS, x))
        ego, motion = world.update(f, ids, np.array(boxes))
    assert ego is not None and ego.source == "scene" and ego.support >= 3
    assert ego.speed == pytest.approx(10.0, abs=0.3)
    lead = motion[1]
    assert lead.v_long == pytest.approx(10.0, abs=0.5) and lead.ttc_s == math.inf
    for k in range(len(static)):
        assert motion[10 + k].speed < 0.5  # parked: stopped over the road
        assert motion[10 + k].closing == pytest.approx(10.0, abs=0.3)


def test_ego_motion_file_takes_precedence():
    file = EgoMotion(np.array([0, 100]), np.array([6.0, 6.0]), None, "ego.csv")
    world = WorldMotion(CAM, FPS, SIZE, ego_motion=file)
    for f in range(8):
        ego, motion = world.update(f, [1], np.array([car_box(20.0, 0.0)]))
    assert ego is not None and ego.source == "file" and ego.speed == 6.0
    assert motion[1].v_long == pytest.approx(6.0, abs=0.2)


def test_ego_estimate_follows_the_reachable_mode():
    """Parked cars at 8 m/s, then they leave and a group at another speed comes: the estimate
    is held, not switched to a speed the ego cannot reach in a frame."""
    world = WorldMotion(CAM, FPS, SIZE, config=EgoMotionConfig(hold_s=1.0))
    for f in range(12):
        boxes = [car_box(30.0 - 8.0 * f / FPS, x) for x in (-4.0, 4.5, -6.0)]
        ego, _ = world.update(f, [1, 2, 3], np.array(boxes))
    assert ego is not None and ego.speed == pytest.approx(8.0, abs=0.3)
    for f in range(12, 18):  # three cars at constant distance (traffic moving along)
        boxes = [car_box(20.0, x) for x in (-4.0, 4.5, -6.0)]
        ego, _ = world.update(f, [4, 5, 6], np.array(boxes))
    assert ego is not None and ego.source == "held" and ego.speed == pytest.approx(8.0, abs=0.3)


# -- the situations over the road -----------------------------------------------------------------
def monitor(ego_speed: float | None, situations=("EXITING_VEHICLE", "SUDDEN_STOP", "OVERTAKING")):
    file = (
        None
        if ego_speed is None
        else EgoMotion(np.array([0, 1000]), np.array([ego_speed, ego_speed]), None, "ego.csv")
    )
    return SituationMonitor(
        SituationConfig(situations=frozenset(situations)),
        fps=FPS,
        image_size=SIZE,
        camera=CAM,
        ego_motion=file,
    )


def car_and_person(car: dict[int, list[float]], person_from: int = 12) -> list[Obj]:
    """A car, and a person appearing (not at the border) right beside it at ``person_from``."""
    boxes = {}
    for f in range(person_from, max(car) + 1):
        x1, y1, x2, y2 = car[f]
        boxes[f] = [x2 - 2.0, y2 - 0.9 * (y2 - y1) * 1.2, x2 + 0.3 * (x2 - x1), y2]
    return [Obj(1, CAR, car), Obj(2, PED, boxes)]


def warnings_of(mon: SituationMonitor, objs: list[Obj]) -> list[tuple[str, tuple[int, ...]]]:
    return [(w.situation, w.objects) for r in build_results(objs) for w in mon.update(r)]


def test_a_car_moving_with_the_ego_car_is_not_stopped():
    frames = range(25)
    car = {f: car_box(12.0, 2.5) for f in frames}  # a constant box: it drives at the ego's speed
    # seen from a standing camera (file: 0 m/s) the car stands still: a person getting out
    assert ("EXITING_VEHICLE", (2, 1)) in warnings_of(monitor(0.0), car_and_person(car))
    # from the ego driving at 9 m/s (file) the same box is a car driving at 9 m/s
    mon = monitor(9.0)
    assert warnings_of(mon, car_and_person(car)) == []
    assert mon._frames[-1].world[1].v_long == pytest.approx(9.0, abs=0.3)
    # and with the ego speed estimated from parked cars at the sides
    mon = monitor(None)
    got = warnings_of(mon, car_and_person(car) + parked_row(frames, 9.0))
    assert ("EXITING_VEHICLE", (2, 1)) not in got
    ego = mon._frames[-1].ego
    assert ego is not None and ego.source == "scene" and ego.speed == pytest.approx(9.0, abs=0.5)


def test_a_parked_car_passed_by_the_ego_car_is_stopped_not_approaching():
    frames = range(25)
    parked = world_boxes(frames, 28.0, 3.0, -8.0)  # grows and slides right in the image
    mon = monitor(None)
    got = warnings_of(mon, car_and_person(parked) + parked_row(frames, 8.0))
    # stopped: a person appearing beside it may be getting out; not a vehicle braking ahead
    assert ("EXITING_VEHICLE", (2, 1)) in got
    assert not [w for w in got if w[0] in ("SUDDEN_STOP", "OVERTAKING")]
    m = mon._frames[-1].world[1]
    assert m.speed < 0.5 and m.closing == pytest.approx(8.0, abs=0.5)


def test_a_sudden_stop_in_the_world_states_its_confidence():
    """A car 14 m ahead keeping the ego's 9 m/s brakes at 8 m/s^2: the warning's record says
    how sure it is (the rule's quarters, 0..1); no other detail depends on it."""
    z, v, boxes = 14.0, 9.0, {}
    for f in range(30):
        boxes[f] = car_box(z, 0.2)
        v = max(0.0, v - 8.0 / FPS) if f >= 12 else v
        z += (v - 9.0) / FPS
    mon = monitor(9.0, ("SUDDEN_STOP",))
    got = [w for r in build_results([Obj(1, CAR, boxes)]) for w in mon.update(r)]
    assert [w.situation for w in got] == ["SUDDEN_STOP"]
    assert got[0].details["confidence"] in (0.25, 0.5, 0.75, 1.0)
    assert "confidence_permille" not in got[0].details


# -- the rules on facts ---------------------------------------------------------------------------
HEAD = (
    "camera. now(0). frame_ms(100). vehicle(1). vehicle(2). "
    + " ".join(f"ego_speed({g},1000)." for g in range(-10, 1))
    + " "
)


def sit(program: str, part: str, head: str = HEAD) -> list[str]:
    import clingo

    facts = []
    for text in (head + program).split("."):
        if text.strip():
            facts.append(_fact(clingo.parse_term(text.strip())))
    return sorted(str(s) for s in SituationSolver([part]).answer(tuple(facts)))


def _fact(sym):
    import clingo

    if sym.type == clingo.SymbolType.Number:
        return sym.number
    return (sym.name, *map(_fact, sym.arguments)) if sym.arguments else sym.name


def braking_car(speeds: list[int], z: int, closing: int, x: int = 0) -> str:
    """Facts of car 1 at frames -len+1..0: world speeds (cm/s, error 30), distance, closing."""
    n = len(speeds)
    out = [
        f"world_speed(1,{g},{s},30). world_long(1,{g},{s}). position(1,{g},{z},{x}). "
        f"closing(1,{g},{closing},40)."
        for g, s in zip(range(-n + 1, 1), speeds, strict=True)
    ]
    return " ".join(out)


def test_sudden_stop_in_the_world():
    hard = braking_car([900, 800, 650, 500, 350, 200], z=1200, closing=500)
    assert sit(hard, "sudden_stop")[-1] == "warn(sudden_stop,(1,))"
    # the same braking, far ahead (time to contact 24 s): no hazard
    assert (
        sit(braking_car([900, 800, 650, 500, 350, 200], z=12000, closing=500), "sudden_stop") == []
    )
    # in the next lane
    assert sit(braking_car([900, 800, 650, 500, 350, 200], 1200, 500, x=350), "sudden_stop") == []
    # closing at 5 m/s +- 2 m/s, 12 m ahead: contact in 2.4 s, or in 12 s: not shown to be soon
    unsure = braking_car([900, 800, 650, 500, 350, 200], 1200, 500).replace(
        ",500,40)", ",500,200)"
    )
    assert sit(unsure, "sudden_stop") == []
    # gentle braking (1 m/s^2)
    assert sit(braking_car([900, 890, 880, 870, 860, 850], 1200, 500), "sudden_stop") == []
    # rolling to a standstill (2 m/s to 0.4 m/s in 1 s: 1.6 m/s^2) is no sudden stop
    rolling = [200 - 16 * k for k in range(11)]
    assert sit(braking_car(rolling, 1200, 500), "sudden_stop") == []
    assert "info(sudden_stop,(1,),cause,stopping)" in sit(
        braking_car([900, 900, 700, 400, 100, 10], 1200, 500), "sudden_stop"
    )
    # a parked car the ego drives towards: stopped all along, never moved
    assert sit(braking_car([10, 20, 10, 0, 10, 20], 1200, 1000), "sudden_stop") == []


def _confidence(answer: list[str], situation: str) -> int | None:
    """The confidence_permille of the one warning of ``answer``, None if it states none."""
    found = [a for a in answer if a.startswith(f"info({situation},") and "confidence" in a]
    assert len(found) <= 1
    return int(found[0].rsplit(",", 1)[1].rstrip(")")) if found else None


def test_sudden_stop_confidence_grows_with_its_margins():
    hard = [900, 800, 650, 500, 350, 200]  # 7 m/s lost against errors of 0.6 m/s: braking 4/4
    # 12 m at 5 - 2 * 0.4 m/s: contact in 2.9 s at worst, within 3/4 of ss_ttc (4 s): 2 of 4
    assert _confidence(sit(braking_car(hard, 1200, 500), "sudden_stop"), "sudden_stop") == 500
    # the same braking 4 m ahead: 0.95 s at worst, within a quarter of ss_ttc: 4 of 4
    assert _confidence(sit(braking_car(hard, 400, 500), "sudden_stop"), "sudden_stop") == 1000
    # 16 m ahead: 3.8 s at worst, just within ss_ttc: 1 of 4
    assert _confidence(sit(braking_car(hard, 1600, 500), "sudden_stop"), "sudden_stop") == 250
    # braking by 2.5 times the speeds' errors (1.5 m/s in 0.5 s), near: the braking decides, 2
    near_mild = braking_car([900, 900, 900, 900, 750, 750], 400, 500)
    assert _confidence(sit(near_mild, "sudden_stop"), "sudden_stop") == 500
    # the warnings themselves do not change: the one far ahead still has none
    assert sit(braking_car(hard, 12000, 500), "sudden_stop") == []


def test_overtaking_confidence_grows_with_the_depth_margins():
    def pair(sd: int, now_a: int = 1900) -> str:
        rows = []
        for g, za in zip(range(-5, 1), [800, 1000, 1200, 1500, 1700, now_a], strict=True):
            rows.append(
                f"position(1,{g},{za},-300). position(2,{g},1500,200). "
                f"position_sd(1,{g},{sd}). position_sd(2,{g},{sd}). "
                f"world_speed(1,{g},1300,20). world_long(1,{g},1300). "
                f"world_speed(2,{g},900,20). world_long(2,{g},900)."
            )
        return " ".join(rows)

    # 3 m apart now beyond the 1 m gap, errors 2 x 0.3 m: 4 of 4 (and 6 m before)
    assert _confidence(sit(pair(30), "overtaking"), "overtaking") == 1000
    # errors 2 x 0.6 m: 2.5 error sums now, 5 before: the weaker, 2 of 4
    assert _confidence(sit(pair(60), "overtaking"), "overtaking") == 500
    # just past now (1.7 m beyond the gap against errors of 1.2 m): 1 of 4
    assert _confidence(sit(pair(60, now_a=1770), "overtaking"), "overtaking") == 250


def test_overtaking_in_the_world_needs_a_moving_overtaken_vehicle():
    def pair(b_speed: int) -> str:
        rows = []
        for g, (za, zb) in zip(
            range(-5, 1),
            [(800, 1500), (1000, 1500), (1200, 1500), (1500, 1500), (1700, 1500), (1900, 1500)],
            strict=False,
        ):
            rows.append(
                f"position(1,{g},{za},-300). position(2,{g},{zb},200). "
                f"position_sd(1,{g},30). position_sd(2,{g},30). "
                f"world_speed(1,{g},{b_speed + 400},20). world_long(1,{g},{b_speed + 400}). "
                f"world_speed(2,{g},{b_speed},20). world_long(2,{g},{b_speed})."
            )
        return " ".join(rows)

    assert "warn(overtaking,(1,2))" in sit(pair(900), "overtaking")
    assert sit(pair(0), "overtaking") == []  # passing a parked car is not overtaking
    # a flip within the distances' errors (2 m each) is no evidence of passing
    noisy = (
        pair(900)
        .replace("position_sd(1,", "position_sd(9,")
        .replace("position_sd(2,", "position_sd(8,")
    )
    noisy += " " + " ".join(f"position_sd({t},{g},200)." for t in (1, 2) for g in range(-5, 1))
    assert sit(noisy, "overtaking") == []
    assert sit(pair(-900), "overtaking") == []  # nor passing oncoming traffic
    # B crosses the road (sideways 6 m/s against 9 m/s along: 34 degrees off the ego's heading)
    crossing = pair(900) + " " + " ".join(f"world_lat(2,{g},600)." for g in range(-5, 1))
    assert sit(crossing, "overtaking") == []
    # the same pair, heading 13 degrees off: still overtaking
    slanted = pair(900) + " " + " ".join(f"world_lat(2,{g},200)." for g in range(-5, 1))
    assert "warn(overtaking,(1,2))" in sit(slanted, "overtaking")
    # two lanes and more apart sideways (7 m: across the road), not neighbours
    assert sit(pair(900).replace(",-300).", ",-500)."), "overtaking") == []
    # B at 9 +- 5 m/s: not shown to move, nor to move the ego's way (two standard errors)
    unsure = pair(900).replace("world_speed(2,", "world_speed(9,")
    unsure += " " + " ".join(f"world_speed(2,{g},900,500)." for g in range(-5, 1))
    assert sit(unsure, "overtaking") == []


def test_reduced_visibility_in_the_world_is_about_the_ego_lane():
    def car(z: int, x: int, hides: bool = False) -> str:
        return (
            "track(1,car). vehicle(1). state(1,0,visible). in_corridor(1,0). area(1,0,200). "
            f"position(1,0,{z},{x}). position_sd(1,0,30). camera. profile(driving)."
            + (" track(2,car). state(2,0,hidden). hidden_by(2,1,0)." if hides else "")
        )

    near_ahead = sit(car(800, 50), "reduced_visibility", head="now(0). frame_ms(100). ")
    assert "warn(reduced_visibility,(1,))" in near_ahead
    assert "info(reduced_visibility,(1,),distance_cm,800)" in near_ahead
    # parked beside the ego lane, however large in the image
    assert sit(car(600, 300), "reduced_visibility", head="now(0). frame_ms(100). ") == []
    # far ahead in the lane: only when it hides something
    assert sit(car(3000, 0), "reduced_visibility", head="now(0). frame_ms(100). ") == []
    far_hiding = sit(
        car(3000, 0, hides=True), "reduced_visibility", head="now(0). frame_ms(100). "
    )
    assert "warn(reduced_visibility,(1,))" in far_hiding


def test_with_a_camera_and_no_ego_speed_image_motion_claims_nothing():
    """A moving camera's image motion is not the objects': without an ego speed yet, the image
    rules stay off (they apply only without a camera model, i.e. a fixed camera)."""
    stopping = (
        "vehicle(1). in_corridor(1,0). area(1,0,50). motion(1,0,stopping). "
        "track(1,car). now(0). frame_ms(100). "
    )
    # (the image rule states no confidence: no standard errors to weigh its evidence against)
    assert sit(stopping, "sudden_stop", head="") == [
        "info(sudden_stop,(1,),cause,stopping)",
        "warn(sudden_stop,(1,))",
    ]
    assert sit(stopping, "sudden_stop", head="camera. ") == []


def test_stories_say_motion_over_the_road_in_km_h_and_metres(tmp_path):
    from sensemaking.reasoning.questions import explain
    from sensemaking.scene import Scene, SceneRecorder

    frames = range(25)
    objs = [Obj(1, CAR, {f: car_box(12.0, 2.5) for f in frames})] + parked_row(frames, 9.0)
    objs.append(Obj(2, CAR, world_boxes(frames, 28.0, 3.0, -9.0)))
    rec = SceneRecorder(FPS, SIZE, metadata={"camera": CAM.to_json()})
    for r in build_results(objs):
        rec.add(r)
    path = tmp_path / "scene.json"
    rec.scene().save(path)
    scene = Scene.load(path)  # the camera travels with the scene file
    moving = " ".join(explain(scene, 1))
    assert "drives the ego vehicle's way at about 32 km/h" in moving  # 9 m/s
    assert "12 m ahead" in moving and "px/s" not in moving
    parked = " ".join(explain(scene, 2))
    assert "stands still, from 28 m to" in parked and "comes closer" not in parked
    # recorded without a camera model: the image story, as before
    plain = SceneRecorder(FPS, SIZE)
    for r in build_results(objs):
        plain.add(r)
    assert "stands still" not in " ".join(explain(plain.scene(), 2))


def test_hidden_entity_severity_from_the_path_in_the_world():
    def hidden(z: int, x: int, vz: int, vx: int) -> list[str]:
        facts = (
            "profile(driving). track(1,car). track(2,car). state(1,0,hidden). "
            "hidden_by(1,2,0). anticipated(1,2,5,600,250). anticipated_in_corridor(1,2,5). "
            f"hidden_motion(1,{z},{x},{vz},{vx})."
        )
        return sit(facts, "hidden_entity")

    def severity(answer: list[str]) -> list[str]:
        return [a for a in answer if ",severity," in a]

    # 20 m ahead, 3 m to the left, closing at 8 m/s and drifting right at 1.5 m/s: in the ego
    # lane after 0.9 s, 12.8 m ahead, contact 1.6 s later
    crossing = hidden(2000, -300, -800, 150)
    assert "warn(hidden_entity,(1,2))" in crossing
    assert severity(crossing) == ["info(hidden_entity,(1,2),severity,3)"]
    assert "info(hidden_entity,(1,2),ego_path_ms,900)" in crossing
    # parked 6 m to the left: never in the ego lane
    assert severity(hidden(2000, -600, -800, 0)) == ["info(hidden_entity,(1,2),severity,2)"]
    # in the lane but 60 m ahead: contact in 7.5 s, not within ss_ttc
    assert severity(hidden(6000, 0, -800, 0)) == ["info(hidden_entity,(1,2),severity,2)"]
    # in the lane, moving away
    assert severity(hidden(2000, 0, 100, 0)) == ["info(hidden_entity,(1,2),severity,2)"]


def test_the_monitor_takes_a_3d_detectors_position_from_the_tracks():
    frames = range(5)
    results = build_results([Obj(1, CAR, {f: car_box(12.0, 0.5) for f in frames})])
    for r in results:  # the tracker's output with a 3D detector: 30 m ahead, 2 m to the left
        r.tracks.data["detection_location"] = np.array([[-2.0, 1.6, 30.0]] * len(r.tracks))
    on = EgoMotionConfig(detection_location=True)
    mon = SituationMonitor(fps=FPS, image_size=SIZE, camera=CAM, ego_config=on)
    mon.run(results)
    m = mon._frames[-1].world[1]
    assert (m.z, m.x) == (30.0, -2.0)
    # by default (it did not pass the keep rule on PointRCNN): from the box on a flat road
    plain = SituationMonitor(fps=FPS, image_size=SIZE, camera=CAM)
    plain.run(results)
    assert plain._frames[-1].world[1].z == pytest.approx(12.0, abs=0.5)
