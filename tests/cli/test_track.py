"""The `track` and `demo` verbs end to end: outputs, formats, and bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA

from sensemaking.cli import main
from sensemaking.io.kitti import read_kitti_labels
from sensemaking.io.mot import read_mot
from sensemaking.synthetic import crossing_scene


def write_mot_det(path: Path, scene) -> None:
    """A MOT det.txt (1-based frames, x,y,w,h) of a synthetic scene's detections."""
    d = scene.detections
    order = np.argsort(d.frame, kind="stable")
    lines = [
        f"{d.frame[i] + 1},-1,{x:.2f},{y:.2f},{w:.2f},{h:.2f},{d.confidence[i]:.3f},-1,-1,-1"
        for i, (x, y, w, h) in zip(order, d.xywh[order], strict=False)
    ]
    path.write_text("\n".join(lines) + "\n")


@pytest.fixture()
def crossing_det(tmp_path: Path) -> Path:
    seq = tmp_path / "CROSS-01"
    (seq / "det").mkdir(parents=True)
    scene = crossing_scene(0, gap=12, far_speed=8.0)
    write_mot_det(seq / "det" / "det.txt", scene)
    (seq / "seqinfo.ini").write_text(
        f"[Sequence]\nname=CROSS-01\nframeRate=10\nseqLength={scene.n_frames}\n"
        "imWidth=1242\nimHeight=375\n"
    )
    return seq / "det" / "det.txt"


def test_track_mot_writes_results_events_and_scene(
    tmp_path: Path, crossing_det: Path, capsys
) -> None:
    out, events, scene = tmp_path / "res.txt", tmp_path / "ev.jsonl", tmp_path / "scene.json"
    code = main(
        [
            "track",
            "--detections",
            str(crossing_det),
            "--format",
            "mot",
            "--output",
            str(out),
            "--events",
            str(events),
            "--scene",
            str(scene),
        ]
    )
    assert code == 0
    res = read_mot(out, kind="results")
    assert len(res) > 0 and res.frame.min() >= 1
    # visible tracks are written with their detection's box: each one is an input box
    det = read_mot(crossing_det, kind="det")
    inputs = {(int(f), tuple(np.round(b, 2))) for f, b in zip(det.frame, det.xyxy, strict=False)}
    assert all(
        (int(f), tuple(np.round(b, 2))) in inputs
        for f, b in zip(res.frame, res.xyxy, strict=False)
    )
    records = [json.loads(line) for line in events.read_text().splitlines()]
    assert {"frame", "event", "args"} <= set(records[0])
    names = [r["event"] for r in records]
    assert "hides_behind" in names and "unhides_from_behind" in names
    hid = next(r for r in records if r["event"] == "hides_behind")["args"][0]
    unhid = next(r for r in records if r["event"] == "unhides_from_behind")["args"][0]
    assert hid == unhid  # the same identity before and after the occlusion
    assert len(np.unique(res.tracker_id)) == 2
    assert json.loads(scene.read_text())  # a scene model was written


def test_no_abduction_loses_the_identity_on_the_same_file(
    tmp_path: Path, crossing_det: Path
) -> None:
    out = tmp_path / "res.txt"
    events = tmp_path / "ev.jsonl"
    assert (
        main(
            [
                "track",
                "--detections",
                str(crossing_det),
                "--format",
                "mot",
                "--output",
                str(out),
                "--events",
                str(events),
                "--no-abduction",
            ]
        )
        == 0
    )
    res = read_mot(out, kind="results")
    assert len(np.unique(res.tracker_id)) == 3  # a new id after the 12-frame occlusion
    names = {json.loads(line)["event"] for line in events.read_text().splitlines()}
    assert not names & {"hides_behind", "unhides_from_behind", "enters_fov", "leaves_fov"}


def test_write_hidden_adds_predicted_boxes(tmp_path: Path, crossing_det: Path) -> None:
    a, b = tmp_path / "a.txt", tmp_path / "b.txt"
    main(["-q", "track", "--detections", str(crossing_det), "--format", "mot", "--output", str(a)])
    main(
        [
            "-q",
            "track",
            "--detections",
            str(crossing_det),
            "--format",
            "mot",
            "--output",
            str(b),
            "--write-hidden",
        ]
    )
    assert len(read_mot(b, kind="results")) > len(read_mot(a, kind="results"))


