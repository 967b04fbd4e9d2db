"""The camera's pitch from the scene: the horizon row fitted to the boxes' bottoms and heights
(a pinhole camera over a flat road), its bounds, its fall-back to level, and its use for the
distances of the situation monitor."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sensemaking.classes import CLASS_IDS
from sensemaking.reasoning.egomotion import (
    OBJECT_HEIGHT_M,
    CameraModel,
    EgoMotionConfig,
    HorizonEstimator,
    WorldMotion,
    fit_horizon,
)

CAM = CameraModel.kitti()
SIZE = (1242, 375)
FPS = 10.0
CAR = CLASS_IDS["car"]
PED = CLASS_IDS["pedestrian"]


def boxes(horizon: float, zs: list[float], xs: list[float], heights: list[float]) -> np.ndarray:
    """Image boxes (N, 4) px of objects ``heights`` m tall standing ``zs`` m ahead, ``xs`` m to
    the right, seen by KITTI's camera with its horizon at row ``horizon``."""
    out = []
    for z, x, hm in zip(zs, xs, heights, strict=True):
        bottom = horizon + CAM.focal_px * CAM.height_m / z
        cx = CAM.cx_px + CAM.focal_px * x / z
        half = CAM.focal_px * 1.7 / z / 2
        out.append([cx - half, bottom - CAM.focal_px * hm / z, cx + half, bottom])
    return np.array(out)


def test_fit_recovers_horizon_and_camera_height_from_exact_boxes():
    rng = np.random.default_rng(0)
    z = rng.uniform(6, 45, 30)
    x = CAM.focal_px / z  # h / H for any H
    y = 181.0 + 1.7 * x
    hor, slope = fit_horizon(x, y, 1.65, band=0.1)
    assert hor == pytest.approx(181.0, abs=1e-6)
    assert slope == pytest.approx(1.7, abs=1e-6)
    # band 0: the camera height is the slope; the horizon absorbs the difference
    hor0, slope0 = fit_horizon(x, y, 1.65, band=0.0)
    assert slope0 == 1.65 and hor0 > 181.0


def test_fit_slope_stays_in_its_band_and_outliers_do_not_move_the_horizon():
    z = np.linspace(6, 40, 25)
    x = CAM.focal_px / z
    y = 170.0 + 1.65 * x
    y[:4] += 60.0  # four boxes far off (a truck's, a misdetection's)
    hor, slope = fit_horizon(x, y, 1.65, band=0.1)
    assert 1.65 * 0.9 <= slope <= 1.65 * 1.1
    assert hor == pytest.approx(170.0, abs=2.0)


@pytest.mark.parametrize("true_horizon", [160.0, 172.9, 185.0])
def test_estimator_converges_to_the_scene_horizon(true_horizon):
    est = HorizonEstimator(CAM, FPS, EgoMotionConfig(horizon_from_scene=True), SIZE)
    rng = np.random.default_rng(1)
    for f in range(20):
        zs = list(rng.uniform(8, 40, 4))
        b = boxes(true_horizon, zs, [-4.0, -1.0, 2.0, 5.0], [OBJECT_HEIGHT_M[CAR]] * 4)
        b += rng.normal(0, 0.7, b.shape)
        hor = est.update(f, b, [CAR] * 4)
    assert hor == pytest.approx(true_horizon, abs=1.5)
    expect = math.degrees(math.atan((true_horizon - CAM.horizon_px) / CAM.focal_px))
    assert est.pitch_deg == pytest.approx(expect, abs=0.15)


def test_classes_of_other_heights_fit_with_their_own_height():
    est = HorizonEstimator(CAM, FPS, EgoMotionConfig(horizon_from_scene=True), SIZE)
    for f in range(15):
        b = boxes(180.0, [8.0, 12.0, 20.0, 30.0], [-3.0, 3.0, -5.0, 4.0], [1.76, 1.76, 1.53, 1.53])
        hor = est.update(f, b, [PED, PED, CAR, CAR])
    assert hor == pytest.approx(180.0, abs=0.5)
    # a truck (no typical height) does not vote
    est.reset()
    for f in range(15):
        b = boxes(180.0, [10.0, 15.0, 25.0], [-3.0, 3.0, 0.0], [3.5, 3.5, 3.5])
        hor = est.update(f, b, [CLASS_IDS["truck"]] * 3)
    assert hor == CAM.horizon_px


