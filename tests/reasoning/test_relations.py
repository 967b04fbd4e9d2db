"""Interval / rectangle algebra and qualitative motion (sensemaking.reasoning.relations)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sensemaking.reasoning.relations import (
    IA_RELATIONS,
    INVERSE,
    MOTION_KINDS,
    MotionThresholds,
    RelationConfig,
    classify_motion,
    interval_relation_masks,
    interval_relations,
    inverse_codes,
    motion_facts,
    motion_features,
    near_pairs,
    order_pairs,
    pair_relations,
    rectangle_relations,
    relation_facts,
    track_motion,
)

# one hand-made pair of intervals per relation: a = [lo, hi], b = [lo, hi]
CASES = {
    "before": ((0, 2), (5, 8)),
    "after": ((5, 8), (0, 2)),
    "during": ((3, 4), (1, 8)),
    "contains": ((1, 8), (3, 4)),
    "starts": ((1, 4), (1, 8)),
    "started_by": ((1, 8), (1, 4)),
    "finishes": ((5, 8), (1, 8)),
    "finished_by": ((1, 8), (5, 8)),
    "overlaps": ((1, 5), (3, 8)),
    "overlapped_by": ((3, 8), (1, 5)),
    "meets": ((1, 3), (3, 8)),
    "met_by": ((3, 8), (1, 3)),
    "equal": ((2, 6), (2, 6)),
}


@pytest.mark.parametrize("name", IA_RELATIONS)
def test_each_relation_on_hand_made_intervals(name):
    a, b = CASES[name]
    assert IA_RELATIONS[interval_relations([a], [b])[0]] == name
    masks = interval_relation_masks([a], [b])
    assert masks[:, 0].sum() == 1 and masks[IA_RELATIONS.index(name), 0]
    # and the converse the other way round
    assert IA_RELATIONS[interval_relations([b], [a])[0]] == INVERSE[name]


def test_all_thirteen_relations_covered_and_vectorised():
    a = np.array([CASES[r][0] for r in IA_RELATIONS], float)
    b = np.array([CASES[r][1] for r in IA_RELATIONS], float)
    assert [IA_RELATIONS[c] for c in interval_relations(a, b)] == list(IA_RELATIONS)


@pytest.mark.parametrize(
    "a,b,tol,expected",
    [
        ((0, 2.9), (3, 8), 0.0, "before"),
        ((0, 2.9), (3, 8), 0.2, "meets"),  # a gap within the tolerance meets
        ((0, 3.1), (3, 8), 0.2, "meets"),  # so does a small overlap
        ((0, 3.5), (3, 8), 0.2, "overlaps"),
        ((2.1, 6.1), (2, 6), 0.2, "equal"),
        ((2.1, 5.0), (2, 6), 0.2, "starts"),
        ((1.0, 5.95), (2, 6), 0.2, "finished_by"),
    ],
)
def test_tolerance_for_meets_and_equal(a, b, tol, expected):
    assert IA_RELATIONS[interval_relations([a], [b], tol)[0]] == expected


def test_large_tolerance_prefers_equal():
    # both "meets" and "met_by" patterns would apply: equal takes precedence
    assert IA_RELATIONS[interval_relations([(0, 1)], [(0.5, 1.5)], 1.0)[0]] == "equal"


def test_bad_intervals_raise():
    with pytest.raises(ValueError):
        interval_relation_masks([(3, 1)], [(0, 1)])
    with pytest.raises(ValueError):
        interval_relation_masks([(0, 1)], [(0, 1)], -1.0)


interval = st.tuples(st.floats(-50, 50, allow_nan=False), st.floats(0, 30, allow_nan=False)).map(
    lambda t: (t[0], t[0] + t[1])
)
small_ints = st.tuples(st.integers(-6, 6), st.integers(0, 6)).map(
    lambda t: (float(t[0]), float(t[0] + t[1]))
)


@settings(max_examples=400, deadline=None)
@given(
    a=st.one_of(interval, small_ints),
    b=st.one_of(interval, small_ints),
    tol=st.one_of(st.just(0.0), st.floats(0, 10, allow_nan=False)),
)
def test_exactly_one_relation_holds_and_converse(a, b, tol):
    masks = interval_relation_masks([a], [b], tol)
    assert masks[:, 0].sum() == 1
    code = int(np.argmax(masks[:, 0]))
    assert interval_relations([a], [b], tol)[0] == code  # the lookup table agrees
    back = interval_relations([b], [a], tol)[0]
    assert IA_RELATIONS[back] == INVERSE[IA_RELATIONS[code]]


@settings(max_examples=200, deadline=None)
@given(a=small_ints, b=small_ints)
def test_exact_definitions_without_tolerance(a, b):
    (a1, a2), (b1, b2) = a, b
    name = IA_RELATIONS[interval_relations([a], [b])[0]]
    if a1 == b1 and a2 == b2:
        assert name == "equal"
    elif a2 < b1:
        assert name == "before"
    elif a2 == b1:
        assert name == "meets" or a1 == a2 == b1  # a point at b's start
    elif b2 < a1:
        assert name == "after"
    else:
        assert name not in ("before", "after")


def test_rectangle_relations_and_converse():
    a = np.array([[0, 0, 10, 10], [0, 0, 10, 10]], float)
    b = np.array([[20, 2, 30, 8], [5, 0, 15, 10]], float)
    codes = rectangle_relations(a, b)
    names = [(IA_RELATIONS[x], IA_RELATIONS[y]) for x, y in codes]
    assert names == [("before", "contains"), ("overlaps", "equal")]
    back = rectangle_relations(b, a)
    assert (back == inverse_codes(codes)).all()
    per_axis = rectangle_relations(a, b, np.array([[11, 0], [0, 0]]))  # (N, 2) tolerance
    assert IA_RELATIONS[per_axis[0, 0]] == "meets"


def test_near_pairs_gates_by_gap():
    boxes = np.array([[0, 0, 10, 10], [14, 0, 24, 10], [100, 0, 110, 10], [5, 5, 8, 8]], float)
    pairs = near_pairs(boxes, near=0.5)
    assert pairs.tolist() == [[0, 1], [0, 3]]  # gap 4 <= 5; box 3 inside box 0; box 2 far away
    assert near_pairs(boxes[:1]).shape == (0, 2)


def test_pair_relations_and_facts_are_written_smaller_id_first():
    boxes = np.array([[0, 0, 10, 10], [5, 0, 15, 10]], float)
    pairs, codes = pair_relations(boxes, RelationConfig(tol_px=0, tol_rel=0))
    ids = np.array([9, 4])  # track 9 is box 0: written as ra(4,9,...) with converse relations
    assert relation_facts(7, ids, pairs, codes) == [("ra", 4, 9, 7, "overlapped_by", "equal")]
    a, b, c = order_pairs(ids, pairs, codes)
    assert (a.tolist(), b.tolist()) == ([4], [9])


def test_motion_features_and_kinds():
    prev = np.array(
        [
            [100, 100, 140, 180],  # approaching: grows, bottom moves down
            [100, 100, 140, 180],  # receding
            [100, 100, 140, 180],  # moving right, same size
            [100, 100, 140, 180],
        ],
        float,
    )  # stopped
    cur = np.array(
        [
            [95, 100, 145, 210],
            [105, 100, 135, 170],
            [130, 100, 170, 180],
            [100.5, 100, 140.5, 180],
        ],
        float,
    )
    feats = motion_features(prev, cur, 0.5)
    assert feats.vx[2] == pytest.approx(60.0) and feats.vbottom[0] == pytest.approx(60.0)
    kinds = classify_motion(feats, speed_before=np.array([0, 0, 0, 80.0]))
    got = [{MOTION_KINDS[k] for k in np.flatnonzero(row)} for row in kinds]
    assert got[0] >= {"approaching", "looming"}
    assert got[1] == {"receding"}
    assert got[2] == {"moving_right", "keeping_distance"}
    assert got[3] == {"stopped", "stopping", "keeping_distance"}  # 80 px/s before, still now
    assert motion_facts(3, np.array([1, 2, 3, 4]), kinds[1:2]) == [("motion", 1, 3, "receding")]


def test_thresholds_are_in_pixels_per_second():
    # the same motion sampled at 10 and at 30 fps gives the same kinds
    t = MotionThresholds()
    for fps in (10.0, 30.0):
        frames = np.arange(0, int(2 * fps))
        boxes = np.array([[100 + 50 * f / fps, 100, 140 + 50 * f / fps, 180] for f in frames])
        fr, kinds, feats = track_motion(frames, boxes, fps, t)
        assert fr.size and np.allclose(feats.vx, 50.0)
        assert kinds[:, MOTION_KINDS.index("moving_right")].all()


def test_track_motion_needs_a_box_lag_frames_before():
    frames = np.array([0, 1, 2, 10, 11])
    boxes = np.tile([0, 0, 10, 10], (5, 1)).astype(float)
    fr, kinds, _ = track_motion(frames, boxes, 10.0, MotionThresholds(lag_s=0.2))
    assert fr.tolist() == [2]  # frame 10 has no box 2..4 frames before; 11 neither (9..7)


def test_threshold_validation():
    with pytest.raises(ValueError):
        MotionThresholds(stopped_px_s=50, moving_px_s=40)
    with pytest.raises(ValueError):
        RelationConfig(near=-1)


def _random_boxes(rng: np.random.Generator, n: int) -> np.ndarray:
    """Boxes on a coarse grid (ties, touching edges, equal sizes) plus some fractional ones."""
    x0, y0 = rng.integers(0, 60, n).astype(float), rng.integers(0, 60, n).astype(float)
    if rng.random() < 0.3:
        x0 += rng.random(n) * 7.3
        y0 += rng.random(n)
    return np.stack([x0, y0, x0 + rng.integers(1, 30, n), y0 + rng.integers(1, 30, n)], 1).reshape(
        n, 4
    )
