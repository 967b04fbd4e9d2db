"""The streaming reader gives what the whole-file readers give, in any chunk size, with the same
``file:line`` errors; the sinks write what the whole-file writers write."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA

from sensemaking.errors import InputError
from sensemaking.io.formats import read_detections
from sensemaking.io.stream import iter_detection_frames, scan_detections


def assert_same_frames(path: Path, fmt: str, chunk_lines: int) -> None:
    whole = dict(read_detections(path, fmt).frames())
    got = list(iter_detection_frames(path, fmt, chunk_lines=chunk_lines))
    assert [f for f, _ in got] == sorted(whole)
    for f, d in got:
        w = whole[f]
        for name in ("xyxy", "confidence", "class_id", "tracker_id", "source_row"):
            assert np.array_equal(getattr(d, name), getattr(w, name)), (path, f, name)
        assert sorted(d.data) == sorted(w.data)


def test_chunks_do_not_change_the_frames(tmp_path: Path) -> None:
    det = tmp_path / "det.txt"
    lines = [
        f"{f},-1,{10 + i},{20 + f},30,40,0.{i + 1},-1,-1,-1"
        for f in range(1, 40, 3)
        for i in range(3)
    ]
    lines.insert(5, "")  # a blank line keeps the line numbers right
    det.write_text("\n".join(lines) + "\n")
    for size in (1, 2, 4, 7, 1000):
        assert_same_frames(det, "mot", size)
    summary = scan_detections(det, "mot", chunk_lines=4)
    assert (summary.first, summary.last, summary.frames, summary.detections) == (1, 37, 13, 39)


@pytest.mark.parametrize(
    ("text", "line", "problem"),
    [
        (
            "1,-1,1,1,2,2,0.9\n3,-1,1,1,2,2,0.9\n2,-1,1,1,2,2,0.9\n",
            3,
            "lines must be sorted by frame",
        ),
        (
            "1,-1,1,1,2,2,0.9\n1,-1,1,1,2,2,0.9\n1,-1,1,1,2,2\n",
            3,
            "expected 7 comma-separated fields, got 6",
        ),
        ("1,-1,1,1,2,2,0.9\n2,-1,nan,1,2,2,0.9\n", 2, "must be a finite number"),
        ("1,-1,1,1,2,2,0.9\n20000000,-1,1,1,2,2,0.9\n", 2, "beyond the sequence"),
    ],
)
def test_errors_name_the_line_whatever_the_chunk(
    tmp_path: Path, text: str, line: int, problem: str
) -> None:
    det = tmp_path / "det.txt"
    det.write_text(text)
    for size in (1, 2, 100):
        with pytest.raises(InputError, match=problem) as err:
            scan_detections(det, "mot", chunk_lines=size)
        assert err.value.line == line


def test_zero_size_boxes_are_dropped_with_one_warning(tmp_path: Path, caplog) -> None:
    det = tmp_path / "det.txt"
    det.write_text("1,-1,1,1,0,2,0.9\n1,-1,1,1,2,2,0.9\n2,-1,1,1,2,0,0.9\n")
    summary = scan_detections(det, "mot", chunk_lines=1)
    assert (summary.detections, summary.dropped) == (1, 2)
    assert sum("dropped 2 detection(s)" in r.message for r in caplog.records) == 1


@pytest.mark.integration
def test_shared_files_stream_as_they_read_whole() -> None:
    files = (
        sorted((SHARED_DATA / "mot17").glob("*/det/det.txt"))[:2]
        + sorted((SHARED_DATA / "kitti" / "detections" / "rrc" / "car").glob("*.txt"))[:2]
        + sorted((SHARED_DATA / "kitti" / "detections" / "pointrcnn").glob("*/0000.txt"))[:1]
        + sorted((SHARED_DATA / "kitti" / "training" / "label_02").glob("*.txt"))[:1]
    )
    if not files:
        pytest.skip("../shared/data not found")
    for path in files:
        fmt = "mot" if "mot17" in str(path) else "kitti"
        assert_same_frames(path, fmt, 1000)
