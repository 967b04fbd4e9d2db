"""Anticipating reappearance of hidden objects (sensemaking.reasoning.anticipation)."""

from __future__ import annotations

import numpy as np
import pytest
from test_scene_helpers import (
    CAR,
    CYC,
    Obj,
    build_results,
    build_scene,
    cyclist_behind_turning_car,
    linear,
)

from sensemaking.reasoning.anticipation import (
    AnticipationConfig,
    anticipate,
    anticipate_scene,
    fit_motion,
    reappearance_errors,
)
from sensemaking.reasoning.context import Corridor
from sensemaking.reasoning.online import SituationMonitor
from sensemaking.reasoning.situations import SituationConfig


def test_fit_motion_recovers_linear_motion():
    f = np.arange(10, 15)
    boxes = np.array([[100 + 3 * t, 50, 140 + 3 * t, 90 + t] for t in range(5)], float)
    last, box, vel = fit_motion(f, boxes)
    assert last == 14 and np.allclose(box, boxes[-1]) and np.allclose(vel, [3, 0, 3, 1])
    last, box, vel = fit_motion(f[:1], boxes[:1])
    assert np.allclose(vel, 0) and np.allclose(box, boxes[0])
    # the span limit drops stale boxes
    last, box, vel = fit_motion(np.array([0, 13, 14]), boxes[[0, 3, 4]], span=2)
    assert np.allclose(vel, [3, 0, 3, 1])


def test_known_reappearance_frame_and_position_exact():
    """Cyclist (linear, +6 px/frame) behind a car (-9 px/frame): hidden 21-33, visible at 34
    with its bottom centre at (658, 254); the prediction at frame 21 is exact."""
    scene = build_scene(cyclist_behind_turning_car())
    (err,) = reappearance_errors(scene)
    assert (err.hidden_from, err.actual_frame, err.predicted_frame) == (21, 34, 34)
    assert err.frame_error == 0 and err.position_error_px == pytest.approx(0.0, abs=1e-6)
    assert err.actual_position == pytest.approx((658.0, 254.0))
    (a,) = anticipate_scene(scene, 21)
    assert (a.track, a.occluder, a.lead_frames, a.lead_s) == (1, 2, 13, pytest.approx(1.3))
    assert a.in_corridor and a.in_image and not a.overdue


def test_error_bound_with_detection_noise(record_property):
    """1 px corner noise on every visible box, 20 seeds: at most 1 frame and 20 px off."""
    frames, px = [], []
    for seed in range(20):
        scene = build_scene(cyclist_behind_turning_car(), noise_px=1.0, seed=seed)
        for e in reappearance_errors(scene):
            frames.append(abs(e.frame_error))
            px.append(e.position_error_px)
    assert len(frames) == 20
    record_property("frame_error_max", max(frames))
    record_property("position_error_px_mean", float(np.mean(px)))
    assert max(frames) <= 1 and float(np.mean(frames)) <= 0.5
    assert max(px) <= 20.0 and float(np.mean(px)) <= 10.0


def test_synthetic_occlusion_suite(record_property):
    """The shared synthetic scenes (straight crossings and turning vehicles): prediction at the
    hiding frame against the ground-truth reappearance (visibility back above 1 - threshold)."""
    synthetic = pytest.importorskip("sensemaking.synthetic")
    suite = synthetic.occlusion_suite(0)
    results = []
    for sc in suite:
        gt = sc.ground_truth
        objs = []
        for i in np.unique(gt.tracker_id):
            m = gt.tracker_id == i
            objs.append(
                Obj(
                    int(i),
                    int(gt.class_id[m][0]),
                    {int(f): b for f, b in zip(gt.frame[m], gt.xyxy[m], strict=False)},
                )
            )
        scene = build_scene(
            objs, sc.n_frames, size=(sc.width, sc.height), hide_cover=0.6, fps=sc.fps
        )
        for e in reappearance_errors(scene, config=AnticipationConfig(reappear_coverage=0.6)):
            m = gt.tracker_id == e.track
            vis = dict(zip(gt.frame[m].tolist(), gt.data["visibility"][m].tolist(), strict=False))
            truth = next(f for f in sorted(vis) if f > e.hidden_from and vis[f] >= 0.4)
            results.append((sc.name, e.predicted_frame - truth, e.position_error_px))
    assert len(results) >= 6
    record_property("anticipation_errors", results)
    assert all(abs(df) <= 1 for _, df, _ in results), results
    assert all(px <= 5.0 for _, _, px in results), results


