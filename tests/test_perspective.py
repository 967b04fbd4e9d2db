"""The pinhole filter (``kalman.perspective``): exact where the pixel filter is not, same API."""

from __future__ import annotations

import numpy as np
import pytest

from sensemaking.abduction.components import SolverCache
from sensemaking.classes import CLASS_IDS
from sensemaking.config import ParameterError, TrackerConfig
from sensemaking.detections import Detections
from sensemaking.motion import KalmanBank, KalmanConfig, PerspectiveBank, motion_bank
from sensemaking.tracker import Tracker

CAR = CLASS_IDS["car"]
F, X0, Y0 = 721.5, 609.6, 172.9  # KITTI's camera: focal length and principal point, pixels


def _box(x: float, y: float, z: float, w: float = 0.6, h: float = 1.7) -> np.ndarray:
    """(1, 4) image box of an object at x, y, z metres (camera frame), w x h metres."""
    cx, cy, bw, bh = X0 + F * x / z, Y0 + F * y / z, F * w / z, F * h / z
    return np.array([[cx - bw / 2, cy - bh / 2, cx + bw / 2, cy + bh / 2]])


def _config(**kw: float) -> KalmanConfig:
    return KalmanConfig(velocity_std=1 / 160, **kw)  # type: ignore[arg-type]


def _centre_error(bank: KalmanBank | PerspectiveBank, gap: int, truth: np.ndarray) -> float:
    p = bank.peek(gap)[0]
    return float(np.abs((p[:2] + p[2:]) / 2 - (truth[0, :2] + truth[0, 2:]) / 2).max())


def _follow(bank: KalmanBank | PerspectiveBank, path: list[np.ndarray]) -> None:
    bank.add(path[0])
    for z in path[1:]:
        bank.predict(1)
        bank.update(np.array([0]), z)


def test_a_parked_object_passed_by_a_driving_camera_is_predicted_exactly() -> None:
    # the camera drives at 1 m a frame past an object 4 m to the side: in pixels it accelerates
    path = [_box(4.0, 0.8, 40.0 - t) for t in range(12)]
    truth = _box(4.0, 0.8, 40.0 - 21)
    pixels, pinhole = (
        KalmanBank(_config()),
        PerspectiveBank(_config(perspective=True, perspective_x=X0, perspective_y=Y0)),
    )
    _follow(pixels, path)
    _follow(pinhole, path)
    assert _centre_error(pinhole, 10, truth) < 1.0
    assert _centre_error(pixels, 10, truth) > 10.0


def test_a_person_walking_past_a_standing_camera_is_predicted_as_in_pixels() -> None:
    path = [_box(-3.0 + 0.1 * t, 0.8, 15.0) for t in range(12)]
    truth = _box(-3.0 + 0.1 * 21, 0.8, 15.0)
    pinhole = motion_bank(_config(perspective=True, perspective_x=X0, perspective_y=Y0))
    assert isinstance(pinhole, PerspectiveBank)
    _follow(pinhole, path)
    assert _centre_error(pinhole, 10, truth) < 1.0


def test_velocity_is_the_pixel_rate_of_change() -> None:
    bank = PerspectiveBank(_config(perspective=True, perspective_x=X0, perspective_y=Y0))
    _follow(bank, [_box(3.0 + 0.05 * t, 0.8, 30.0 - 0.5 * t) for t in range(8)])
    before, v = bank.cxcywh(), bank.velocity()
    after = bank.peek(1)
    c = np.column_stack([(after[:, :2] + after[:, 2:]) / 2, after[:, 2:] - after[:, :2]])
    # one frame ahead the box moved by the velocity, to first order
    assert np.allclose(c - before, v, rtol=0.05, atol=0.05)
    assert np.allclose(bank.motion(np.array([0]))[0, 1], v[0, :2])


def test_rows_are_taken_removed_extended_and_copied_whole() -> None:
    bank = PerspectiveBank(_config(perspective=True, perspective_x=X0, perspective_y=Y0))
    boxes = np.concatenate([_box(x, 0.8, 20.0) for x in (-2.0, 0.0, 2.0)])
    bank.add(boxes)
    part = bank.take(np.array([2, 0]))
    assert np.allclose(part.xyxy(), boxes[[2, 0]])
    copy = bank.copy()
    bank.remove(np.array([1]))
    assert len(bank) == 2 and len(copy) == 3
    bank.extend(part)
    assert np.allclose(bank.xyxy(), boxes[[0, 2, 2, 0]])
    with pytest.raises(TypeError):
        bank.extend(KalmanBank(_config()))


def test_reupdate_after_a_gap_lands_on_the_new_box() -> None:
    bank = PerspectiveBank(_config(perspective=True, perspective_x=X0, perspective_y=Y0))
    _follow(bank, [_box(3.0, 0.8, 30.0 - 0.5 * t) for t in range(6)])
    bank.predict(5)
    seen = _box(3.0, 0.8, 30.0 - 0.5 * 11)
    bank.reupdate(np.array([0]), seen, np.array([5]))
    assert np.abs(bank.xyxy() - seen).max() < 2.0
    assert np.allclose(bank.observed(), seen)
    with pytest.raises(ValueError, match="gaps"):
        bank.reupdate(np.array([0]), seen, np.array([-1]))


