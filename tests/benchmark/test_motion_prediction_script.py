"""benchmarks/motion_prediction.py: boxes predicted ahead from an object's own detections."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from conftest import load_benchmarks_script


def _predict(shared_data: Path, *sets: str) -> dict[str, list[float]]:
    load_benchmarks_script("occlusion_errors")  # the script imports it by name
    script = load_benchmarks_script("motion_prediction")
    item = script.Item("kitti-rrc-car", "0001")
    return script.predictions(item, shared_data, list(sets))


def test_predictions_are_ious_at_every_horizon(shared_data: Path) -> None:
    got = _predict(shared_data)
    assert set(got) == {"0.2s", "0.5s", "1s", "young"}
    for values in got.values():
        assert values and all(0.0 <= v <= 1.0 for v in values)
    # the farther ahead, the fewer ground-truth boxes to compare with and the worse the guess
    assert len(got["0.2s"]) > len(got["1s"])
    assert np.mean(got["0.2s"]) > np.mean(got["0.5s"]) > np.mean(got["1s"])


def test_the_pinhole_filter_predicts_a_driving_cameras_cars_further(shared_data: Path) -> None:
    pixels = _predict(shared_data)
    pinhole = _predict(shared_data, "kalman.perspective=true")
    assert len(pinhole["1s"]) == len(pixels["1s"])  # the same objects and frames
    assert np.mean(pinhole["1s"]) > np.mean(pixels["1s"]) + 0.02
