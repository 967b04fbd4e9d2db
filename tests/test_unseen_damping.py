"""unseen_damping (issue 27): a hidden or missing track's image velocity fades per unseen frame;
1 changes nothing."""

from __future__ import annotations

import numpy as np
import pytest

from sensemaking import settings
from sensemaking.classes import CLASS_IDS
from sensemaking.detections import Detections
from sensemaking.motion import KalmanBank
from sensemaking.tracker import Tracker, TrackerConfig

PED = CLASS_IDS["pedestrian"]


def _x_while_unseen(damping: float, abduction: bool = True) -> list[float]:
    """A pedestrian walking right at 8 px/frame for 8 frames, then unseen for 4: the x of its
    predicted box on each unseen frame."""
    cfg = TrackerConfig(
        fps=10, image_size=(1000, 400), unseen_damping=damping, abduction=abduction
    )
    tracker = Tracker(cfg)
    for f in range(8):
        x = 100.0 + 8.0 * f
        tracker.update(
            Detections(np.array([[x, 100.0, x + 40, 200.0]]), confidence=0.9, class_id=PED),
            frame=f,
        )
    xs = []
    for f in range(8, 12):
        r = tracker.update(Detections.empty(), frame=f)
        assert len(r.tracks) == 1
        xs.append(float(r.tracks.xyxy[0, 0]))
    return xs


@pytest.mark.parametrize("abduction", [True, False])
def test_damping_slows_the_unseen_prediction(abduction):
    plain = _x_while_unseen(1.0, abduction)
    damped = _x_while_unseen(0.5, abduction)
    steps = np.diff([plain[0], *plain[1:]])
    assert np.all(steps > 5.0)  # constant velocity: it walks on
    assert damped[0] == pytest.approx(plain[0])  # the first unseen frame: full velocity
    d = np.diff(damped)
    assert np.all(d > 0) and np.all(d[1:] < d[:-1])  # slower every frame
    assert d[0] == pytest.approx(steps[0] * 0.5, rel=0.05)


def test_kalman_damp_scales_velocities_of_the_rows_only():
    kf = KalmanBank()
    kf.add(np.array([[0.0, 0, 10, 10], [50, 50, 60, 60]]), velocity=np.array([2.0, 1, 0.5, 0.5]))
    kf.damp(np.array([True, False]), 0.25)
    assert np.allclose(kf.velocity(), [[0.5, 0.25, 0.125, 0.125], [2, 1, 0.5, 0.5]])
    with pytest.raises(ValueError):
        kf.damp(np.array([0]), 1.5)


def test_setting_is_checked_and_round_trips():
    cfg = settings.load_config(None, "kitti", overrides=["unseen_damping=0.8"])
    assert cfg.unseen_damping == 0.8
    with pytest.raises(settings.ParameterError):
        settings.load_config(None, "kitti", overrides=["unseen_damping=0"])
    with pytest.raises(settings.ParameterError):
        settings.load_config(None, "kitti", overrides=["unseen_damping=1.5"])
