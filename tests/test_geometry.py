"""Property tests of sensemaking.geometry and the Detections container."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from sensemaking.detections import Detections
from sensemaking.geometry import (
    clip_to_image,
    coverage,
    cxcywh_to_xyxy,
    intersection,
    iou,
    xywh_to_xyxy,
    xyxy_to_cxcywh,
    xyxy_to_xywh,
)

coord = st.floats(-1000.0, 1000.0, allow_nan=False, allow_infinity=False)
size = st.floats(0.0, 500.0, allow_nan=False, allow_infinity=False)
positive = st.floats(0.5, 500.0, allow_nan=False, allow_infinity=False)
box_count = st.integers(0, 6)


@st.composite
def boxes(draw, n=box_count, sizes=size) -> np.ndarray:
    k = draw(n)
    out = np.empty((k, 4))
    for i in range(k):
        x, y, w, h = draw(coord), draw(coord), draw(sizes), draw(sizes)
        out[i] = (x, y, x + w, y + h)
    return out


def area(b: np.ndarray) -> np.ndarray:
    return (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])


# ---- geometry -----------------------------------------------------------------------------
@settings(deadline=None, max_examples=60)
@given(boxes(), boxes())
def test_iou_shape_range_and_symmetry(a, b):
    m = iou(a, b)
    assert m.shape == (len(a), len(b))
    assert np.all((m >= 0.0) & (m <= 1.0))
    assert np.array_equal(m, iou(b, a).T)


@settings(deadline=None, max_examples=60)
@given(boxes(n=st.integers(1, 6), sizes=positive))
def test_iou_of_a_box_with_itself_is_one(a):
    assert np.allclose(np.diag(iou(a, a)), 1.0, rtol=0, atol=1e-9)


@settings(deadline=None, max_examples=60)
@given(boxes(), boxes())
def test_coverage_times_area_is_the_intersection(a, b):
    inter = intersection(a, b)
    assert inter.shape == (len(a), len(b)) and np.all(inter >= 0)
    assert np.array_equal(inter, intersection(b, a).T)
    cov = coverage(a, b)
    assert np.all((cov >= 0.0) & (cov <= 1.0 + 1e-12))
    assert np.allclose(cov * area(a)[:, None], inter, rtol=1e-9, atol=1e-6)
    # the intersection never exceeds either box
    assert np.all(inter <= np.minimum(area(a)[:, None], area(b)[None, :]) * (1 + 1e-12) + 1e-9)


@settings(deadline=None, max_examples=60)
@given(boxes(n=st.integers(1, 6), sizes=positive))
def test_iou_is_at_most_the_smaller_coverage(a):
    b = a[::-1] + 3.0
    assert np.all(iou(a, b) <= np.minimum(coverage(a, b), coverage(b, a).T) + 1e-12)


def test_geometry_examples():
    a = np.array([[0.0, 0.0, 10.0, 10.0]])
    b = np.array([[5.0, 0.0, 15.0, 10.0], [20.0, 20.0, 30.0, 30.0], [0.0, 0.0, 0.0, 0.0]])
    assert np.allclose(iou(a, b), [[50 / 150, 0.0, 0.0]])
    assert np.allclose(coverage(a, b), [[0.5, 0.0, 0.0]])
    assert np.allclose(
        coverage(b, a)[:, 0], [0.5, 0.0, 0.0]
    )  # an empty box covers and is covered by nothing
    assert iou(b[2], b[2]).tolist() == [[0.0]]  # empty union: 0, no warning or nan
    assert iou(np.zeros((0, 4)), a).shape == (0, 1)
    assert iou([0, 0, 2, 2], [1, 1, 3, 3]).shape == (1, 1)  # a single box is (1, 4)


@settings(deadline=None, max_examples=60)
@given(boxes())
def test_round_trips(a):
    assert np.allclose(xywh_to_xyxy(xyxy_to_xywh(a)), a, rtol=1e-12, atol=1e-9)
    assert np.allclose(cxcywh_to_xyxy(xyxy_to_cxcywh(a)), a, rtol=1e-12, atol=1e-9)
    xywh = xyxy_to_xywh(a)
    assert np.allclose(
        xyxy_to_cxcywh(xywh_to_xyxy(xywh))[:, 2:], xywh[:, 2:], rtol=1e-12, atol=1e-9
    )
    assert np.allclose(xyxy_to_cxcywh(a)[:, 2:], xyxy_to_xywh(a)[:, 2:])


def test_conversions_examples_and_no_aliasing():
    xyxy = np.array([[10.0, 20.0, 40.0, 60.0]])
    assert xyxy_to_xywh(xyxy).tolist() == [[10.0, 20.0, 30.0, 40.0]]
    assert xyxy_to_cxcywh(xyxy).tolist() == [[25.0, 40.0, 30.0, 40.0]]
    assert cxcywh_to_xyxy([25, 40, 30, 40]).tolist() == xyxy.tolist()
    xyxy_to_xywh(xyxy)
    xywh_to_xyxy(xyxy)
    assert xyxy.tolist() == [[10.0, 20.0, 40.0, 60.0]]  # inputs are not modified


@settings(deadline=None, max_examples=60)
@given(boxes(), positive, positive)
def test_clip_to_image(a, w, h):
    c = clip_to_image(a, w, h)
    assert np.all(
        (c[:, [0, 2]] >= 0) & (c[:, [0, 2]] <= w) & (c[:, [1, 3]] >= 0) & (c[:, [1, 3]] <= h)
    )
    inside = (a[:, 0] >= 0) & (a[:, 1] >= 0) & (a[:, 2] <= w) & (a[:, 3] <= h)
    assert np.array_equal(c[inside], a[inside])


# ---- Detections ---------------------------------------------------------------------------
def test_detections_validation_errors():
    with pytest.raises(ValueError, match="xyxy"):
        Detections(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="xyxy"):
        Detections(np.zeros(4))
    with pytest.raises(ValueError, match="confidence"):
        Detections(np.zeros((2, 4)), confidence=[0.5])
    with pytest.raises(ValueError, match="class_id"):
        Detections(np.zeros((2, 4)), class_id=np.ones((2, 1)))
    with pytest.raises(ValueError, match="frame"):
        Detections(np.zeros((2, 4)), frame=[1, 2, 3])
    with pytest.raises(ValueError, match="gt_id"):
        Detections(np.zeros((2, 4)), data={"gt_id": np.arange(3)})
    with pytest.raises(ValueError, match="gt_id"):
        Detections(np.zeros((2, 4)), data={"gt_id": 5})
    with pytest.raises(ValueError, match="confidence"):
        Detections(np.zeros((2, 4))).with_(confidence=[1.0, 2.0, 3.0])


def test_detections_defaults_and_broadcasting():
    d = Detections(np.zeros((3, 4)), confidence=0.5, frame=7)
    assert d.confidence.tolist() == [0.5] * 3 and d.frame.tolist() == [7] * 3
    assert d.class_id.tolist() == [0] * 3 and d.tracker_id.tolist() == [-1] * 3
    assert d.source_row.tolist() == [-1] * 3
    assert d.class_id.dtype == np.int64 and d.xyxy.dtype == np.float64
    for empty in (Detections.empty(), Detections([]), Detections(np.zeros((0, 4)))):
        assert len(empty) == 0 and empty.xyxy.shape == (0, 4)
        assert list(empty.frames()) == []
    x = Detections.from_xywh([[1, 2, 3, 4]])
    assert (
        x.xyxy.tolist() == [[1, 2, 4, 6]]
        and x.xywh.tolist() == [[1, 2, 3, 4]]
        and x.area.tolist() == [12]
    )


def _sample(n: int = 5) -> Detections:
    return Detections(
        np.arange(4 * n, dtype=float).reshape(n, 4) * [1, 1, 2, 2],
        confidence=np.linspace(0.1, 0.9, n),
        class_id=np.arange(n),
        tracker_id=np.arange(n) + 10,
        frame=[3, 1, 3, 2, 1][:n],
        source_row=np.arange(n) + 100,
        data={"gt_id": np.arange(n) * 2, "vec": np.arange(2 * n).reshape(n, 2)},
    )


def _rows(d: Detections) -> list:
    return [
        d.xyxy.tolist(),
        d.confidence.tolist(),
        d.class_id.tolist(),
        d.tracker_id.tolist(),
        d.frame.tolist(),
        d.source_row.tolist(),
        {k: v.tolist() for k, v in d.data.items()},
    ]


def test_detections_indexing():
    d = _sample()
    one = d[2]
    assert (
        len(one) == 1 and one.tracker_id.tolist() == [12] and one.data["vec"].tolist() == [[4, 5]]
    )
    assert d[np.int64(-1)].tracker_id.tolist() == [14]
    assert (
        _rows(d[1:4])
        == _rows(d[[1, 2, 3]])
        == _rows(d[np.array([False, True, True, True, False])])
    )
    assert d[d.confidence > 0.5].tracker_id.tolist() == [13, 14]
    assert len(d[np.zeros(5, bool)]) == 0 and set(d[np.zeros(5, bool)].data) == {"gt_id", "vec"}
    assert _rows(d[:]) == _rows(d)
    assert d[[4, 0]].source_row.tolist() == [104, 100]


def test_detections_concatenate():
    d = _sample()
    assert _rows(Detections.concatenate([d[:2], d[2:]])) == _rows(d)
    assert _rows(Detections.concatenate([Detections.empty(), d])) == _rows(
        d
    )  # empty parts are skipped
    assert len(Detections.concatenate([])) == 0
    assert len(Detections.concatenate([Detections.empty(), Detections.empty()])) == 0
    with pytest.raises(ValueError, match="data keys"):
        Detections.concatenate([d, Detections(np.zeros((1, 4)))])


@settings(deadline=None, max_examples=60)
@given(st.lists(st.integers(-3, 5), max_size=30))
def test_detections_frames_grouping_and_order(frames):
    n = len(frames)
    d = Detections(
        np.zeros((n, 4)), frame=np.array(frames, dtype=np.int64), source_row=np.arange(n)
    )
    groups = list(d.frames())
    keys = [f for f, _ in groups]
    assert keys == sorted(set(frames))  # increasing, one group per frame
    for f, g in groups:
        assert np.all(g.frame == f)
        rows = g.source_row.tolist()
        assert rows == [i for i, x in enumerate(frames) if x == f]  # input order within a frame
    assert sum(len(g) for _, g in groups) == n


@settings(deadline=None, max_examples=60)
@given(
    arrays(
        np.float64,
        st.tuples(st.integers(0, 5), st.just(4)),
        elements=st.floats(-100, 100, allow_nan=False, allow_infinity=False),
    )
)
def test_detections_accepts_any_float_boxes_and_keeps_them(xyxy):
    d = Detections(xyxy)
    assert np.array_equal(d.xyxy, xyxy) and len(d) == len(xyxy)


def test_detections_trusted_equals_validated():
    cols = dict(
        xyxy=np.array([[0.0, 0, 10, 10], [5, 5, 20, 30]]),
        confidence=np.array([0.5, 0.9]),
        class_id=np.array([1, 2], dtype=np.int64),
        tracker_id=np.array([3, 4], dtype=np.int64),
        frame=np.array([7, 7], dtype=np.int64),
        source_row=np.array([-1, 2], dtype=np.int64),
        data={"state": np.array([0, 1])},
    )
    a, b = Detections(**cols), Detections.trusted(**cols)
    for name in ("xyxy", "confidence", "class_id", "tracker_id", "frame", "source_row"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y)
    assert a.data.keys() == b.data.keys() and np.array_equal(a.data["state"], b.data["state"])


def test_tracker_output_columns_are_valid():
    """The tracker builds its output with Detections.trusted: validating it again is a no-op."""
    from sensemaking.tracker import Tracker

    t = Tracker(image_size=(100, 100))
    for f in range(3):
        out = t.update(
            Detections(
                xyxy=[[10.0 + f, 10, 30 + f, 40], [50, 50, 70, 90]],
                confidence=[0.9, 0.8],
                frame=[f, f],
            )
        ).tracks
        again = Detections(
            xyxy=out.xyxy,
            confidence=out.confidence,
            class_id=out.class_id,
            tracker_id=out.tracker_id,
            frame=out.frame,
            source_row=out.source_row,
            data=out.data,
        )
        for name in ("xyxy", "confidence", "class_id", "tracker_id", "frame", "source_row"):
            assert getattr(again, name).dtype == getattr(out, name).dtype
            assert np.array_equal(getattr(again, name), getattr(out, name))
    assert len(out) == 2


def test_front_margin_by_box_bottom_or_by_depth():
    from sensemaking.geometry import front_margin

    back = np.array([[0.0, 0.0, 10.0, 100.0], [0.0, 0.0, 10.0, 100.0]])
    front = np.array([[0.0, 20.0, 10.0, 130.0], [0.0, 20.0, 10.0, 105.0]])
    nan = np.full(2, np.nan)
    assert np.allclose(front_margin(front, back, nan, nan), [0.3, 0.05])  # pixels / height
    # with both depths the 3D gap counts, whatever the boxes: (20 - 15) / 20
    got = front_margin(front, back, np.array([15.0, np.nan]), np.array([20.0, 20.0]))
    assert np.allclose(got, [0.25, 0.05])
