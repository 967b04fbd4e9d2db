"""`sensemaking track` with situations a user configures: --lanes, --segmentation, --profile."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA

from sensemaking.cli import main
from sensemaking.settings import ParameterError, document_params, preset_profile

LANES = {"lanes": [{"id": 1, "points": [[620, 150], [620, 375]], "width": 300}]}


def parked_car_det(tmp_path: Path, n: int = 40) -> Path:
    """A MOT det.txt: one car standing still in the middle of the road for n frames."""
    det = tmp_path / "det.txt"
    det.write_text("".join(f"{f},-1,560,230,140,80,0.95,-1,-1,-1\n" for f in range(1, n + 1)))
    return det


def track(tmp_path: Path, det: Path, *extra: str) -> int:
    return main(
        [
            "track",
            "--detections",
            str(det),
            "--format",
            "mot",
            "--fps",
            "10",
            "--image-size",
            "1242x375",
            "--output",
            str(tmp_path / "res.txt"),
            *extra,
        ]
    )


def records(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_blocked_lane_fires_through_track_lanes(tmp_path: Path):
    det, lanes, warnings = parked_car_det(tmp_path), tmp_path / "lanes.json", tmp_path / "w.jsonl"
    lanes.write_text(json.dumps(LANES))
    assert track(tmp_path, det, "--warnings", str(warnings), "--lanes", str(lanes)) == 0
    blocked = [r for r in records(warnings) if r["situation"] == "BLOCKED_LANE"]
    assert [r["record"] for r in blocked] == ["start", "end"]  # one episode, held to the end
    start, end = blocked
    assert start["details"]["lane"] == 1 and start["objects"] == end["objects"]
    assert end["reason"] == "end_of_input" and end["last_frame"] == 40
    assert start["severity"] in (1, 2, 3) and start["lane_position"] == "unknown"  # MOT: fixed
    # with a driving camera the car stands on the ego lane
    warnings.unlink()
    assert (
        track(
            tmp_path,
            det,
            "--warnings",
            str(warnings),
            "--lanes",
            str(lanes),
            "--profile",
            "driving",
        )
        == 0
    )
    start = next(r for r in records(warnings) if r["situation"] == "BLOCKED_LANE")
    assert start["lane_position"] == "ego" and start["severity"] == 3


def test_without_lanes_blocked_lane_is_a_notice_not_a_record(tmp_path: Path):
    det, warnings = parked_car_det(tmp_path), tmp_path / "w.jsonl"
    assert track(tmp_path, det, "--warnings", str(warnings)) == 0
    assert all(r["situation"] != "BLOCKED_LANE" for r in records(warnings))


def test_segmentation_beside_the_road_blocks_no_lane(tmp_path: Path):
    det, lanes, warnings = parked_car_det(tmp_path), tmp_path / "lanes.json", tmp_path / "w.jsonl"
    lanes.write_text(json.dumps(LANES))
    seg = tmp_path / "seg.npy"
    np.save(seg, np.full((375, 1242), 1, dtype=np.int64))  # Cityscapes 1: sidewalk everywhere
    assert (
        track(
            tmp_path,
            det,
            "--warnings",
            str(warnings),
            "--lanes",
            str(lanes),
            "--segmentation",
            str(seg),
        )
        == 0
    )
    assert all(r["situation"] != "BLOCKED_LANE" for r in records(warnings))
    np.save(seg, np.zeros((375, 1242), dtype=np.int64))  # 0: road
    warnings.unlink()
    assert (
        track(
            tmp_path,
            det,
            "--warnings",
            str(warnings),
            "--lanes",
            str(lanes),
            "--segmentation",
            str(seg),
        )
        == 0
    )
    assert any(r["situation"] == "BLOCKED_LANE" for r in records(warnings))


@pytest.mark.parametrize(
    "content, problem",
    [
        ("{not json", "not valid JSON"),
        ('{"lanes": [{"id": 1, "points": [[0, 0], [1, 1]]}]}', "needs 'width'"),
        ('{"lanes": [{"id": 1.5, "points": [[0, 0], [1, 1]], "width": 3}]}', "'id'"),
        ("[]", "must be an object"),
        (None, "cannot read lanes file"),  # a directory
        (b"\xff\xfe", "not UTF-8"),
    ],
)
def test_bad_lanes_file_is_one_line_and_exit_2(tmp_path: Path, capsys, content, problem):
    det = parked_car_det(tmp_path)
    lanes = tmp_path / "lanes.json"
    if content is None:
        lanes.mkdir()
    elif isinstance(content, bytes):
        lanes.write_bytes(content)
    else:
        lanes.write_text(content)
    out = tmp_path / "out"
    code = main(
        [
            "track",
            "--detections",
            str(det),
            "--format",
            "mot",
            "--output",
            str(out / "res.txt"),
            "--warnings",
            str(out / "w.jsonl"),
            "--lanes",
            str(lanes),
        ]
    )
    err = capsys.readouterr().err.strip()
    assert code == 2
    assert len(err.splitlines()) == 1 and str(lanes) in err and problem in err
    assert not out.exists() or list(out.iterdir()) == []


def test_context_options_need_warnings(tmp_path: Path, capsys):
    det, lanes = parked_car_det(tmp_path), tmp_path / "lanes.json"
    lanes.write_text(json.dumps(LANES))
    assert track(tmp_path, det, "--lanes", str(lanes)) == 2
    assert "--lanes needs --warnings" in capsys.readouterr().err
    assert track(tmp_path, det, "--profile", "fixed") == 2
    assert "--profile needs --warnings" in capsys.readouterr().err


def test_presets_name_their_profile():
    assert preset_profile("kitti") == "driving" and preset_profile("mot") == "fixed"
    with pytest.raises(ParameterError, match="profile"):
        document_params(
            {"format": "sensemaking-params/1", "profile": "flying", "params": {}}, "x.json"
        )


MOT17_02 = SHARED_DATA / "mot17" / "MOT17-02-YOLOX-half" / "det" / "det.txt"


@pytest.mark.slow
@pytest.mark.skipif(not MOT17_02.exists(), reason="needs ../shared/data (MOT17-02)")
def test_mot17_fixed_camera_gives_no_ego_vehicle_warnings(tmp_path: Path):
    warnings, events = tmp_path / "w.jsonl", tmp_path / "ev.jsonl"
    code = main(
        [
            "--quiet",
            "track",
            "--detections",
            str(MOT17_02),
            "--format",
            "mot",
            "--output",
            str(tmp_path / "res.txt"),
            "--events",
            str(events),
            "--warnings",
            str(warnings),
        ]
    )
    assert code == 0
    hides = [r for r in records(events) if r["event"] == "hides_behind"]
    assert len(hides) > 20  # people do hide: with an ego vehicle this would warn
    said = {r["situation"] for r in records(warnings)}
    assert said & {"HIDDEN_ENTITY", "REDUCED_VISIBILITY", "SUDDEN_STOP"} == set()


def test_preset_profile_without_ego_vehicle_says_so_once(tmp_path: Path, caplog):
    det, warnings = parked_car_det(tmp_path), tmp_path / "w.jsonl"
    with caplog.at_level("WARNING"):
        assert track(tmp_path, det, "--warnings", str(warnings)) == 0
    said = [r.getMessage() for r in caplog.records if "--profile driving" in r.getMessage()]
    assert len(said) == 1 and "HIDDEN_ENTITY" in said[0] and "fixed" in said[0]
    # the user chose the profile: nothing to point out
    caplog.clear()
    warnings.unlink()
    with caplog.at_level("WARNING"):
        assert track(tmp_path, det, "--warnings", str(warnings), "--profile", "fixed") == 0
        assert (
            track(tmp_path, det, "--warnings", str(tmp_path / "w2.jsonl"), "--profile", "driving")
            == 0
        )
    assert not [r for r in caplog.records if "--profile driving" in r.getMessage()]
