"""Scene context files: corridor, lanes JSON, segmentation label maps.

The readers of sensemaking.reasoning.context.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from test_scene_helpers import CAR, Obj, build_results, linear

from sensemaking.errors import InputError
from sensemaking.reasoning.context import (
    CITYSCAPES_LABELS,
    Corridor,
    LaneMap,
    SceneContext,
    Segmentation,
    asp_name,
    load_lanes,
)
from sensemaking.reasoning.online import SituationMonitor

SIZE = (1242, 375)


def test_default_corridor_is_a_lower_middle_trapezoid_scaled_to_the_image():
    c = Corridor()
    assert c.polygon((1000, 500)).tolist() == [[100, 500], [900, 500], [600, 250], [400, 250]]
    xl, xr = c.span_at(np.array([500, 375, 100]), (1000, 500))
    assert (xl[0], xr[0]) == (100, 900) and (xl[1], xr[1]) == (250, 750)
    assert np.isnan(xl[2]) and np.isnan(xr[2])  # above the corridor
    # at y = 480 the corridor spans x = 124..876
    boxes = np.array(
        [[450, 400, 550, 480], [0, 400, 100, 480], [20, 300, 220, 480], [450, 100, 550, 200]]
    )
    assert c.overlap(boxes, (1000, 500)).round(2).tolist() == [1.0, 0.0, 0.48, 0.0]
    assert c.contains_boxes(boxes, (1000, 500)).tolist() == [True, False, False, False]
    assert c.contains_points(np.array([[500, 490], [50, 490]]), (1000, 500)).tolist() == [
        True,
        False,
    ]


def test_corridor_in_pixels_and_parsing():
    c = Corridor.parse("0,375 1242,375 621,100")
    assert not c.normalized and c.contains_points(np.array([[621, 300]]), SIZE).tolist() == [True]
    n = Corridor.parse("0.2,1 0.8,1 0.5,0.5")
    assert n.normalized
    assert Corridor.from_json(n.to_json()) == n
    with pytest.raises(InputError, match="at least 3"):
        Corridor.parse("1,2,3,4")
    with pytest.raises(ValueError):
        Corridor(((0, 0), (1, 1)))


def test_lanes_centre_line_boundaries_and_per_frame(tmp_path):
    p = tmp_path / "lanes.json"
    p.write_text(
        json.dumps(
            {
                "lanes": [
                    {"id": 1, "points": [[600, 375], [620, 200]], "width": 100},
                    {
                        "id": "bus",
                        "left": [[800, 375], [700, 200]],
                        "right": [[1000, 375], [760, 200]],
                    },
                ],
                "frames": {
                    "10": [{"id": 7, "points": [[100, 375], [100, 200]], "widths": [40, 20]}]
                },
            }
        )
    )
    lm = load_lanes(p)
    assert [ln.id for ln in lm.lanes_at(0)] == [1, "bus"]
    assert [ln.id for ln in lm.lanes_at(10)] == [7] and [ln.id for ln in lm.lanes_at(50)] == [7]
    lane = lm.lanes_at(0)[0]
    xl, xr = lane.span_at(np.array([375.0, 200.0, 100.0]))
    assert (xl[0], xr[0]) == (550, 650) and (xl[1], xr[1]) == (570, 670) and np.isnan(xl[2])
    assert lane.contains_points(np.array([[600, 300], [700, 300]])).tolist() == [True, False]
    narrow = lm.lanes_at(10)[0]
    assert narrow.span_at(np.array([200.0]))[0][0] == 90  # width 20 at the top
    assert bool(lm) and not bool(LaneMap())


@pytest.mark.parametrize(
    "record,problem",
    [
        ({"nolanes": []}, "'lanes' and/or 'frames'"),
        ({"lanes": [{"id": 1, "points": [[0, 0]]}]}, "at least two"),
        ({"lanes": [{"id": 1, "points": [[0, 0], [1, 1]]}]}, "needs 'width' or 'widths'"),
        ({"lanes": [{"id": 1, "points": [[0, 0], [1, 1]], "widths": [3]}]}, "one value per point"),
        ({"lanes": [{"id": 1.5, "points": [[0, 0], [1, 1]], "width": 3}]}, "integer or a string"),
        ({"lanes": [{"id": 1, "points": [[0, 0], [1, 1]], "width": 0}]}, ">= 1 pixel"),
        ({"frames": {"x": []}}, "not a frame number"),
    ],
)
def test_lane_file_errors(tmp_path, record, problem):
    p = tmp_path / "lanes.json"
    p.write_text(json.dumps(record))
    with pytest.raises(InputError, match=problem) as err:
        load_lanes(p)
    assert str(p) in str(err.value)


def test_lane_file_not_json_or_missing(tmp_path):
    p = tmp_path / "lanes.json"
    p.write_text("{\n  oops")
    with pytest.raises(InputError, match=r"lanes.json:2: not valid JSON"):
        load_lanes(p)
    with pytest.raises(InputError, match="lanes file not found"):
        load_lanes(tmp_path / "none.json")


def _label_map(road_rows: int = 300) -> np.ndarray:
    lm = np.full((375, 1242), 1, dtype=np.uint8)  # sidewalk
    lm[road_rows:, 400:900] = 0  # road in the lower middle
    return lm


def test_segmentation_npy_per_frame_and_surface(tmp_path):
    np.save(tmp_path / "000003.npy", _label_map())
    seg = Segmentation(tmp_path)
    assert seg.label_map(0) is None and seg.label_map(3).shape == (375, 1242)
    boxes = np.array([[500, 200, 600, 320], [100, 200, 200, 320], [500, 200, 600, 374]])
    assert seg.surface_under(3, boxes, SIZE) == [
        "road",
        "sidewalk",
        None,
    ]  # last: below is off the map
    assert seg.surface_under(4, boxes, SIZE) == [None, None, None]


def test_segmentation_png_static_file_labels_and_scaling(tmp_path):
    pil = pytest.importorskip("PIL.Image")
    small = _label_map()[::3, ::3]  # a third of the image size: scaled
    pil.fromarray(small).save(tmp_path / "seg.png")
    (tmp_path / "labels.json").write_text(json.dumps({"0": "Drivable Road", "1": "side walk"}))
    seg = Segmentation(tmp_path / "seg.png")
    assert seg.labels == {0: "drivable_road", 1: "side_walk"}
    boxes = np.array([[500, 200, 600, 320]])
    assert (
        seg.surface_under(0, boxes, SIZE)
        == seg.surface_under(99, boxes, SIZE)
        == ["drivable_road"]
    )


def test_segmentation_errors(tmp_path):
    with pytest.raises(InputError, match="not found"):
        Segmentation(tmp_path / "none")
    (tmp_path / "x.txt").write_text("")
    with pytest.raises(InputError, match=".npy or .png"):
        Segmentation(tmp_path / "x.txt")
    np.save(tmp_path / "0.npy", np.zeros((4, 4), dtype=float))
    with pytest.raises(InputError, match="2-D integer array"):
        Segmentation(tmp_path).label_map(0)


def test_asp_name_and_default_labels():
    assert (
        asp_name("Traffic Light") == "traffic_light"
        and asp_name("3d") == "l_3d"
        and asp_name("") == "unknown"
    )
    assert CITYSCAPES_LABELS[0] == "road" and CITYSCAPES_LABELS[13] == "car"


def test_scene_context_load(tmp_path):
    (tmp_path / "lanes.json").write_text(
        json.dumps({"lanes": [{"id": 1, "points": [[600, 375], [620, 200]], "width": 200}]})
    )
    np.save(tmp_path / "seg.npy", _label_map())
    (tmp_path / "labels.json").write_text(json.dumps({"0": "road", "1": "sidewalk"}))
    ctx = SceneContext.load(
        lanes=tmp_path / "lanes.json",
        segmentation=tmp_path / "seg.npy",
        labels=tmp_path / "labels.json",
        corridor="0.2,1 0.8,1 0.5,0.6",
    )
    assert ctx.lanes and ctx.segmentation is not None and ctx.corridor.points[2] == (0.5, 0.6)
    assert SceneContext.load().lanes is None


def test_blocked_lane_uses_the_ground_label():
    """A car standing on the lane but on the sidewalk (per segmentation) does not block it."""
    lanes = LaneMap.from_json(
        {"lanes": [{"id": 1, "points": [[620, 375], [620, 200]], "width": 400}]}
    )

    class FakeSeg(Segmentation):
        def __init__(self, label: str):
            self.label = label

        def surface_under(self, frame, xyxy, image_size):
            return [self.label] * len(xyxy)

    car = Obj(1, CAR, linear(range(12), (560, 230, 700, 310)))
    for label, expected in (("road", 1), ("sidewalk", 0)):
        mon = SituationMonitor(
            context=SceneContext(lanes=lanes, segmentation=FakeSeg(label)),
            fps=10.0,
            image_size=SIZE,
        )
        got = [w for w in mon.run(build_results([car])) if w.situation == "BLOCKED_LANE"]
        assert len(got) == expected