def test_no_reappearance_when_moving_together():
    f = np.arange(5)
    hidden = np.array([[100 + 5 * t, 50, 140 + 5 * t, 90] for t in f], float)
    occl = np.array([[80 + 5 * t, 40, 200 + 5 * t, 120] for t in f], float)
    assert anticipate(f[:3], hidden[:3], f, occl, 4, fps=10.0) is None
    assert anticipate(f[:0], hidden[:0], f, occl, 4, fps=10.0) is None


def test_overdue_and_outside_the_image():
    f = np.arange(5)
    # stands still beside a static occluder that barely covers it: overdue
    hidden = np.tile([100, 50, 140, 90], (5, 1)).astype(float)
    occl = np.tile([0, 0, 115, 120], (5, 1)).astype(float)
    a = anticipate(f, hidden, f, occl, 6, fps=10.0, image_size=(1242, 375))
    assert a.overdue and a.reappear_frame == 7 and a.lead_frames == 1
    # moves left out of the image before it clears the occluder
    moving = np.array([[300 - 40 * t, 50, 340 - 40 * t, 90] for t in f], float)
    wall = np.tile([-500, 0, 300, 120], (5, 1)).astype(float)
    a = anticipate(f[:2], moving[:2], f, wall, 4, fps=10.0, image_size=(1242, 375))
    assert a is not None and not a.in_image and not a.in_corridor


def test_corridor_decides_in_corridor():
    scene = build_scene(cyclist_behind_turning_car())
    narrow = Corridor(((0.0, 0.9), (0.2, 0.9), (0.2, 0.95), (0.0, 0.95)))
    (a,) = anticipate_scene(scene, 21, corridor=narrow)
    assert not a.in_corridor and a.reappear_frame == 34


def test_online_monitor_warns_with_the_same_prediction_while_hidden():
    results = build_results(cyclist_behind_turning_car())
    lead = SituationConfig(constants={"he_lead_ms": 5000})  # the 1.3 s lead is warned of
    mon = SituationMonitor(lead, fps=10.0, image_size=(1242, 375))
    warned = [w for r in results for w in mon.update(r) if w.situation == "HIDDEN_ENTITY"]
    (w,) = warned
    assert w.frame == 21 and w.objects == (1, 2)
    assert w.details["lead_frames"] == 13 and w.details["lead_s"] == pytest.approx(1.3)
    ant = w.details["anticipation"]
    assert ant["reappear_frame"] == 34 and ant["position"] == [658.0, 254.0] and ant["in_corridor"]
    assert (
        "may reappear in front of the ego vehicle at frame 34 (in 13 frames, 1.3 s)" in w.message
    )
    # issued while hidden: the cyclist is hidden at the warning frame
    assert results[21].state_of(1).name == "HIDDEN"


def test_prediction_follows_the_occluder_during_the_occlusion():
    """A pedestrian stands behind a car that drives off: the reappearance frame is set by the
    occluder's motion, and the online lead time shrinks frame by frame."""
    ped = Obj(1, CYC, linear(range(40), (600, 200, 640, 280)))
    car = Obj(2, CAR, linear(range(40), (340, 190, 500, 300), (10, 0, 10, 0)))
    results = build_results([ped, car])
    mon = SituationMonitor(fps=10.0, image_size=(1242, 375))
    leads = []
    for r in results:
        mon.update(r)
        leads += [(r.frame, a.reappear_frame) for a in mon.anticipations]
    first_visible = next(
        r.frame for r in results if r.frame > 12 and r.state_of(1).name == "VISIBLE"
    )
    assert first_visible == 29
    assert [f for f, _ in leads] == list(range(12, 29)) and all(rf == 29 for _, rf in leads)