@pytest.mark.parametrize(
    ("content", "line", "problem"),
    [
        ("1,-1,10,10,20,20,0.9\n2,-1,10,10,abc,20,0.9\n", 2, "w"),
        ("1,-1,10,10,20,20,0.9\n2,-1,10,nan,20,20,0.9\n", 2, "finite"),
        ("1,-1,10,10,20,20,0.9\n2,-1,10,10,-5,20,0.9\n", 2, "width"),
        ("2,-1,10,10,20,20,0.9\n1,-1,10,10,20,20,0.9\n", 2, "sorted by frame"),
    ],
)
def test_bad_input_names_file_line_and_leaves_no_output(
    tmp_path: Path, capsys, content, line, problem
) -> None:
    det = tmp_path / "det.txt"
    det.write_text(content)
    out, events = tmp_path / "out" / "res.txt", tmp_path / "out" / "ev.jsonl"
    code = main(
        [
            "track",
            "--detections",
            str(det),
            "--format",
            "mot",
            "--output",
            str(out),
            "--events",
            str(events),
        ]
    )
    err = capsys.readouterr().err
    assert code == 2
    assert (f"{det}:{line}:" if line else f"{det}:") in err
    assert problem in err
    assert not out.exists() and not events.exists()
    leftovers = list((tmp_path / "out").glob("*")) if (tmp_path / "out").exists() else []
    assert leftovers == []


def test_unknown_parameter_is_a_clear_error(tmp_path: Path, crossing_det: Path, capsys) -> None:
    code = main(
        [
            "track",
            "--detections",
            str(crossing_det),
            "--format",
            "mot",
            "--output",
            str(tmp_path / "r.txt"),
            "--set",
            "max_hiden_s=2",
        ]
    )
    assert code == 2
    assert "max_hiden_s" in capsys.readouterr().err


def test_seconds_not_frames(tmp_path: Path, crossing_det: Path) -> None:
    """Halving max_hidden_s below the occlusion length loses the track; the gap is 12 frames
    at 10 fps."""
    out = tmp_path / "r.txt"
    main(
        [
            "-q",
            "track",
            "--detections",
            str(crossing_det),
            "--format",
            "mot",
            "--output",
            str(out),
            "--set",
            "max_hidden_s=0.5",
        ]
    )
    assert len(np.unique(read_mot(out, kind="results").tracker_id)) == 3


def test_demo_hides_and_unhides_the_cyclist_with_the_same_id(tmp_path: Path) -> None:
    from sensemaking.classes import CLASS_IDS
    from sensemaking.demo import run_demo

    lines: list[str] = []
    result = run_demo(tmp_path, render=False, echo=lines.append)
    hides = [e for e in result.events if e.name == "hides_behind"]
    unhides = [e for e in result.events if e.name == "unhides_from_behind"]
    assert hides and unhides
    cyclist = hides[0].args[0]
    assert unhides[0].args == hides[0].args and unhides[0].frame > hides[0].frame
    classes = {
        int(t): int(c)
        for r in result.results
        for t, c in zip(r.tracks.tracker_id, r.tracks.class_id, strict=False)
    }
    assert (
        classes[cyclist] == CLASS_IDS["cyclist"] and classes[hides[0].args[1]] == CLASS_IDS["car"]
    )
    hidden_frames = [
        r.frame
        for r in result.results
        if r.state_of(cyclist) is not None and r.state_of(cyclist).name == "HIDDEN"
    ]
    assert hidden_frames == list(range(hides[0].frame, unhides[0].frame))
    assert any("hides behind car" in s for s in result.sentences)
    assert any(w.situation == "HIDDEN_ENTITY" and cyclist in w.objects for w in result.warnings)
    tracks = read_kitti_labels(result.files["tracks"])
    assert set(np.unique(tracks.tracker_id)) == set(classes)
    for name in ("events", "warnings", "scene", "detections"):
        assert result.files[name].exists()


@pytest.mark.integration
@pytest.mark.skipif(not SHARED_DATA.exists(), reason="../shared/data not present")
def test_track_kitti_rrc_sequence(tmp_path: Path) -> None:
    det = SHARED_DATA / "kitti" / "detections" / "rrc" / "car" / "0000.txt"
    out = tmp_path / "0000.txt"
    assert (
        main(
            [
                "-q",
                "track",
                "--detections",
                str(det),
                "--format",
                "kitti",
                "--output",
                str(out),
                "--events",
                str(tmp_path / "ev.jsonl"),
            ]
        )
        == 0
    )
    res = read_kitti_labels(out)
    assert len(res) > 100
    assert set(res.class_id.tolist()) == {3}  # car, from the folder name
    assert res.frame.max() <= 153
