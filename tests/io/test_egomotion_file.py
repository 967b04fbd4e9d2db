"""The ego-motion file: parsed, interpolated, and every bad row a one-line error."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sensemaking.cli import main
from sensemaking.errors import InputError
from sensemaking.io.egomotion import parse_ego_motion, read_ego_motion


def test_parse_interpolate_and_optional_yaw(tmp_path: Path):
    p = tmp_path / "ego.csv"
    p.write_text("# OXTS vf, wu\nframe,speed_mps,yaw_rate_rad_s\n0,8.0,0.1\n\n10,10.0,-0.1\n")
    ego = read_ego_motion(p)
    assert ego.frames.tolist() == [0, 10] and ego.yaw_rate is not None
    assert ego.at(5) == pytest.approx((9.0, 0.0))
    assert ego.at(-1) is None and ego.at(11) is None
    two = parse_ego_motion("frame,speed_mps\n3,4.5\n4,5.5\n")
    assert two.yaw_rate is None and two.at(4) == (5.5, None)
    assert np.array_equal(two.speed, [4.5, 5.5])


@pytest.mark.parametrize(
    ("text", "line", "problem"),
    [
        ("frame,speed\n0,1\n", 1, "the header must be"),
        ("frame,speed_mps\n0,1\n1\n", 3, "expected 2 comma-separated values"),
        ("frame,speed_mps\n0,abc\n", 2, "speed_mps is not a number"),
        ("frame,speed_mps\n0,-1\n", 2, "speed_mps must be in [0, 150]"),
        ("frame,speed_mps\n0,nan\n", 2, "speed_mps must be finite"),
        ("frame,speed_mps\n0.5,1\n", 2, "frame must be an integer"),
        ("frame,speed_mps\n3,1\n3,2\n", 3, "frames must increase"),
        ("frame,speed_mps,yaw_rate_rad_s\n0,1,99\n", 2, "yaw_rate_rad_s must be within"),
    ],
)
def test_bad_rows_name_file_and_line(tmp_path: Path, text: str, line: int, problem: str):
    p = tmp_path / "ego.csv"
    p.write_text(text)
    with pytest.raises(InputError) as err:
        read_ego_motion(p)
    assert str(err.value).startswith(f"{p}:{line}: {problem}")
    assert "\n" not in str(err.value)


def test_empty_and_missing_files(tmp_path: Path):
    p = tmp_path / "ego.csv"
    p.write_text("")
    with pytest.raises(InputError, match="empty ego-motion file"):
        read_ego_motion(p)
    p.write_text("frame,speed_mps\n")
    with pytest.raises(InputError, match="no rows"):
        read_ego_motion(p)
    with pytest.raises(InputError, match="no such file"):
        read_ego_motion(tmp_path / "nope.csv")


def _kitti_detections(path: Path) -> Path:
    rows = [f"{f},{500 + f},{200},{600 + f},{260},0.9" for f in range(12)]
    path.write_text("\n".join(rows) + "\n")
    return path


def test_track_ego_motion_bad_row_exits_2_with_one_line(tmp_path: Path, capsys):
    det = _kitti_detections(tmp_path / "0000.txt")
    ego = tmp_path / "ego.csv"
    ego.write_text("frame,speed_mps\n0,8\n1,fast\n")
    out, warn = tmp_path / "out.txt", tmp_path / "warnings.jsonl"
    args = [
        "-q",
        "track",
        "--detections",
        str(det),
        "--format",
        "kitti",
        "--class",
        "car",
        "--output",
        str(out),
        "--warnings",
        str(warn),
        "--ego-motion",
        str(ego),
    ]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{ego}:3: speed_mps is not a number" in err[0]
    assert not out.exists() and not warn.exists()
    ego.write_text("frame,speed_mps\n0,8\n11,8\n")
    assert main(args) == 0 and out.exists() and warn.exists()
    # an ego-motion file without a camera model (MOT format, no --camera) is refused
    mot = tmp_path / "det.txt"
    mot.write_text("".join(f"{f + 1},-1,500,200,100,60,0.9,-1,-1,-1\n" for f in range(5)))
    bad = [
        "-q",
        "track",
        "--detections",
        str(mot),
        "--format",
        "mot",
        "--output",
        str(tmp_path / "o.txt"),
        "--warnings",
        str(tmp_path / "w.jsonl"),
        "--ego-motion",
        str(ego),
        "--image-size",
        "1242x375",
        "--fps",
        "10",
    ]
    assert main(bad) == 2
    assert "needs a camera model" in capsys.readouterr().err
