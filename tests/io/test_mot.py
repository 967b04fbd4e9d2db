"""MOTChallenge readers and writer: known rows, round trips (exact), seqinfo."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from helpers import assert_same
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st

from sensemaking.detections import Detections
from sensemaking.io.formats import read_detections, write_results
from sensemaking.io.mot import SequenceInfo, read_mot, read_seqinfo, write_mot


def write(tmp_path: Path, text: str, name: str = "det.txt") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8", newline="")
    return path


# --------------------------------------------------------------------------- unit: reading


def test_read_det_ten_fields(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        "1,-1,10.5,20,30,40.25,0.9,-1,-1,-1\n"
        "1,-1,0,0,1,2,0.01,-1,-1,-1\n"
        "4,-1,5,6,7,8,0.5,-1,-1,-1\n",
    )
    d = read_mot(path)
    assert len(d) == 3
    np.testing.assert_array_equal(d.xyxy[0], [10.5, 20, 40.5, 60.25])
    np.testing.assert_array_equal(d.frame, [1, 1, 4])  # frames 2, 3 empty: fine
    np.testing.assert_array_equal(d.confidence, [0.9, 0.01, 0.5])
    np.testing.assert_array_equal(d.class_id, [1, 1, 1])
    np.testing.assert_array_equal(d.tracker_id, [-1, -1, -1])
    np.testing.assert_array_equal(d.source_row, [1, 2, 3])
    assert d.data == {}


def test_read_det_seven_fields_and_default_class(tmp_path: Path) -> None:
    path = write(tmp_path, "2,-1,1,2,3,4,0.75\n")
    d = read_mot(path, default_class=3)
    np.testing.assert_array_equal(d.xyxy, [[1, 2, 4, 6]])
    assert d.class_id.tolist() == [3] and d.frame.tolist() == [2]


def test_crlf_and_blank_lines_keep_line_numbers(tmp_path: Path) -> None:
    path = write(
        tmp_path, "1,-1,1,2,3,4,0.5\r\n\r\n2,-1,1,2,3,4,0.6\r\n  \n3,-1,1,2,3,4,0.7\r\n\n\n"
    )
    d = read_mot(path)
    assert d.source_row.tolist() == [1, 3, 5]
    assert d.confidence.tolist() == [0.5, 0.6, 0.7]


def test_byte_order_mark_is_skipped(tmp_path: Path) -> None:
    path = tmp_path / "det.txt"
    path.write_bytes(b"\xef\xbb\xbf1,-1,1,2,3,4,0.5\r\n")
    assert read_mot(path).frame.tolist() == [1]


def test_read_gt_mot17_sorted_by_frame_then_id(tmp_path: Path) -> None:
    path = write(tmp_path, "1,2,10,10,5,5,1,1,0.5\n2,1,11,11,5,5,0,7,0.25\n1,1,12,12,5,5,1,-1,1\n")
    d = read_mot(path, kind="gt")
    assert d.frame.tolist() == [1, 1, 2]
    assert d.tracker_id.tolist() == [1, 2, 1]
    assert d.source_row.tolist() == [3, 1, 2]
    assert d.class_id.tolist() == [1, 1, 7]  # -1 -> default_class
    assert d.data["consider"].tolist() == [1, 1, 0] and d.data["consider"].dtype == np.int64
    assert d.data["visibility"].tolist() == [1.0, 0.5, 0.25]
    assert d.confidence.tolist() == [1.0, 1.0, 1.0]


def test_read_gt_mot15_ten_fields(tmp_path: Path) -> None:
    path = write(
        tmp_path, "1,1,212,204,20,57,0,-3.1784,16.34,0.45739\n1,2,223,181,36,104,1,-1,-1,-1\n"
    )
    d = read_mot(path, kind="gt", default_class=1)
    assert d.class_id.tolist() == [1, 1]
    assert d.data["consider"].tolist() == [0, 1]  # TrackEval drops MOT15 rows marked 0
    assert d.data["visibility"].tolist() == [-1.0, -1.0]  # unknown in MOT15


def test_read_results(tmp_path: Path) -> None:
    path = write(
        tmp_path, "1,7,1,2,3,4,-1,-1,-1,-1\n1,3,5,6,7,8,0.5,-1,-1,-1\n2,7,1,2,3,4,1,-1,-1,-1\n"
    )
    d = read_mot(path, kind="results")
    assert d.tracker_id.tolist() == [7, 3, 7]
    assert d.confidence.tolist() == [-1.0, 0.5, 1.0]


def test_empty_results_and_gt_are_legal(tmp_path: Path) -> None:
    path = write(tmp_path, "\n\n")
    assert len(read_mot(path, kind="results")) == 0
    gt = read_mot(path, kind="gt")
    assert len(gt) == 0 and sorted(gt.data) == ["consider", "visibility"]


def test_zero_sized_detection_dropped_with_warning(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    path = write(tmp_path, "1,-1,1,2,3,4,0.5\n1,-1,1,2,0,4,0.5\n2,-1,1,2,3,4,0.5\n")
    d = read_mot(path)
    assert d.source_row.tolist() == [1, 3]
    assert "dropped 1 detection(s) of zero width or height (first on line 2)" in caplog.text


def test_read_detections_mot_uses_class_name(tmp_path: Path) -> None:
    path = write(tmp_path, "1,-1,1,2,3,4,0.5\n")
    assert read_detections(path, "mot").class_id.tolist() == [1]
    assert read_detections(path, "mot", class_name="car").class_id.tolist() == [3]


# --------------------------------------------------------------------------- unit: writing


def test_write_mot_text(tmp_path: Path) -> None:
    tracks = Detections.from_xywh(
        [[10, 20, 30, 40], [0.1, 0.2, 0.2, 1e-7]],
        confidence=[0.5, 1.0],
        tracker_id=[5, 6],
        frame=[2, 1],
    )
    out = tmp_path / "sub" / "res.txt"
    write_mot(out, tracks)
    assert out.read_text().splitlines() == [
        "1,6,0.1,0.2,0.2,1e-07,1,-1,-1,-1",  # sorted by frame
        "2,5,10,20,30,40,0.5,-1,-1,-1",
    ]
    assert not list(out.parent.glob("*.part"))


def test_write_results_dispatch_and_empty(tmp_path: Path) -> None:
    out = tmp_path / "res.txt"
    write_results(out, Detections.empty(), "mot")
    assert out.read_text() == ""
    assert len(read_mot(out, kind="results")) == 0
    with pytest.raises(ValueError, match="unknown format"):
        write_results(out, Detections.empty(), "csv")  # type: ignore[arg-type]


def test_write_refuses_bad_boxes_and_leaves_no_file(tmp_path: Path) -> None:
    out = tmp_path / "res.txt"
    bad = Detections(xyxy=[[0, 0, np.nan, 1]], frame=[1])
    with pytest.raises(ValueError, match="non-finite"):
        write_mot(out, bad)
    assert list(tmp_path.iterdir()) == []


def test_write_keeps_frame_order_stable(tmp_path: Path) -> None:
    tracks = Detections.from_xywh(np.ones((4, 4)), tracker_id=[4, 3, 2, 1], frame=[2, 1, 2, 1])
    out = tmp_path / "res.txt"
    write_mot(out, tracks)
    back = read_mot(out, kind="results")
    assert back.frame.tolist() == [1, 1, 2, 2]
    assert back.tracker_id.tolist() == [3, 1, 4, 2]


# --------------------------------------------------------------------------- lossless floats

coords = st.floats(min_value=-1e5, max_value=1e5, allow_nan=False, allow_infinity=False)
sizes = st.floats(min_value=1e-300, max_value=1e5, allow_nan=False, allow_infinity=False)
scores = st.floats(allow_nan=False, allow_infinity=False)
ROW = st.tuples(
    coords, coords, sizes, sizes, scores, st.integers(1, 10**6), st.integers(-1, 10**9)
)


@settings(
    max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.lists(ROW, min_size=1, max_size=20))
@example([(0.1, 0.2, 0.2, 0.1, 0.30000000000000004, 1, 1)])
@example([(-1000.0, 1e-3, 1000.001, 1.0, -0.0, 1, 1)])
@example([(1234.5678901234567, 1e-5, 1.2345678901234567e-3, 3.3333333333333335, 1e300, 2, 3)])
def test_mot_round_trip_is_exact_for_random_floats(tmp_path: Path, rows: list[tuple]) -> None:
    rows = sorted(
        (r for r in rows if r[0] + r[2] > r[0] and r[1] + r[3] > r[1]), key=lambda r: r[5]
    )
    assume(rows)  # x + w == x for a tiny w: no box
    arr = np.array([r[:4] for r in rows], dtype=np.float64)
    first = Detections.from_xywh(  # exactly what read_mot builds from "x,y,w,h"
        arr,
        confidence=[r[4] for r in rows],
        frame=[r[5] for r in rows],
        tracker_id=[r[6] for r in rows],
        source_row=np.arange(1, len(rows) + 1),
        class_id=1,
    )
    out = tmp_path / "res.txt"
    write_mot(out, first)
    second = read_mot(out, kind="results")
    assert_same(first, second)
    write_mot(out, second)
    assert_same(second, read_mot(out, kind="results"))


@settings(
    max_examples=50, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    st.lists(
        st.tuples(st.floats(0, 1e5), st.floats(0, 1e5), st.floats(0, 1e5), st.floats(0, 1e5)),
        min_size=1,
        max_size=20,
    )
)
@example([(0.0, 1.0, 1.2922106224250456, 32769.78174769245)])  # a tie: no float w has y + w == y2
def test_mot_any_corners_come_back_within_one_ulp(tmp_path: Path, rows: list[tuple]) -> None:
    # Corners not read from x, w (e.g. a filter's output) cannot always be hit exactly by x + w
    # (rounding ties); x1, y1 come back exactly and x2, y2 within one ulp, then stay put.
    corners = np.array([[min(a, b), min(c, d), max(a, b), max(c, d)] for a, b, c, d in rows])
    assume(bool(((corners[:, 2] > corners[:, 0]) & (corners[:, 3] > corners[:, 1])).all()))
    tracks = Detections(
        xyxy=corners, frame=1, tracker_id=1, class_id=1, source_row=np.arange(1, len(rows) + 1)
    )
    out = tmp_path / "res.txt"
    write_mot(out, tracks)
    back = read_mot(out, kind="results")
    assert_same(tracks, back, skip=("xyxy",))
    np.testing.assert_array_equal(back.xyxy[:, :2], corners[:, :2])
    assert np.all(np.abs(back.xyxy[:, 2:] - corners[:, 2:]) <= np.spacing(corners[:, 2:]))
    write_mot(out, back)
    assert_same(back, read_mot(out, kind="results"))


# --------------------------------------------------------------------------- seqinfo


def test_read_seqinfo_file_and_folder(tmp_path: Path) -> None:
    seq = tmp_path / "SEQ-01"
    seq.mkdir()
    (seq / "seqinfo.ini").write_text(
        "[Sequence]\nname=SEQ-01\nimDir=img1\nframeRate=30\nseqLength=600\nimWidth=1920\nimHeight=1080\nimExt=.jpg\n"
    )
    expected = SequenceInfo(name="SEQ-01", length=600, width=1920, height=1080, fps=30.0)
    assert read_seqinfo(seq) == expected
    assert read_seqinfo(seq / "seqinfo.ini") == expected
    (seq / "seqinfo.ini").write_text(
        "[Sequence]\nframeRate=12.5\nseqLength=3\nimWidth=4\nimHeight=5\n"
    )
    assert read_seqinfo(seq) == SequenceInfo("SEQ-01", 3, 4, 5, 12.5)


# --------------------------------------------------------------------------- integration


@pytest.fixture(scope="module")
def parsed(shared_data: Path) -> tuple[dict[str, Detections], float]:
    """Every MOT file of the shared data, read once: (relative path -> Detections, seconds
    taken)."""
    start = time.perf_counter()
    out: dict[str, Detections] = {}
    for path in sorted(shared_data.glob("mot*/*/det/det.txt")):
        out[str(path.relative_to(shared_data))] = read_detections(path, "mot")
    for path in sorted(shared_data.glob("mot*/*/gt/gt.txt")) + sorted(
        shared_data.glob("metric-fixtures/*/gt.txt")
    ):
        out[str(path.relative_to(shared_data))] = read_mot(path, kind="gt")
    for path in sorted(shared_data.glob("metric-fixtures/*/test.txt")):
        out[str(path.relative_to(shared_data))] = read_mot(path, kind="results")
    return out, time.perf_counter() - start


@pytest.mark.integration
def test_all_mot_files_parse_fast(parsed: tuple[dict[str, Detections], float]) -> None:
    files, elapsed = parsed
    assert len(files) == 11 + 13 + 2
    assert sum(map(len, files.values())) == 205_653
    assert elapsed < 3.0, f"parsing the MOT shared data took {elapsed:.2f} s"


@pytest.mark.integration
def test_known_rows_mot17(shared_data: Path, parsed: tuple[dict[str, Detections], float]) -> None:
    files = parsed[0]
    det = files["mot17/MOT17-02-YOLOX-half/det/det.txt"]
    assert len(det) == 24951
    # line 1: 1,-1,889.7,422.6,137.7,520.4,0.94,-1,-1,-1
    np.testing.assert_array_equal(det.xyxy[0], [889.7, 422.6, 889.7 + 137.7, 422.6 + 520.4])
    first = (
        det.frame[0],
        det.confidence[0],
        det.class_id[0],
        det.tracker_id[0],
        det.source_row[0],
    )
    assert first == (1, 0.94, 1, -1, 1)
    assert det.confidence.min() == 0.01 and det.confidence.max() == 0.95
    assert det.frame.max() == read_seqinfo(shared_data / "mot17/MOT17-02-YOLOX-half").length == 299

    frcnn = files["mot17/MOT17-05-FRCNN/det/det.txt"]  # 7 fields
    assert len(frcnn) == 3848
    # line 3: 1,-1,306.9,212.5,14.1,33.5,0.999
    np.testing.assert_array_equal(frcnn.xyxy[2], [306.9, 212.5, 306.9 + 14.1, 212.5 + 33.5])
    assert (frcnn.confidence[2], frcnn.source_row[2]) == (0.999, 3)

    gt = files["mot17/MOT17-02-YOLOX-half/gt/gt.txt"]
    assert len(gt) == 15430
    # line 1: 1,1,912,484,97,109,0,7,0 (the file is sorted by id; we sort by frame, id)
    assert gt.source_row[0] == 1
    np.testing.assert_array_equal(gt.xyxy[0], [912, 484, 1009, 593])
    assert (gt.frame[0], gt.tracker_id[0], gt.class_id[0]) == (1, 1, 7)
    assert (gt.data["consider"][0], gt.data["visibility"][0]) == (0, 0.0)
    assert np.all(np.diff(gt.frame) >= 0)
    assert int(((gt.class_id == 1) & (gt.data["consider"] == 1)).sum()) == 9880
    assert np.unique(gt.class_id).tolist() == [1, 2, 4, 7, 8, 9]


@pytest.mark.integration
def test_known_rows_mot15_and_fixtures(
    shared_data: Path, parsed: tuple[dict[str, Detections], float]
) -> None:
    files = parsed[0]
    gt = files["mot15/ETH-Bahnhof/gt/gt.txt"]
    assert len(gt) == 7670
    assert int((gt.data["consider"] == 0).sum()) == 2255
    np.testing.assert_array_equal(gt.xyxy[0], [212, 204, 232, 261])  # 1,1,212,204,20,57,0,...
    assert (gt.data["consider"][0], gt.data["visibility"][0], gt.class_id[0]) == (0, -1.0, 1)

    res = files["metric-fixtures/TUD-Campus/test.txt"]  # CRLF line ends
    assert len(res) == 222
    # line 1: 1,3,113.84,274.5,57.307,130.05,-1,-1,-1,-1
    np.testing.assert_array_equal(res.xyxy[0], [113.84, 274.5, 113.84 + 57.307, 274.5 + 130.05])
    assert (res.frame[0], res.tracker_id[0], res.confidence[0]) == (1, 3, -1.0)
    assert read_seqinfo(shared_data / "mot15/TUD-Campus/seqinfo.ini") == SequenceInfo(
        "TUD-Campus", 71, 640, 480, 25.0
    )


@pytest.mark.integration
def test_round_trip_every_mot_file(
    parsed: tuple[dict[str, Detections], float], tmp_path: Path
) -> None:
    out = tmp_path / "out.txt"
    for name, first in parsed[0].items():
        write_mot(out, first)
        if name.endswith("det.txt"):
            assert_same(first, read_mot(out, kind="det"), where=name)
        elif name.endswith("test.txt"):
            assert_same(first, read_mot(out, kind="results"), where=name)
        else:  # gt has no writer of its own: boxes, ids and frames survive the results format
            assert_same(
                first,
                read_mot(out, kind="results"),
                skip=("class_id", "source_row", "data"),
                where=name,
            )


@pytest.mark.integration
def test_every_sequence_fits_its_seqinfo(
    shared_data: Path, parsed: tuple[dict[str, Detections], float]
) -> None:
    seqs = sorted(p.parent for p in shared_data.glob("mot*/*/seqinfo.ini"))
    assert len(seqs) == 11
    for seq in seqs:
        info = read_seqinfo(seq)
        assert info.name == seq.name and info.width > 0 and info.height > 0 and info.fps > 0
        for kind in ("det", "gt"):
            boxes = parsed[0][str((seq / kind / f"{kind}.txt").relative_to(shared_data))]
            assert boxes.frame.min() >= 1 and boxes.frame.max() <= info.length, seq


def test_results_sorted_by_id_are_accepted_in_file_order(tmp_path):
    path = tmp_path / "res.txt"
    path.write_text(
        "1,1,10,20,30,40,1,-1,-1,-1\n2,1,11,20,30,40,1,-1,-1,-1\n1,2,50,20,30,40,1,-1,-1,-1\n"
    )
    res = read_mot(path, kind="results")
    assert res.frame.tolist() == [1, 2, 1]
    assert res.tracker_id.tolist() == [1, 1, 2]
