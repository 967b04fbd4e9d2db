"""KITTI readers and writer: labels, RRC and PointRCNN detections, seqinfo.csv, exact round
trips."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from helpers import assert_same, same_array
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from sensemaking.classes import CLASS_IDS, KITTI_NAMES
from sensemaking.detections import Detections
from sensemaking.errors import InputError
from sensemaking.io.formats import read_detections, write_results
from sensemaking.io.kitti import (
    read_kitti_detections,
    read_kitti_labels,
    read_kitti_seqinfo,
    write_kitti,
)
from sensemaking.io.mot import SequenceInfo

CAR, PED, CYC, VAN, DONTCARE = (
    CLASS_IDS[n] for n in ("car", "pedestrian", "cyclist", "van", "dontcare")
)

LABELS = (
    "0 -1 DontCare -1 -1 -10.000000 219.310000 188.490000 245.500000 218.560000 -1000.000000 "
    "-1000.000000 -1000.000000 -10.000000 -1.000000 -1.000000 -1.000000\n"
    "0 0 Van 0 0 -1.793451 296.744956 161.752147 455.226042 292.372804 2.000000 1.823255 "
    "4.433886 -4.552284 1.858523 13.410495 -2.115488\n"
    "1 1 Pedestrian 1 2 0.5 10 20 30 60 1.7 0.6 0.8 1 2 3 0.25\n"
)


def write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8", newline="")
    return path


# --------------------------------------------------------------------------- labels


def test_read_labels(tmp_path: Path) -> None:
    d = read_kitti_labels(write(tmp_path / "0000.txt", LABELS))
    assert len(d) == 3
    assert d.class_id.tolist() == [DONTCARE, VAN, PED]
    assert d.tracker_id.tolist() == [-1, 0, 1]
    assert d.frame.tolist() == [0, 0, 1]
    assert d.source_row.tolist() == [1, 2, 3]
    assert d.confidence.tolist() == [1.0, 1.0, 1.0]
    np.testing.assert_array_equal(d.xyxy[1], [296.744956, 161.752147, 455.226042, 292.372804])
    assert d.data["truncated"].tolist() == [-1.0, 0.0, 1.0]
    assert d.data["occluded"].tolist() == [-1, 0, 2] and d.data["occluded"].dtype == np.int64
    assert d.data["alpha"].tolist() == [-10.0, -1.793451, 0.5]
    np.testing.assert_array_equal(d.data["dimensions"][1], [2.0, 1.823255, 4.433886])
    np.testing.assert_array_equal(d.data["location"][1], [-4.552284, 1.858523, 13.410495])
    assert d.data["rotation_y"].tolist() == [-1.0, -2.115488, 0.25]


def test_read_results_with_score_sorted_by_frame_then_id(tmp_path: Path) -> None:
    text = (
        "1 4 Car -1 -1 -10 1 2 3 4 -1 -1 -1 -1000 -1000 -1000 -10 -2.5\n"
        "0 9 car 0 0 0 1 2 3 4 1 1 1 1 1 1 0 0.5\n"
    )
    d = read_kitti_labels(write(tmp_path / "r.txt", text))
    assert d.frame.tolist() == [0, 1] and d.source_row.tolist() == [2, 1]
    assert d.confidence.tolist() == [0.5, -2.5]
    assert d.class_id.tolist() == [CAR, CAR]


def test_empty_labels_give_empty_detections_with_columns(tmp_path: Path) -> None:
    d = read_kitti_labels(write(tmp_path / "r.txt", "\n"))
    assert len(d) == 0 and d.data["dimensions"].shape == (0, 3)
    write_kitti(tmp_path / "r.txt", d)
    assert (tmp_path / "r.txt").read_text() == ""
    assert_same(d, read_kitti_labels(tmp_path / "r.txt"))


def test_write_kitti_text_with_defaults(tmp_path: Path) -> None:
    tracks = Detections(
        xyxy=[[10, 20, 30.5, 40], [1, 2, 3, 4]],
        confidence=[0.75, 1],
        class_id=[CAR, PED],
        tracker_id=[3, 1],
        frame=[5, 2],
    )
    out = tmp_path / "out" / "0001.txt"
    write_kitti(out, tracks)
    assert out.read_text().splitlines() == [
        "2 1 Pedestrian -1 -1 -10 1 2 3 4 -1 -1 -1 -1000 -1000 -1000 -10 1",
        "5 3 Car -1 -1 -10 10 20 30.5 40 -1 -1 -1 -1000 -1000 -1000 -10 0.75",
    ]
    back = read_kitti_labels(out)
    assert back.class_id.tolist() == [PED, CAR] and back.confidence.tolist() == [1.0, 0.75]


def test_write_kitti_refuses_class_without_kitti_name(tmp_path: Path) -> None:
    out = tmp_path / "0000.txt"
    tracks = Detections(xyxy=[[1, 2, 3, 4]], class_id=[CLASS_IDS["bicycle"]], frame=[0])
    with pytest.raises(InputError, match=r"class 4 \(bicycle\) has no KITTI type name") as info:
        write_kitti(out, tracks)
    assert info.value.path == str(out) and info.value.line is None
    assert list(tmp_path.iterdir()) == []  # nothing written, not even a partial file
    with pytest.raises(InputError, match="class 0"):
        write_results(out, Detections(xyxy=[[1, 2, 3, 4]]), "kitti")  # default class 0 = unknown


names = st.sampled_from(sorted(KITTI_NAMES))
real = st.floats(allow_nan=False, allow_infinity=False)
pixel = st.floats(min_value=-1e4, max_value=1e4, allow_nan=False)
label_row = st.tuples(
    st.integers(0, 10**5),
    st.integers(-1, 10**6),
    names,
    real,
    st.integers(-1, 3),
    st.tuples(pixel, pixel, st.floats(1e-3, 1e4), st.floats(1e-3, 1e4)),
    st.lists(real, min_size=8, max_size=8),
    real,
)


@settings(
    max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.lists(label_row, min_size=1, max_size=20))
@example(
    [
        (
            0,
            1,
            CAR,
            0.30000000000000004,
            0,
            (0.1, 0.2, 1e-3, 1.0),
            [-0.0, 1e-300, 1e300, 2.5, -7.0, 1 / 3, 2**0.5, -1e-7],
            1e16,
        )
    ]
)
def test_kitti_round_trip_is_exact_for_random_floats(tmp_path: Path, rows: list[tuple]) -> None:
    rows.sort(key=lambda r: (r[0], r[1]))
    xyxy = np.array([[x, y, x + w, y + h] for _, _, _, _, _, (x, y, w, h), _, _ in rows])
    extra = np.array([r[6] for r in rows])
    first = Detections(
        xyxy=xyxy,
        confidence=[r[7] for r in rows],
        class_id=[r[2] for r in rows],
        tracker_id=[r[1] for r in rows],
        frame=[r[0] for r in rows],
        source_row=np.arange(1, len(rows) + 1),
        data={
            "truncated": np.array([r[3] for r in rows]),
            "occluded": np.array([r[4] for r in rows]),
            "alpha": extra[:, 0],
            "dimensions": extra[:, 1:4],
            "location": extra[:, 4:7],
            "rotation_y": extra[:, 7],
        },
    )
    out = tmp_path / "0000.txt"
    write_kitti(out, first)
    assert_same(first, read_kitti_labels(out))


# --------------------------------------------------------------------------- detections


def test_rrc_class_from_folder_or_name(tmp_path: Path) -> None:
    text = "0,296.021000,160.173000,452.297000,288.372000,0.529230\r\n2,1,2,3,4,0.1\r\n"
    d = read_kitti_detections(write(tmp_path / "rrc" / "car" / "0000.txt", text))
    assert d.class_id.tolist() == [CAR, CAR] and d.frame.tolist() == [0, 2]
    np.testing.assert_array_equal(d.xyxy[0], [296.021, 160.173, 452.297, 288.372])
    assert d.confidence.tolist() == [0.52923, 0.1] and d.tracker_id.tolist() == [-1, -1]
    assert d.data == {}
    other = write(tmp_path / "mine" / "0000.txt", text)
    assert read_kitti_detections(other, class_name="Pedestrian").class_id.tolist() == [PED, PED]
    assert read_detections(other, "kitti", class_name="cyclist").class_id.tolist() == [CYC, CYC]


def test_pointrcnn(tmp_path: Path) -> None:
    text = (
        "0,2,298.3125,165.1800,458.2292,293.4391,8.2981,1.9605,1.8137,4.7549,-4.5720,1.8435,13.5308,-2.1125,-1.7867\n"
        "0,1,364.7274,137.8874,453.8243,172.5940,-0.4501,1.4779,1.5952,3.8674,-9.0942,-0.0122,32.8211,-1.0285,-0.7582\n"
        "1,3,1,2,3,4,0,1,1,1,1,1,1,1,1\n"
    )
    d = read_kitti_detections(write(tmp_path / "any" / "0000.txt", text))
    assert d.class_id.tolist() == [CAR, PED, CYC]
    # the logits, mapped through the sigmoid to probabilities
    np.testing.assert_allclose(d.confidence, 1 / (1 + np.exp(-np.array([8.2981, -0.4501, 0.0]))))
    np.testing.assert_array_equal(d.xyxy[0], [298.3125, 165.18, 458.2292, 293.4391])
    np.testing.assert_array_equal(d.data["dimensions"][0], [1.9605, 1.8137, 4.7549])
    np.testing.assert_array_equal(d.data["location"][0], [-4.572, 1.8435, 13.5308])
    assert d.data["rotation_y"][0] == -2.1125 and d.data["alpha"][0] == -1.7867


def test_zero_width_detection_is_dropped_with_warning(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    text = "0,1,2,3,4,0.5\n1,1241,185.4478,1241,374,0.1\n2,1,2,3,4,0.5\n"
    d = read_kitti_detections(write(tmp_path / "car" / "0000.txt", text))
    assert d.source_row.tolist() == [1, 3]
    assert "dropped 1 detection(s) of zero width or height (first on line 2)" in caplog.text


def test_empty_detection_file_is_an_empty_sequence(tmp_path: Path) -> None:
    path = write(tmp_path / "pedestrian" / "0005.txt", "")
    assert len(read_kitti_detections(path)) == 0
    assert len(read_detections(path, "kitti")) == 0


def test_read_detections_sniffs_kitti_kinds(tmp_path: Path) -> None:
    labels = write(tmp_path / "label.txt", LABELS)
    rrc = write(tmp_path / "car" / "rrc.txt", "0,1,2,3,4,0.5\n")
    prcnn = write(tmp_path / "p.txt", "0,1,1,2,3,4,0,1,1,1,1,1,1,1,1\n")
    assert_same(read_detections(labels, "kitti"), read_kitti_labels(labels))
    assert_same(read_detections(rrc, "kitti"), read_kitti_detections(rrc))
    # PointRCNN logits become probabilities (sigmoid) in the one reader every path uses
    assert_same(read_detections(prcnn, "kitti"), read_kitti_detections(prcnn))
    assert read_detections(prcnn, "kitti").confidence.tolist() == [0.5]


def test_read_kitti_seqinfo(tmp_path: Path) -> None:
    path = write(
        tmp_path / "seqinfo.csv",
        "seq,num_frames,im_width,im_height,frame_rate\n0000,154,1242,375,10\n\n"
        "0001,447,1242,375,10\n",
    )
    infos = read_kitti_seqinfo(path)
    assert infos == {
        "0000": SequenceInfo("0000", 154, 1242, 375, 10.0),
        "0001": SequenceInfo("0001", 447, 1242, 375, 10.0),
    }


# --------------------------------------------------------------------------- integration


@pytest.fixture(scope="module")
def parsed(shared_data: Path) -> tuple[dict[str, Detections], float]:
    """Every KITTI file of the shared data, read once: (relative path -> Detections, seconds)."""
    start = time.perf_counter()
    out = {
        str(p.relative_to(shared_data)): read_kitti_labels(p)
        for p in sorted(shared_data.glob("kitti/training/label_02/*.txt"))
    }
    for p in sorted(shared_data.glob("kitti/detections/*/*/*.txt")):
        out[str(p.relative_to(shared_data))] = read_detections(p, "kitti")
    return out, time.perf_counter() - start


@pytest.mark.integration
def test_all_kitti_files_parse_fast(parsed: tuple[dict[str, Detections], float]) -> None:
    files, elapsed = parsed
    assert len(files) == 11 + 11 * 5
    assert sum(len(d) for name, d in files.items() if "label_02" in name) == 26359
    assert elapsed < 3.0, f"parsing the KITTI shared data took {elapsed:.2f} s"


@pytest.mark.integration
def test_known_label_rows(parsed: tuple[dict[str, Detections], float]) -> None:
    gt = parsed[0]["kitti/training/label_02/0000.txt"]
    assert len(gt) == 1089
    # line 1: 0 -1 DontCare -1 -1 -10.000000 219.310000 188.490000 245.500000 218.560000 -1000 ...
    assert (gt.frame[0], gt.tracker_id[0], gt.class_id[0], gt.source_row[0]) == (
        0,
        -1,
        DONTCARE,
        1,
    )
    np.testing.assert_array_equal(gt.xyxy[0], [219.31, 188.49, 245.5, 218.56])
    # line 3: 0 0 Van 0 0 -1.793451 296.744956 161.752147 455.226042 292.372804 2 1.823255
    # 4.433886 ...
    assert (gt.tracker_id[2], gt.class_id[2], gt.source_row[2], gt.data["occluded"][2]) == (
        0,
        VAN,
        3,
        0,
    )
    np.testing.assert_array_equal(gt.data["location"][2], [-4.552284, 1.858523, 13.410495])
    assert gt.data["rotation_y"][2] == -2.115488
    assert np.unique(gt.class_id).tolist() == [PED, CAR, VAN, CYC, DONTCARE]
    assert gt.source_row.tolist() == list(
        range(1, 1090)
    )  # the file is sorted by (frame, id) already


@pytest.mark.integration
def test_known_detection_rows(parsed: tuple[dict[str, Detections], float]) -> None:
    files = parsed[0]
    rrc = files["kitti/detections/rrc/car/0000.txt"]
    assert len(rrc) == 513 and set(rrc.class_id.tolist()) == {CAR}
    np.testing.assert_array_equal(rrc.xyxy[0], [296.021, 160.173, 452.297, 288.372])
    assert rrc.confidence[0] == 0.52923 and rrc.confidence.min() >= 0.1
    assert set(files["kitti/detections/rrc/pedestrian/0000.txt"].class_id.tolist()) == {PED}
    assert len(files["kitti/detections/rrc/pedestrian/0005.txt"]) == 0  # empty file in the data

    prcnn = files["kitti/detections/pointrcnn/car/0000.txt"]
    assert len(prcnn) == 1054 - 1  # line 614 has x1 == x2 == 1241: dropped
    assert 614 not in prcnn.source_row.tolist()
    # read_detections maps PointRCNN logits through the sigmoid (8.2981 and -0.4501 in the file)
    np.testing.assert_allclose(
        prcnn.confidence[[0, 2]], 1 / (1 + np.exp(-np.array([8.2981, -0.4501])))
    )
    np.testing.assert_array_equal(prcnn.data["dimensions"][0], [1.9605, 1.8137, 4.7549])
    assert set(files["kitti/detections/pointrcnn/cyclist/0000.txt"].class_id.tolist()) == {CYC}


@pytest.mark.integration
def test_round_trip_every_kitti_file(
    parsed: tuple[dict[str, Detections], float], tmp_path: Path
) -> None:
    out = tmp_path / "0000.txt"
    for name, first in parsed[0].items():
        write_kitti(out, first)
        second = read_kitti_labels(out)
        if "label_02" in name:
            assert_same(first, second, where=name)
        else:
            # detections: boxes, scores, classes, frames and 3D fields survive the results format
            assert_same(first, second, skip=("source_row", "data"), where=name)
            for key, value in first.data.items():
                same_array(value, second.data[key], f"{name} data[{key!r}]")


@pytest.mark.integration
def test_kitti_seqinfo_fits_labels(
    shared_data: Path, parsed: tuple[dict[str, Detections], float]
) -> None:
    infos = read_kitti_seqinfo(shared_data / "kitti/training/seqinfo.csv")
    assert sorted(infos) == [f"{i:04d}" for i in range(11)]
    assert infos["0000"] == SequenceInfo("0000", 154, 1242, 375, 10.0)
    for seq, info in infos.items():
        gt = parsed[0][f"kitti/training/label_02/{seq}.txt"]
        assert gt.frame.min() >= 0 and gt.frame.max() < info.length, seq
