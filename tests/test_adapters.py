"""Adapters from other libraries' detector outputs.

Duck-typed fakes, and the real libraries when installed.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from sensemaking.adapters import (
    COCO_ALIASES,
    as_detections,
    from_array,
    from_supervision,
    from_ultralytics,
    map_class_name,
    to_supervision,
)
from sensemaking.classes import CLASS_IDS
from sensemaking.detections import Detections

COCO = {
    0: "person",
    1: "bicycle",
    2: "car",
    3: "motorcycle",
    5: "bus",
    6: "train",
    7: "truck",
    9: "traffic light",
}


class FakeTensor:
    """Quacks like a torch tensor on a GPU: no __array__, only .detach().cpu().numpy()."""

    def __init__(self, values: Any):
        self._values = np.asarray(values, dtype=np.float32)
        self.moved = False

    def detach(self) -> FakeTensor:
        return self

    def cpu(self) -> FakeTensor:
        self.moved = True
        return self

    def numpy(self) -> np.ndarray:
        assert self.moved, "must be moved to the CPU before .numpy()"
        return self._values


def fake_ultralytics(
    xyxy: Any, conf: Any, cls: Any, names: dict[int, str] = COCO, tensors: bool = True
) -> Any:
    wrap = FakeTensor if tensors else np.asarray
    boxes = SimpleNamespace(xyxy=wrap(xyxy), conf=wrap(conf), cls=wrap(cls), id=None)
    return SimpleNamespace(boxes=boxes, names=names, orig_shape=(375, 1242))


BOXES = [[10, 20, 50, 80], [100, 100, 200, 180], [300, 50, 340, 120], [5, 5, 15, 30]]


def test_map_class_name_table():
    assert map_class_name("person") == CLASS_IDS["pedestrian"]
    assert map_class_name("Car") == CLASS_IDS["car"]
    assert map_class_name("bicycle") == CLASS_IDS["bicycle"]
    assert map_class_name("motorcycle") == CLASS_IDS["motorbike"]
    assert map_class_name("bus") == CLASS_IDS["truck"]
    assert map_class_name("train") == CLASS_IDS["tram"]
    assert map_class_name("Cyclist") == CLASS_IDS["cyclist"]
    assert map_class_name("Person_sitting") == CLASS_IDS["person_sitting"]
    assert map_class_name("traffic light") == 0
    assert set(COCO_ALIASES) >= {"person", "motorcycle", "bus", "train"}


@pytest.mark.parametrize("tensors", [True, False])
def test_from_ultralytics(tensors: bool):
    res = fake_ultralytics(BOXES, [0.9, 0.8, 0.7, 0.3], [0, 2, 5, 9], tensors=tensors)
    det = from_ultralytics(res, frame=7)
    assert isinstance(det, Detections) and len(det) == 4
    np.testing.assert_allclose(det.xyxy, BOXES)
    np.testing.assert_allclose(det.confidence, [0.9, 0.8, 0.7, 0.3], rtol=1e-6)
    assert det.class_id.tolist() == [
        CLASS_IDS["pedestrian"],
        CLASS_IDS["car"],
        CLASS_IDS["truck"],
        0,
    ]
    assert det.data["source_class_id"].tolist() == [0, 2, 5, 9]
    assert det.data["class_name"].tolist() == ["person", "car", "bus", "traffic light"]
    assert det.frame.tolist() == [7] * 4 and det.tracker_id.tolist() == [-1] * 4
    kept = from_ultralytics([res], drop_unknown=True)
    assert len(kept) == 3
    mapped = from_ultralytics(res, class_map={5: "bus_is_unknown", 9: CLASS_IDS["misc"]})
    assert mapped.class_id.tolist()[2:] == [0, CLASS_IDS["misc"]]


def test_from_ultralytics_edge_cases():
    empty = from_ultralytics(fake_ultralytics(np.zeros((0, 4)), [], []))
    assert len(empty) == 0 and empty.xyxy.shape == (0, 4)
    with pytest.raises(ValueError, match="no boxes"):
        from_ultralytics(SimpleNamespace(boxes=None, names={}))
    with pytest.raises(ValueError, match="one ultralytics Results"):
        from_ultralytics([fake_ultralytics(BOXES, [1] * 4, [0] * 4)] * 2)


def test_from_supervision_like():
    sv_like = SimpleNamespace(
        xyxy=np.array(BOXES[:3], dtype=np.float32),
        confidence=np.array([0.5, 0.6, 0.7]),
        class_id=np.array([0, 2, 1]),
        tracker_id=None,
        mask=None,
        data={
            "class_name": np.array(["person", "car", "bicycle"]),
            "depth": np.array([1.0, 2.0, 3.0]),
        },
    )
    det = from_supervision(sv_like, frame=3)
    assert det.class_id.tolist() == [
        CLASS_IDS["pedestrian"],
        CLASS_IDS["car"],
        CLASS_IDS["bicycle"],
    ]
    assert det.data["depth"].tolist() == [1.0, 2.0, 3.0]
    assert det.data["class_name"].tolist() == ["person", "car", "bicycle"]
    # no class names: ids through ``names`` or unknown
    bare = SimpleNamespace(
        xyxy=np.array(BOXES[:2]), confidence=None, class_id=np.array([2, 7]), data={}
    )
    assert from_supervision(bare).class_id.tolist() == [0, 0]
    assert from_supervision(bare, names=COCO).class_id.tolist() == [
        CLASS_IDS["car"],
        CLASS_IDS["truck"],
    ]
    assert from_supervision(bare).confidence.tolist() == [1.0, 1.0]
    no_class = SimpleNamespace(
        xyxy=np.array(BOXES[:2]), confidence=np.array([0.1, 0.2]), class_id=None, data={}
    )
    assert from_supervision(no_class).class_id.tolist() == [0, 0]


def test_supervision_round_trip():
    sv = pytest.importorskip("supervision")
    ours = Detections(
        xyxy=np.array(BOXES[:2], float),
        confidence=[0.4, 0.9],
        class_id=[CLASS_IDS["car"], CLASS_IDS["cyclist"]],
        tracker_id=[4, 9],
        frame=12,
        data={"state": np.array([0, 1]), "occluder": np.array([-1, 4])},
    )
    theirs = to_supervision(ours)
    assert isinstance(theirs, sv.Detections)
    assert theirs.tracker_id.tolist() == [4, 9]
    assert list(theirs.data["class_name"]) == ["car", "cyclist"]
    assert theirs.data["occluder"].tolist() == [-1, 4] and theirs.data["frame"].tolist() == [
        12,
        12,
    ]
    back = from_supervision(theirs)
    np.testing.assert_allclose(back.xyxy, ours.xyxy)
    assert back.class_id.tolist() == ours.class_id.tolist()
    assert as_detections(theirs).class_id.tolist() == ours.class_id.tolist()
    empty = to_supervision(Detections.empty())
    assert len(empty) == 0


def test_from_array_shapes():
    four = from_array(np.array(BOXES))
    assert four.confidence.tolist() == [1.0] * 4 and four.class_id.tolist() == [0] * 4
    five = from_array([[0, 0, 10, 10, 0.5]])
    assert five.confidence.tolist() == [0.5]
    six = from_array([[0, 0, 10, 10, 0.5, 3.0]], frame=4)
    assert six.class_id.tolist() == [3] and six.frame.tolist() == [4]
    assert len(from_array([])) == 0
    with pytest.raises(ValueError, match=r"\(N, 4\)"):
        from_array(np.zeros((2, 3)))


def test_as_detections_dispatch():
    det = Detections(xyxy=np.array(BOXES, float), frame=5)
    assert as_detections(det) is det
    assert as_detections(det, frame=5) is det
    assert as_detections(det, frame=6).frame.tolist() == [6] * 4
    assert len(as_detections(None)) == 0
    assert len(as_detections(np.array(BOXES))) == 4
    assert len(as_detections([[0, 0, 1, 1, 0.9, 1]])) == 1
    assert len(as_detections(FakeTensor(BOXES))) == 4
    ultra = fake_ultralytics(BOXES, [0.9] * 4, [0, 2, 2, 7])
    assert as_detections(ultra).class_id.tolist()[1] == CLASS_IDS["car"]
    assert len(as_detections([ultra])) == 4
    sv_like = SimpleNamespace(xyxy=np.array(BOXES), confidence=np.ones(4), class_id=None, data={})
    assert len(as_detections(sv_like)) == 4
    with pytest.raises(TypeError, match="cannot use"):
        as_detections("boxes.txt")
    with pytest.raises(TypeError, match="cannot use"):
        as_detections(np.zeros((3, 7)))


def test_tracker_accepts_detector_outputs():
    tracker_mod = pytest.importorskip("sensemaking.tracker")
    tracker = tracker_mod.Tracker(
        tracker_mod.TrackerConfig.for_dataset("kitti", image_size=(1242, 375))
    )
    for f in range(4):
        shifted = np.array(BOXES[:2], float) + [2 * f, 0, 2 * f, 0]
        result = tracker.update(fake_ultralytics(shifted, [0.95, 0.9], [2, 2]), frame=f)
    assert result.frame == 3
    assert set(result.tracks.class_id.tolist()) <= {CLASS_IDS["car"]}
