"""Tests of sensemaking.synthetic: scenario generator with ground truth."""

from __future__ import annotations

import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sensemaking.classes import CLASS_IDS
from sensemaking.detections import Detections
from sensemaking.geometry import iou
from sensemaking.synthetic import (
    SyntheticScene,
    _union_area,
    crossing_scene,
    make_scene,
    occlusion_suite,
    overlap_fraction,
)

SUITE = occlusion_suite(0)


def _same(a: Detections, b: Detections) -> bool:
    return (
        len(a) == len(b)
        and all(
            np.array_equal(getattr(a, k), getattr(b, k))
            for k in ("xyxy", "confidence", "class_id", "tracker_id", "frame")
        )
        and a.data.keys() == b.data.keys()
        and all(np.array_equal(a.data[k], b.data[k]) for k in a.data)
    )


def _visibility_by_raster(gt: Detections, frame: int, step: float = 0.25) -> dict[int, float]:
    """Independent check: sample each box on a fine grid, count samples under a nearer box."""
    m = gt.frame == frame
    boxes, ids = gt.xyxy[m], gt.tracker_id[m]
    out = {}
    for b, oid in zip(boxes, ids, strict=True):
        xs = np.arange(b[0] + step / 2, b[2], step)
        ys = np.arange(b[1] + step / 2, b[3], step)
        gx, gy = np.meshgrid(xs, ys)
        hidden = np.zeros(gx.shape, dtype=bool)
        for o, ooid in zip(boxes, ids, strict=True):
            if ooid != oid and o[3] > b[3]:
                hidden |= (gx >= o[0]) & (gx <= o[2]) & (gy >= o[1]) & (gy <= o[3])
        out[int(oid)] = 1.0 - hidden.mean()
    return out


def _missing_runs(scene: SyntheticScene, oid: int) -> list[tuple[int, int]]:
    """(first frame, length) of each run of frames where object ``oid`` is in the ground truth
    but has no detection."""
    gt_frames = scene.ground_truth.frame[scene.ground_truth.tracker_id == oid]
    seen = set(scene.detections.frame[scene.detections.data["gt_id"] == oid].tolist())
    runs: list[list[int]] = []
    for f in gt_frames.tolist():
        if f in seen:
            continue
        if runs and runs[-1][0] + runs[-1][1] == f:
            runs[-1][1] += 1
        else:
            runs.append([f, 1])
    return [(a, n) for a, n in runs]


def _check_consistent(
    scene: SyntheticScene, noise_px: float = 1.0, threshold: float = 0.6
) -> None:
    gt, det = scene.ground_truth, scene.detections
    # shapes and ranges
    assert np.all(gt.xyxy[:, 2:] > gt.xyxy[:, :2]) and np.all(det.xyxy[:, 2:] > det.xyxy[:, :2])
    for boxes in (gt.xyxy, det.xyxy):
        if not len(boxes):
            continue
        assert boxes[:, [0, 2]].min() >= 0 and boxes[:, [0, 2]].max() <= scene.width
        assert boxes[:, [1, 3]].min() >= 0 and boxes[:, [1, 3]].max() <= scene.height
    assert np.all((det.confidence > 0) & (det.confidence <= 1))
    assert np.all(det.tracker_id == -1) and np.all(gt.confidence == 1)
    assert np.all((gt.frame >= 0) & (gt.frame < scene.n_frames))
    assert np.all((det.frame >= 0) & (det.frame < scene.n_frames))
    assert np.all(np.diff(det.frame) >= 0) and np.all(np.diff(gt.frame) >= 0)
    vis = gt.data["visibility"]
    assert np.all((vis >= 0) & (vis <= 1))
    # one ground-truth row per object and frame
    gt_key = gt.frame * 100_000 + gt.tracker_id
    assert np.unique(gt_key).size == len(gt)
    # each true detection matches its object's ground truth on that frame
    true = det.data["gt_id"] >= 0
    det_key = det.frame[true] * 100_000 + det.data["gt_id"][true]
    assert np.unique(det_key).size == det_key.size
    where = np.searchsorted(gt_key, det_key)
    assert np.all(gt_key[where] == det_key)
    assert np.all(gt.class_id[where] == det.class_id[true])
    assert np.all(np.abs(det.xyxy[true] - gt.xyxy[where]) <= 6 * noise_px + 1.0)
    # hidden objects have no detection, the others are detected (no miss_rate here)
    detected = np.isin(gt_key, det_key)
    np.testing.assert_array_equal(detected, vis >= 1 - threshold - 1e-12)


# make_scene --------------------------------------------------------------------------------
def test_make_scene_is_deterministic():
    a = make_scene(20, seed=3, miss_rate=0.1, false_positive_rate=0.1)
    b = make_scene(20, seed=3, miss_rate=0.1, false_positive_rate=0.1)
    c = make_scene(20, seed=4, miss_rate=0.1, false_positive_rate=0.1)
    assert _same(a.detections, b.detections) and _same(a.ground_truth, b.ground_truth)
    assert not _same(a.detections, c.detections)
    for s in (SUITE, occlusion_suite(0)):
        assert [x.name for x in s] == [x.name for x in SUITE]
    assert all(
        _same(x.detections, y.detections) for x, y in zip(SUITE, occlusion_suite(0), strict=True)
    )