def test_shift_and_damp_move_the_box_and_its_velocity_in_pixels() -> None:
    bank = PerspectiveBank(_config(perspective=True, perspective_x=X0, perspective_y=Y0))
    _follow(bank, [_box(3.0 + 0.1 * t, 0.8, 20.0) for t in range(6)])
    before, v = bank.xyxy(), bank.velocity()
    bank.shift(np.array([0]), np.array([12.0, -3.0]), np.array([1.0, 0.0]))
    assert np.allclose(bank.xyxy() - before, [[12.0, -3.0, 12.0, -3.0]])
    assert abs(bank.velocity()[0, 0] - v[0, 0] - 1.0) < 0.02  # and u's share of the growth
    bank.damp(np.array([0]), 0.0)
    assert np.allclose(bank.velocity(), 0.0)


def test_the_principal_point_is_the_image_centre_unless_given() -> None:
    cfg = TrackerConfig(image_size=(1242, 375), kalman=KalmanConfig(perspective=True))
    k = cfg.kalman_config
    assert (k.perspective_x, k.perspective_y) == (621.0, 187.5)
    given = KalmanConfig(perspective=True, perspective_x=X0, perspective_y=Y0)
    assert TrackerConfig(image_size=(1242, 375), kalman=given).kalman_config.perspective_x == X0
    with pytest.raises(ParameterError, match="principal point"):
        TrackerConfig(kalman=KalmanConfig(perspective=True))
    with pytest.raises(ValueError, match="together"):
        KalmanConfig(perspective_x=X0)
    assert isinstance(motion_bank(KalmanConfig()), KalmanBank)


def _ids_through_a_gap(perspective: bool) -> list[list[int]]:
    """Ids per frame of a car 6 m to the side that a camera driving 1.5 m a frame passes; it is
    hidden on frames 8-16."""
    kalman = KalmanConfig(velocity_std=1 / 160, perspective=perspective)
    tracker = Tracker(
        TrackerConfig(fps=10.0, image_size=(1242, 375), kalman=kalman),
        solver_cache=SolverCache(),
    )
    out = []
    for f in range(22):
        box = _box(6.0, 0.8, 40.0 - 1.5 * f, w=1.8, h=1.5)
        seen = Detections(box, confidence=0.9, class_id=CAR)
        r = tracker.update(Detections.empty() if 8 <= f <= 16 else seen, frame=f)
        out.append(r.tracks.tracker_id.tolist())
    return out


def test_the_tracker_keeps_the_passed_car_with_the_pinhole_filter_only() -> None:
    pinhole, pixels = _ids_through_a_gap(True), _ids_through_a_gap(False)
    assert pinhole[7] == pinhole[-1] and len(pinhole[7]) == 1
    assert pixels[7] != pixels[-1]  # the pixel filter's stiff prediction missed it


def _lateral_error(depth_noise: float, seed: int) -> float:
    """Pixels off, 10 frames ahead, for a person walking past a standing camera at a constant
    depth, far from the principal point, whose box heights jitter by 20 % (legs and heads
    cut and found again)."""
    rng = np.random.default_rng(seed)
    bank = PerspectiveBank(
        _config(perspective=True, perspective_x=X0, perspective_y=Y0, depth_noise=depth_noise)
    )
    path = [_box(-6.0 + 0.1 * t, 0.8, 12.0) for t in range(21)]
    for t, z in enumerate(path):
        h = z[0, 3] - z[0, 1]
        noisy = z + np.array([[0.0, -1.0, 0.0, 1.0]]) * rng.normal(0.0, 0.2 * h) / 2
        if t == 0:
            bank.add(noisy)
        else:
            bank.predict(1)
            bank.update(np.array([0]), noisy)
    return _centre_error(bank, 10, _box(-6.0 + 0.1 * 30, 0.8, 12.0))


def test_a_smaller_depth_noise_keeps_height_jitter_out_of_the_position() -> None:
    slow = np.mean([_lateral_error(0.1, seed) for seed in range(20)])
    fast = np.mean([_lateral_error(1.0, seed) for seed in range(20)])
    assert slow < 0.8 * fast


def test_steps_are_checked_as_in_the_pixel_bank() -> None:
    bank = PerspectiveBank(_config(perspective=True, perspective_x=X0, perspective_y=Y0))
    bank.add(np.concatenate([_box(x, 0.8, 20.0) for x in (-2.0, 2.0)]))
    for bad in (-1, np.array([1.5, 1.0]), np.array([1, 1, 1])):
        with pytest.raises(ValueError, match="steps"):
            bank.predict(bad)
    ahead = bank.peek(np.array([0, 3]))
    assert np.allclose(ahead, bank.peek(0))  # no velocity yet: nowhere to go