def test_first_uncovered_is_the_frame_by_frame_look_ahead():
    # the look-ahead with _box_at and _coverage written out finds what composing them finds:
    # early and late reappearances, none at all, boxes shrinking to the 1 px clamp
    from sensemaking.reasoning.anticipation import _box_at, _coverage, _first_uncovered

    def plain(t_fit, o_fit, now, steps, cov):
        overdue = _coverage(_box_at(*t_fit, now), _box_at(*o_fit, now)) < cov
        for k in range(1, steps + 1):
            tb = _box_at(*t_fit, now + k)
            if _coverage(tb, _box_at(*o_fit, now + k)) < cov:
                return k, tb, overdue and k == 1
        return None

    rng = np.random.default_rng(5)
    found = late = 0
    for it in range(3000):
        tb = rng.uniform(300, 700, 2).tolist()
        tb = tb + [tb[0] + rng.uniform(0.5, 80), tb[1] + rng.uniform(0.5, 80)]
        ob = [
            tb[0] - rng.uniform(0, 60),
            tb[1] - rng.uniform(0, 60),
            tb[2] + rng.uniform(-20, 60),
            tb[3] + rng.uniform(-20, 60),
        ]
        scale = [0.0, 0.05, 1.0, 4.0][it % 4]
        tv = (rng.normal(0, scale, 4)).tolist()
        ov = (np.asarray(tv) + rng.normal(0, scale / 4 + 0.01, 4)).tolist()
        if it % 7 == 0:  # the object shrinks to a point: the clamp to 1 px
            tv = [0.5, 0.5, -0.5, -0.5]
        now, t_last, o_last = 100, 100 - int(rng.integers(0, 5)), 100 - int(rng.integers(0, 2))
        cov = float(rng.choice([0.5, 0.6, 0.9]))
        steps = int(rng.integers(1, 160))
        want = plain((t_last, tb, tv), (o_last, ob, ov), now, steps, cov)
        assert _first_uncovered(t_last, tb, tv, o_last, ob, ov, now, steps, cov) == want
        found += want is not None
        late += want is not None and want[0] > 12
    assert found > 500 and late > 100 and 3000 - found > 500


# -- the pinhole motion model -----------------------------------------------------------------
def _project(
    x: float, y: float, z: float, w: float, h: float, size=(1242, 375), f=700.0
) -> list[float]:
    """The box of an object w x h metres standing at (x, y, z) metres before a pinhole camera
    (focal length f px, principal point at the image centre)."""
    cx, cy = size[0] / 2, size[1] / 2
    xc, y2 = cx + f * x / z, cy + f * y / z
    return [xc - f * w / z / 2, y2 - f * h / z, xc + f * w / z / 2, y2]


def test_pinhole_model_is_exact_for_constant_velocity_in_3d():
    """A pedestrian 22 m ahead walks slowly; a car 14 m ahead comes closer and crosses in front
    of it from left to right. Seen through a pinhole camera the car accelerates across the image
    and grows: the pinhole model predicts the reappearance exactly, the linear one 9 frames
    late."""
    frames = np.arange(40)
    ped = np.array([_project(1.0 - 0.02 * t, 1.65, 22.0 - 0.2 * t, 0.6, 1.7) for t in frames])
    car = np.array([_project(-2.0 + 0.12 * t, 1.65, 14.0 - 0.3 * t, 1.8, 1.5) for t in frames])
    from sensemaking.reasoning.anticipation import _coverage

    cover = [_coverage(list(p), list(c)) for p, c in zip(ped, car, strict=False)]
    now = next(f for f in frames if cover[f] >= 0.5)
    back = next(f for f in frames if f > now and cover[f] < 0.5)
    truth = ((ped[back][0] + ped[back][2]) / 2, ped[back][3])
    got = {}
    for model in ("pinhole", "linear"):
        a = anticipate(
            frames[:now],
            ped[:now],
            frames[: now + 1],
            car[: now + 1],
            int(now),
            fps=10.0,
            image_size=(1242, 375),
            config=AnticipationConfig(motion_model=model),
        )
        got[model] = a.reappear_frame
        if model == "pinhole":
            assert a.position == pytest.approx(truth, abs=1e-6)
    assert got == {"pinhole": back, "linear": back + 9}


def test_pinhole_model_an_occluder_passing_the_camera_uncovers():
    # a truck 4 m high right in front comes at the camera, 0.9 m a frame, and hides a person
    # 30 m away: at frame 11 it is 0.1 m from the camera's plane and covers the whole view; its
    # fitted 1/h reaches zero before frame 12: it has passed and covers nothing any more
    frames = np.arange(10)
    ped = np.array([_project(0.0, 1.65, 30.0, 0.6, 1.7) for _ in frames])
    truck = np.array([_project(0.0, 1.65, 10.0 - 0.9 * t, 2.5, 4.0) for t in frames])
    car = truck
    a = anticipate(
        frames[:1],
        ped[:1],
        frames,
        car,
        9,
        fps=10.0,
        image_size=(1242, 375),
        config=AnticipationConfig(motion_model="pinhole"),
    )
    assert a is not None and a.reappear_frame == 12 and not a.overdue
    assert a.position == pytest.approx(((ped[0][0] + ped[0][2]) / 2, ped[0][3]))
    assert (
        anticipate(frames[:1], ped[:1], frames, car, 9, fps=10.0, image_size=(1242, 375)) is None
    )


def test_motion_model_is_checked():
    with pytest.raises(ValueError, match="motion_model"):
        AnticipationConfig(motion_model="quadratic")