@pytest.mark.parametrize("n_tracks", [5, 10, 20, 50, 100])
def test_make_scene_counts_and_overlap(n_tracks):
    scene = make_scene(n_tracks, overlap=0.3, seed=n_tracks)
    _check_consistent(scene)
    gt = scene.ground_truth
    # every object on every frame
    assert len(gt) == n_tracks * scene.n_frames
    assert np.unique(gt.tracker_id).tolist() == list(range(1, n_tracks + 1))
    measured = overlap_fraction(gt)
    assert 0.3 <= measured <= 0.3 + 0.11
    # overlapping tracks overlap on every frame, not only on average
    per_frame = [overlap_fraction(d) for _, d in gt.frames()]
    assert min(per_frame) == pytest.approx(measured)


@settings(max_examples=25, deadline=None)
@given(
    n_tracks=st.integers(0, 60),
    overlap=st.floats(0.0, 1.0),
    seed=st.integers(0, 10_000),
    classes=st.sampled_from([(3,), (1,), (1, 3, 16), (15, 14)]),
)
def test_make_scene_overlap_matches_target(n_tracks, overlap, seed, classes):
    scene = make_scene(n_tracks, n_frames=20, overlap=overlap, seed=seed, classes=classes)
    _check_consistent(scene)
    assert len(scene.ground_truth) == n_tracks * 20
    assert set(scene.ground_truth.class_id.tolist()) <= set(classes)
    measured = overlap_fraction(scene.ground_truth)
    if n_tracks < 2 or overlap == 0:
        assert measured == 0
    else:
        assert overlap - 1e-9 <= measured <= overlap + 2 / n_tracks + 1e-9


def test_make_scene_has_occlusions_and_moves():
    scene = make_scene(50, overlap=0.5, seed=1)
    gt = scene.ground_truth
    assert (gt.data["visibility"] < 0.4).mean() > 0.02  # some objects are hidden
    assert len(scene.detections) < len(gt)
    start = gt.xyxy[gt.frame == 0]
    end = gt.xyxy[gt.frame == scene.n_frames - 1]
    assert np.median(np.abs(end - start).max(axis=1)) > 5  # objects move (pixels)


def test_visibility_matches_an_independent_raster():
    scene = make_scene(12, n_frames=30, overlap=1.0, seed=7, classes=(1, 3))
    for f in (0, 10, 17, 29):
        m = scene.ground_truth.frame == f
        expected = _visibility_by_raster(scene.ground_truth, f)
        for oid, vis in zip(
            scene.ground_truth.tracker_id[m], scene.ground_truth.data["visibility"][m], strict=True
        ):
            assert vis == pytest.approx(expected[int(oid)], abs=0.03)


def test_union_area_of_overlapping_rectangles():
    rects = np.array([[0, 0, 2, 2], [1, 1, 3, 3], [0, 0, 1, 1.0]])
    assert _union_area(rects) == pytest.approx(7.0)


def test_miss_and_false_positive_rates():
    clean = make_scene(50, seed=2)
    noisy = make_scene(50, seed=2, miss_rate=0.2, false_positive_rate=0.1)
    _check_ids = noisy.detections.data["gt_id"]
    n_true_clean = len(clean.detections)
    n_true = int((_check_ids >= 0).sum())
    assert n_true / n_true_clean == pytest.approx(0.8, abs=0.03)
    assert (_check_ids == -1).sum() / n_true == pytest.approx(0.1, abs=0.03)
    fp = noisy.detections[_check_ids == -1]
    assert np.all((fp.confidence > 0) & (fp.confidence <= 0.5))
    assert np.all(np.isin(fp.class_id, [3]))
    # ground truth does not depend on detector noise
    assert _same(clean.ground_truth, noisy.ground_truth)


def test_detection_order_within_a_frame_carries_no_identity():
    scene = make_scene(20, seed=0)
    orders = [d.data["gt_id"] for _, d in scene.frames()]
    assert any(np.any(np.diff(o) < 0) for o in orders)


def test_make_scene_100_tracks_is_fast():
    make_scene(10)
    start = time.perf_counter()
    make_scene(100, n_frames=100, false_positive_rate=0.1, miss_rate=0.05)
    assert time.perf_counter() - start < 0.5


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(n_tracks=-1),
        dict(n_tracks=3, n_frames=0),
        dict(n_tracks=3, overlap=1.5),
        dict(n_tracks=3, miss_rate=2.0),
        dict(n_tracks=3, classes=()),
        dict(n_tracks=10_000),
    ],
)
def test_make_scene_rejects_bad_arguments(kwargs):
    with pytest.raises(ValueError):
        make_scene(**kwargs)


