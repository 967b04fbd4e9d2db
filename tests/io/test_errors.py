"""Bad input: every reader raises InputError naming the file, the 1-based line and the problem."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from pathlib import Path

import pytest

from sensemaking.detections import Detections
from sensemaking.errors import InputError
from sensemaking.io.formats import read_detections, write_results
from sensemaking.io.kitti import read_kitti_detections, read_kitti_labels, read_kitti_seqinfo
from sensemaking.io.mot import read_mot, read_seqinfo

DET = "1,-1,10,20,30,40,0.9,-1,-1,-1\n"
LABEL = "0 1 Car 0 0 -1.5 10 20 40 60 1.5 1.6 3.9 1 2 20 -1.6\n"
RRC = "0,10,20,40,60,0.9\n"
PRCNN = "0,2,10,20,40,60,0.9,1.5,1.6,3.9,1,2,20,-1.6,-1.5\n"

det = partial(read_mot, kind="det")
gt = partial(read_mot, kind="gt")
results = partial(read_mot, kind="results")
kitti = partial(read_detections, fmt="kitti")
OVERFLOW = "box corner x + width or y + height is not representable in float64"

# (reader, file name, content, line, problem)
CASES: list[tuple[Callable, str, str, int | None, str]] = [
    # --- MOTChallenge: shape of the table
    (
        det,
        "det.txt",
        DET * 2 + "3,-1,1,2,3,4,0.5\n" + DET,
        3,
        "expected 10 comma-separated fields, got 7",
    ),
    (det, "det.txt", "1,-1,1,2,3\n", 1, "expected 7 to 10 comma-separated fields, got 5"),
    (gt, "gt.txt", "1,1,1,2,3,4,1,1\n", 1, "expected 9 or 10 comma-separated fields, got 8"),
    (
        det,
        "det.txt",
        DET + "1,-1,abc,2,3,4,0.5,-1,-1,-1\n",
        2,
        "field 3 (x) is not a number: 'abc'",
    ),
    (det, "det.txt", DET + "1,-1,1,,3,4,0.5,-1,-1,-1\n", 2, "field 4 (y) is not a number: ''"),
    (results, "res.txt", "1;2;3;4;5;6;7\n", 1, "expected 7 to 10 comma-separated fields, got 1"),
    (gt, "gt.txt", "1,1,1,2,3,4,yes,1,1\n", 1, "field 7 (consider flag) is not a number: 'yes'"),
    # --- MOTChallenge: values
    (
        det,
        "det.txt",
        DET + "1,-1,nan,2,3,4,0.5,-1,-1,-1\n",
        2,
        "x must be a finite number, got nan",
    ),
    (
        det,
        "det.txt",
        DET * 3 + "2,-1,1,2,3,inf,0.5,-1,-1,-1\n",
        4,
        "height must be a finite number, got inf",
    ),
    (results, "res.txt", "1,1,1,2,3,4,nan\n", 1, "confidence must be a finite number, got nan"),
    (
        det,
        "det.txt",
        DET + "1,-1,1,2,-3,4,0.5,-1,-1,-1\n",
        2,
        "box width and height must be positive, got width -3 and height 4",
    ),
    (
        gt,
        "gt.txt",
        "1,1,1,2,3,4,1,1,1\n1,2,1,2,3,0,1,1,1\n",
        2,
        "box width and height must be positive, got width 3 and height 0",
    ),
    (
        results,
        "res.txt",
        "1,1,1,2,0,4,1\n",
        1,
        "box width and height must be positive, got width 0 and height 4",
    ),
    (
        det,
        "det.txt",
        DET + "0,-1,1,2,3,4,0.5,-1,-1,-1\n",
        2,
        "frame must be >= 1 (MOTChallenge frames are 1-based), got 0",
    ),
    (det, "det.txt", "1.5,-1,1,2,3,4,0.5\n", 1, "frame must be an integer, got 1.5"),
    (results, "res.txt", "1,2.5,1,2,3,4,1\n", 1, "id must be an integer, got 2.5"),
    (gt, "gt.txt", "1,1,1,2,3,4,1,7.5,1\n", 1, "class must be an integer, got 7.5"),
    (results, "res.txt", "1,1,1e308,2,1.7e308,4,1\n", 1, OVERFLOW),
    (results, "res.txt", "1,1,1,1e20,3,1e-20,1\n", 1, OVERFLOW),
    (gt, "gt.txt", "1,1,1,2,3,4,1,1,nan\n", 1, "visibility must be a finite number, got nan"),
    # --- MOTChallenge: order (online input only; results may be sorted by id, as gt files are)
    (
        det,
        "det.txt",
        "1,-1,1,2,3,4,0.5\n\n2,-1,1,2,3,4,0.5\n1,-1,1,2,3,4,0.5\n",
        4,
        "frame 1 comes after frame 2: lines must be sorted by frame",
    ),
    # --- KITTI labels / results
    (
        read_kitti_labels,
        "0000.txt",
        LABEL + LABEL.replace("Car", "Bus") + LABEL.replace("Car", "Ape"),
        2,
        "unknown object type 'Bus' (KITTI types: Car, Van, Truck, Pedestrian, Person, Cyclist, "
        "Tram, Misc, DontCare)",
    ),
    (
        read_kitti_labels,
        "0000.txt",
        LABEL + "0 2 Car 0 0 -1.5 10 20 40 60 1.5 1.6 3.9 1 2 20\n",
        2,
        "expected 17 space-separated fields, got 16",
    ),
    (
        read_kitti_labels,
        "0000.txt",
        "0,1,2\n",
        1,
        "expected 17 or 18 space-separated fields, got 1",
    ),
    (
        read_kitti_labels,
        "0000.txt",
        LABEL.replace(" 10 20 40", " 10 abc 40"),
        1,
        "field 8 (y1) is not a number: 'abc'",
    ),
    (
        read_kitti_labels,
        "0000.txt",
        LABEL.replace(" 10 20 40", " 50 20 40"),
        1,
        "box width and height must be positive, got width -10 and height 40",
    ),
    (
        read_kitti_labels,
        "0000.txt",
        LABEL.replace("Car 0 0", "Car 0 0.5"),
        1,
        "occluded must be an integer, got 0.5",
    ),
    (read_kitti_labels, "0000.txt", "-1" + LABEL[1:], 1, "frame must be >= 0, got -1"),
    (
        read_kitti_labels,
        "0000.txt",
        LABEL.replace(" -1.6\n", " inf\n"),
        1,
        "rotation_y must be a finite number, got inf",
    ),
    # --- KITTI detections
    (
        read_kitti_detections,
        "car/0000.txt",
        RRC + "1,1,2,3,4,0.5,7\n",
        2,
        "expected 6 comma-separated fields, got 7",
    ),
    (
        read_kitti_detections,
        "car/0000.txt",
        "1,2,3\n",
        1,
        "expected 6 or 15 comma-separated fields, got 3",
    ),
    (
        read_kitti_detections,
        "car/0000.txt",
        "3,1,2,3,4,0.5\n" + RRC,
        2,
        "frame 0 comes after frame 3: lines must be sorted by frame",
    ),
    (
        read_kitti_detections,
        "car/0000.txt",
        RRC + "1,10,20,5,60,0.9\n",
        2,
        "box width and height must be positive, got width -5 and height 40",
    ),
    (
        read_kitti_detections,
        "car/0000.txt",
        RRC + "1,10,20,40,60,nan\n",
        2,
        "score must be a finite number, got nan",
    ),
    (
        read_kitti_detections,
        "x/0000.txt",
        PRCNN + PRCNN.replace("0,2,", "0,4,", 1),
        2,
        "unknown PointRCNN type 4 (expected 1 pedestrian, 2 car or 3 cyclist)",
    ),
    (
        read_kitti_detections,
        "x/0000.txt",
        PRCNN + PRCNN.replace(",1.5,1.6,", ",1.5,nan,", 1),
        2,
        "width must be a finite number, got nan",
    ),
    (
        read_kitti_detections,
        "seq/0000.txt",
        RRC,
        None,
        "cannot tell the class of these RRC detections: folder 'seq' is not a class name; "
        "pass class_name (e.g. --class car)",
    ),
    (
        kitti,
        "0000.txt",
        "\n1,2,3,4\n",
        2,
        "cannot tell the KITTI file kind: expected 17 or 18 space-separated fields "
        "(labels or tracking results), 6 comma-separated (RRC detections) or 15 comma-separated "
        "(PointRCNN detections), "
        "got 4 comma-separated",
    ),
    (
        kitti,
        "0000.txt",
        "1 2 3\n",
        1,
        "cannot tell the KITTI file kind: expected 17 or 18 space-separated fields "
        "(labels or tracking results), 6 comma-separated (RRC detections) or 15 comma-separated "
        "(PointRCNN detections), "
        "got 3 space-separated",
    ),
    # --- empty input
    (det, "det.txt", "", None, "no detections in file"),
    (det, "det.txt", "\n \n\n", None, "no detections in file"),
    (partial(read_detections, fmt="mot"), "det.txt", "", None, "no detections in file"),
    # --- seqinfo
    (
        read_seqinfo,
        "seqinfo.ini",
        "[Sequence]\nname=a\nimWidth=1\nimHeight=1\nframeRate=30\n",
        None,
        "missing key 'seqLength' in [Sequence]",
    ),
    (
        read_seqinfo,
        "seqinfo.ini",
        "[Sequence]\nseqLength=5\nimWidth=wide\nimHeight=1\nframeRate=30\n",
        None,
        "imWidth must be an integer, got 'wide'",
    ),
    (
        read_seqinfo,
        "seqinfo.ini",
        "[Sequence]\nseqLength=0\nimWidth=1\nimHeight=1\nframeRate=30\n",
        None,
        "seqLength must be positive, got '0'",
    ),
    (read_seqinfo, "seqinfo.ini", "name=a\n", 1, "expected a section header such as [Sequence]"),
    (read_seqinfo, "seqinfo.ini", "[Other]\nname=a\n", None, "no [Sequence] section"),
    (
        read_kitti_seqinfo,
        "seqinfo.csv",
        "seq,frames\n0000,1\n",
        1,
        "header must name columns seq, num_frames, im_width, im_height, frame_rate; "
        "missing num_frames, im_width, im_height, frame_rate",
    ),
    (
        read_kitti_seqinfo,
        "seqinfo.csv",
        "seq,num_frames,im_width,im_height,frame_rate\n0000,1,2,3,4\n0001,x,2,3,4\n",
        3,
        "num_frames must be an integer, got 'x'",
    ),
    (
        read_kitti_seqinfo,
        "seqinfo.csv",
        "seq,num_frames,im_width,im_height,frame_rate\n0000,1,2,3,4\n0000,1,2,3,4\n",
        3,
        "sequence '0000' listed twice",
    ),
]


@pytest.mark.parametrize(("reader", "name", "content", "line", "problem"), CASES)
def test_bad_input_names_file_line_and_problem(
    tmp_path: Path, reader: Callable, name: str, content: str, line: int | None, problem: str
) -> None:
    path = tmp_path / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(content, encoding="utf-8")
    with pytest.raises(InputError) as info:
        reader(path)
    err = info.value
    assert (err.path, err.line, err.problem) == (str(path), line, problem)
    assert str(err) == (f"{path}:{line}: {problem}" if line else f"{path}: {problem}")
    assert isinstance(err, ValueError)


READERS = [
    det,
    gt,
    results,
    read_kitti_labels,
    read_kitti_detections,
    kitti,
    partial(read_detections, fmt="mot"),
    read_seqinfo,
    read_kitti_seqinfo,
]


@pytest.mark.parametrize("reader", READERS)
def test_missing_file(tmp_path: Path, reader: Callable) -> None:
    path = tmp_path / "nope" / "missing.txt"
    with pytest.raises(InputError) as info:
        reader(path)
    assert (info.value.path, info.value.line, str(info.value)) == (
        str(path),
        None,
        f"{path}: no such file",
    )


@pytest.mark.parametrize("reader", [det, read_kitti_labels, kitti])
def test_directory_and_binary_file(tmp_path: Path, reader: Callable) -> None:
    with pytest.raises(InputError, match="is a directory, expected a file"):
        reader(tmp_path)
    binary = tmp_path / "det.txt"
    binary.write_bytes(b"1,-1,\xff\xfe,2,3,4,0.5\n")
    with pytest.raises(InputError, match="not a UTF-8 text file") as info:
        reader(binary)
    assert info.value.path == str(binary)


def test_unknown_class_name(tmp_path: Path) -> None:
    path = tmp_path / "0000.txt"
    path.write_text(RRC)
    with pytest.raises(
        InputError, match=r"unknown class name 'bus' \(known: bicycle, car, "
    ) as info:
        read_kitti_detections(path, class_name="bus")
    assert info.value.path == str(path)
    det_path = tmp_path / "det.txt"
    det_path.write_text(DET)
    with pytest.raises(InputError, match="unknown class name 'lorry'"):
        read_detections(det_path, "mot", class_name="lorry")


def test_unknown_format_and_kind_are_programming_errors(tmp_path: Path) -> None:
    path = tmp_path / "det.txt"
    path.write_text(DET)
    with pytest.raises(ValueError, match="unknown format 'csv'"):
        read_detections(path, "csv")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="unknown MOT file kind 'dets'"):
        read_mot(path, kind="dets")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="unknown format"):
        write_results(path, Detections.empty(), "txt")  # type: ignore[arg-type]


def test_error_reports_the_first_bad_line_of_many(tmp_path: Path) -> None:
    # the numpy fast path fails somewhere; the line-by-line pass names the first bad line
    lines = [f"{1 + i // 10},-1,{i},{i},5,5,0.5,-1,-1,-1" for i in range(5000)]
    lines[3210] = lines[3210].replace(",0.5,", ",0.5x,")
    lines[4000] = lines[4000].replace(",5,5,", ",five,5,")
    path = tmp_path / "det.txt"
    path.write_text("\n".join(lines) + "\n\n")
    with pytest.raises(InputError) as info:
        read_mot(path)
    assert (info.value.line, info.value.problem) == (
        3211,
        "field 7 (confidence) is not a number: '0.5x'",
    )