def test_too_few_boxes_relax_back_to_level_and_cut_boxes_do_not_vote():
    cfg = EgoMotionConfig(horizon_from_scene=True)
    est = HorizonEstimator(CAM, FPS, cfg, SIZE)
    b = boxes(185.0, [8.0, 12.0, 20.0, 30.0], [-3.0, 3.0, -5.0, 4.0], [1.53] * 4)
    for f in range(10):
        est.update(f, b, [CAR] * 4)
    assert est.horizon_px > CAM.horizon_px + 10
    for f in range(10, 40):  # nothing seen for 3 s
        hor = est.update(f, np.zeros((0, 4)), [])
    assert hor == pytest.approx(CAM.horizon_px, abs=0.1)
    # boxes touching the image's bottom edge are cut: their bottom is not the road contact
    est.reset()
    cut = b.copy()
    cut[:, 3] = SIZE[1] - 1
    for f in range(10):
        hor = est.update(f, cut, [CAR] * 4)
    assert hor == CAM.horizon_px


def test_the_pitch_is_bounded():
    cfg = EgoMotionConfig(horizon_from_scene=True, horizon_max_pitch_deg=1.0)
    est = HorizonEstimator(CAM, FPS, cfg, SIZE)
    b = boxes(230.0, [8.0, 12.0, 20.0, 30.0], [-3.0, 3.0, -5.0, 4.0], [1.53] * 4)
    for f in range(30):
        est.update(f, b, [CAR] * 4)
    assert est.pitch_deg == pytest.approx(1.0, abs=0.01)


def test_memory_is_bounded_by_the_window():
    est = HorizonEstimator(CAM, FPS, EgoMotionConfig(horizon_from_scene=True), SIZE)
    b = boxes(175.0, list(np.linspace(8, 45, 100)), [3.0] * 100, [1.53] * 100)
    for f in range(200):
        est.update(f, b, [CAR] * 100)
    assert len(est._window) <= round(est.config.horizon_window_s * FPS)
    assert sum(len(w[1]) for w in est._window) <= 40 * len(est._window)


def test_world_motion_distances_follow_the_estimated_horizon():
    """With the scene's horizon 12 px below the level row, the level camera puts the cars
    nearer than they are; the estimate gives their true distance."""
    zs, xs = [10.0, 15.0, 22.0, 30.0], [-3.0, 3.0, -5.0, 4.0]
    b = boxes(CAM.horizon_px + 12.0, zs, xs, [1.53] * 4)
    level = WorldMotion(CAM, FPS, SIZE)
    scene = WorldMotion(CAM, FPS, SIZE, config=EgoMotionConfig(horizon_from_scene=True))
    for f in range(15):
        _, m_level = level.update(f, [1, 2, 3, 4], b, classes=[CAR] * 4)
        _, m_scene = scene.update(f, [1, 2, 3, 4], b, classes=[CAR] * 4)
    for t, z in zip([1, 2, 3, 4], zs, strict=True):
        assert m_scene[t].z == pytest.approx(z, rel=0.02)
        assert m_level[t].z < 0.95 * z


def test_config_rejects_bad_horizon_settings():
    for bad in (
        {"horizon_window_s": 0.0},
        {"horizon_smooth_s": -1.0},
        {"horizon_min_boxes": 1},
        {"horizon_max_pitch_deg": 50.0},
        {"horizon_height_band": 1.0},
    ):
        with pytest.raises(ValueError):
            EgoMotionConfig(**bad)


def test_track_pitch_option(tmp_path, capsys):
    """``--pitch level`` is the default's output; ``--pitch scene`` runs; without a camera
    model or without --warnings it is a one-line error."""
    from sensemaking.cli import main

    det = tmp_path / "0000.txt"
    det.write_text(
        "".join(
            f"{f},{400 + 3 * f},{180 + f},{520 + 4 * f},{250 + 2 * f},0.9\n"
            f"{f},{800 - 2 * f},{178},{860 - 2 * f},{205},0.8\n"
            for f in range(15)
        )
    )

    def run(name: str, *extra: str, fmt: str = "kitti") -> int:
        args = ["-q", "track", "--detections", str(det), "--format", fmt]
        args += ["--output", str(tmp_path / f"{name}.txt")]
        return main([*args, *extra])

    w = {k: tmp_path / f"{k}.jsonl" for k in ("default", "level", "scene")}
    kitti = ("--class", "car", "--warnings")
    assert run("default", *kitti, str(w["default"])) == 0
    assert run("level", *kitti, str(w["level"]), "--pitch", "level") == 0
    assert run("scene", *kitti, str(w["scene"]), "--pitch", "scene") == 0
    assert w["level"].read_bytes() == w["default"].read_bytes()
    capsys.readouterr()
    assert run("nowarn", "--class", "car", "--pitch", "scene") == 2
    assert "--pitch needs --warnings" in capsys.readouterr().err
    mot = ("--image-size", "1242x375", "--fps", "10", "--warnings", str(tmp_path / "m.jsonl"))
    det.write_text("".join(f"{f + 1},-1,500,200,100,60,0.9,-1,-1,-1\n" for f in range(5)))
    assert run("mot", *mot, "--pitch", "scene", fmt="mot") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--pitch needs a camera model" in err[0]