# frames() ----------------------------------------------------------------------------------
def test_frames_yields_every_frame_including_empty_ones():
    scene = make_scene(3, n_frames=12, miss_rate=0.7, seed=5)
    out = list(scene.frames())
    assert [f for f, _ in out] == list(range(12))
    assert sum(len(d) for _, d in out) == len(scene.detections)
    assert any(len(d) == 0 for _, d in out)
    for f, d in out:
        assert np.all(d.frame == f)
        assert set(d.data) == {"gt_id"}
    silent = make_scene(2, n_frames=5, miss_rate=1.0)
    assert [(f, len(d)) for f, d in silent.frames()] == [(f, 0) for f in range(5)]


def test_empty_scene():
    scene = make_scene(0, n_frames=4)
    assert len(scene.detections) == 0 and len(scene.ground_truth) == 0
    assert [f for f, _ in scene.frames()] == [0, 1, 2, 3]
    assert overlap_fraction(scene.ground_truth) == 0.0


# hand-made occlusion scenes ------------------------------------------------------------------
@pytest.mark.parametrize("gap", [1, 2, 3, 5, 8, 11, 15])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_crossing_scene_hides_the_far_object_for_exactly_gap_frames(gap, seed):
    scene = crossing_scene(seed, gap=gap)
    _check_consistent(scene)
    gt = scene.ground_truth
    assert len(gt) == 2 * scene.n_frames  # both in view throughout
    assert _missing_runs(scene, 1) == [(_missing_runs(scene, 1)[0][0], gap)]
    assert _missing_runs(scene, 2) == []
    # far = id 1 = box bottom higher in the image
    far, near = gt[gt.tracker_id == 1], gt[gt.tracker_id == 2]
    assert np.all(far.xyxy[:, 3] < near.xyxy[:, 3])
    # clear view at the start and at the end
    assert (
        iou(far.xyxy[:1], near.xyxy[:1])[0, 0] == 0
        and iou(far.xyxy[-1:], near.xyxy[-1:])[0, 0] == 0
    )


def test_default_crossing_defeats_iou_matching_with_the_last_box():
    scene = crossing_scene()
    start, gap = _missing_runs(scene, 1)[0]
    det = scene.detections
    far = det[det.data["gt_id"] == 1]
    near = det[det.data["gt_id"] == 2]
    before = far.xyxy[far.frame == start - 1]
    after = far.xyxy[far.frame == start + gap]
    near_after = near.xyxy[near.frame == start + gap]
    assert iou(before, after)[0, 0] == 0  # reappears more than a box width away
    assert iou(after, near_after)[0, 0] > 0  # ... right next to the near one
    ratio = (after[0, 3] - after[0, 1]) / (near_after[0, 3] - near_after[0, 1])
    assert 0.75 < ratio < 1.0  # similar sizes


@pytest.mark.parametrize("direction", [1, -1])
def test_crossing_scene_directions(direction):
    scene = crossing_scene(
        0, direction=direction, far_speed=3.0, gap=4
    )  # they walk towards each other
    gt = scene.ground_truth
    far = gt.xyxy[gt.tracker_id == 1]
    near = gt.xyxy[gt.tracker_id == 2]
    assert np.sign(far[-1, 0] - far[0, 0]) == direction
    assert np.sign(near[-1, 0] - near[0, 0]) == -direction


def test_crossing_scene_rejects_impossible_occlusion():
    with pytest.raises(ValueError):  # a pedestrian cannot hide a truck
        crossing_scene(near_class=CLASS_IDS["pedestrian"], far_class=CLASS_IDS["truck"])
    with pytest.raises(ValueError):
        crossing_scene(gap=0)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_occlusion_suite(seed):
    suite = SUITE if seed == 0 else occlusion_suite(seed)
    assert len(suite) >= 8
    assert len({s.name for s in suite}) == len(suite)
    gaps = []
    for scene in suite:
        _check_consistent(scene)
        for oid in np.unique(scene.ground_truth.tracker_id):
            gaps += [n for _, n in _missing_runs(scene, int(oid))]
    assert min(gaps) >= 3 and max(gaps) <= 15
    assert {3, 15} <= set(gaps) and len(set(gaps)) >= 5
    names = {s.name: s for s in suite}
    # Figure 1: the cyclist is hidden by the turning car, then seen again
    fig1 = names["car_turns_right_hiding_cyclist"]
    cyclist = int(
        fig1.ground_truth.tracker_id[fig1.ground_truth.class_id == CLASS_IDS["cyclist"]][0]
    )
    ((start, gap),) = _missing_runs(fig1, cyclist)
    assert start + gap < fig1.n_frames - 5
    # a car leaves at the right border, the other cars come and go
    border = names["leave_and_enter_at_border"]
    gt = border.ground_truth
    first = {int(i): int(gt.frame[gt.tracker_id == i].min()) for i in np.unique(gt.tracker_id)}
    last = {int(i): int(gt.frame[gt.tracker_id == i].max()) for i in np.unique(gt.tracker_id)}
    assert last[1] < border.n_frames - 1 and first[2] > last[1] and first[3] > 0
    assert gt.xyxy[(gt.tracker_id == 1) & (gt.frame == last[1])][0, 2] == border.width
    assert gt.xyxy[(gt.tracker_id == 2) & (gt.frame == first[2])][0, 2] == border.width
    assert all(_missing_runs(border, i) == [] for i in first)
