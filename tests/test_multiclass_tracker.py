"""One tracker for several classes: each class's new tracks start with their own class's motion."""

from __future__ import annotations

import numpy as np

from sensemaking.classes import CLASS_IDS
from sensemaking.detections import Detections
from sensemaking.tracker import Tracker, TrackerConfig

CAR, PED = CLASS_IDS["car"], CLASS_IDS["pedestrian"]


def boxes(f: int, *objects: tuple[float, float, int]) -> Detections:
    """Frame ``f``: objects ``(x0, speed px/frame, class)`` on a row, 60x120 px."""
    xs = [x0 + v * f for x0, v, _ in objects]
    return Detections(
        xyxy=np.array([[x, 100.0, x + 60.0, 220.0] for x in xs]),
        confidence=np.full(len(xs), 0.99),
        class_id=np.array([c for _, _, c in objects], dtype=np.int64),
    )


def test_new_tracks_inherit_the_motion_of_their_own_class() -> None:
    t = Tracker(TrackerConfig(image_size=(1242, 375)))
    objects = [(100.0, 12.0, CAR), (300.0, 12.0, CAR), (800.0, -3.0, PED)]
    for f in range(6):
        t.update(boxes(f, *objects), frame=f)
    prior = t.scene_velocity(np.array([CAR, PED, CLASS_IDS["cyclist"]]))
    assert prior.shape == (3, 4)
    assert abs(prior[0, 0] - 12.0) < 1.5 and abs(prior[1, 0] + 3.0) < 1.0
    assert prior[2].tolist() == [0.0, 0.0, 0.0, 0.0]  # no cyclist established: at rest
    pooled = t.scene_velocity()  # over every class: the cars' motion outvotes the pedestrian's
    assert pooled.shape == (4,) and abs(pooled[0] - 12.0) < 1.5
