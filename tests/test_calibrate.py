"""`sensemaking calibrate`: parameters estimated from annotated sequences, written for --params."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA

from sensemaking import settings
from sensemaking.calibrate import CalibrationSequence, calibrate
from sensemaking.cli import main
from sensemaking.detections import Detections
from sensemaking.errors import InputError

SIZE = (640, 480)


def _scene() -> CalibrationSequence:
    """Two objects over 30 frames at 10 fps: A enters at the left border on frame 3, B appears in
    the middle on frame 5; A's detections miss frames 10-12; one-frame false detections score
    0.3."""
    rng = np.random.default_rng(0)
    gt_rows, det_rows = [], []
    for f in range(30):
        if f >= 3:
            box = [0 + 2 * (f - 3), 100, 60 + 2 * (f - 3), 200]
            gt_rows.append((f, 1, box))
            if f not in (10, 11, 12):
                det_rows.append((f, box, 0.9))
        if f >= 5:
            box = [300, 200, 350, 300]
            gt_rows.append((f, 2, box))
            det_rows.append((f, box, 0.95))
        if f % 2 == 0:
            x = float(rng.uniform(400, 550))
            det_rows.append((f, [x, 20, x + 30, 60], 0.3))
    gt = Detections(
        xyxy=np.array([r[2] for r in gt_rows], float),
        frame=[r[0] for r in gt_rows],
        tracker_id=[r[1] for r in gt_rows],
        class_id=1,
    )
    dets = Detections(
        xyxy=np.array([r[1] for r in det_rows], float),
        frame=[r[0] for r in det_rows],
        confidence=[r[2] for r in det_rows],
        class_id=1,
    )
    return CalibrationSequence(
        "synthetic", gt, dets, first_frame=0, n_frames=30, fps=10.0, image_size=SIZE
    )


def test_estimates_follow_what_is_seen() -> None:
    result = calibrate([_scene()])
    p = result.params
    assert 0.3 < p["start_confidence"] <= 0.9  # true detections score 0.9+, false ones 0.3
    assert p["min_confidence"] <= p["start_confidence"]
    assert p["confirm_confidence"] is not None and p["confirm_confidence"] <= 0.9
    assert p["min_hits"] == 1  # false detections never repeat
    assert p["max_missing_s"] == pytest.approx(0.3)  # a 3-frame gap at 10 fps
    # one of two objects began at the border: -100 ln((1 + 1) / (2 + 2)) each way (add-one)
    assert p["costs.enters"] == p["costs.appears"] == round(100 * math.log(2))
    # neither object ends before the last frame: no leave / lost evidence, the preset stays
    assert "costs.leaves" not in p and "costs.lost" not in p
    assert result.stats["true"] == 24 + 25 and result.stats["false"] == 15
    assert "2 annotated objects" in result.source()
    for key, value in p.items():
        settings.check_value(key, value)


def test_repeating_false_detections_raise_min_hits() -> None:
    seq = _scene()
    d = seq.detections
    ghost = Detections(
        xyxy=np.tile([[500.0, 300, 540, 360]], (30, 1)),
        frame=np.arange(30),
        confidence=np.full(30, 0.95),
        class_id=1,
    )  # a false box that never leaves
    many = [
        Detections(
            xyxy=np.array([[10.0 + 40 * k, 400, 40 + 40 * k, 440]] * 2),
            frame=[2 * k, 2 * k + 1],
            confidence=[0.95, 0.95],
            class_id=1,
        )
        for k in range(5)
    ]  # two-frame ghosts
    merged = Detections.concatenate([d, ghost, *many])
    order = np.argsort(merged.frame, kind="stable")
    result = calibrate([CalibrationSequence("ghosts", seq.gt, merged[order], 0, 30, 10.0, SIZE)])
    assert result.params["min_hits"] >= 3


def test_bad_input_is_an_error() -> None:
    seq = _scene()
    with pytest.raises(InputError, match="no annotated sequence"):
        calibrate([])
    with pytest.raises(InputError, match="no ground truth"):
        calibrate([CalibrationSequence("x", seq.gt[:0], seq.detections, 0, 30, 10.0, SIZE)])
    late = seq.detections.with_(frame=seq.detections.frame + 100)
    with pytest.raises(InputError, match="outside the sequence's frames 0..29"):
        calibrate([CalibrationSequence("x", seq.gt, late, 0, 30, 10.0, SIZE)])
    shifted = seq.detections.with_(xyxy=seq.detections.xyxy + 1000)
    with pytest.raises(InputError, match="no detection matches the ground truth"):
        calibrate([CalibrationSequence("x", seq.gt, shifted, 0, 30, 10.0, SIZE)])


needs_data = pytest.mark.skipif(
    not (SHARED_DATA / "kitti").is_dir(), reason="needs ../shared/data"
)


@pytest.mark.integration
@needs_data
def test_calibrate_then_track_round_trip(tmp_path: Path, capsys) -> None:
    labels, dets = (
        SHARED_DATA / "kitti" / "training" / "label_02",
        SHARED_DATA / "kitti" / "detections" / "rrc" / "car",
    )
    params = tmp_path / "car.json"
    assert (
        main(
            [
                "-q",
                "calibrate",
                "--format",
                "kitti",
                "--class",
                "car",
                "--gt",
                str(labels / "0001.txt"),
                "--detections",
                str(dets / "0001.txt"),
                "--gt",
                str(labels / "0004.txt"),
                "--detections",
                str(dets / "0004.txt"),
                "--output",
                str(params),
            ]
        )
        == 0
    )
    values = settings.load_params(params)
    assert {"start_confidence", "min_confidence", "min_hits", "costs.enters"} <= set(values)
    config = settings.load_config(params)
    assert (
        config.start_confidence == values["start_confidence"] and config.fps == 10.0
    )  # kitti base
    out = tmp_path / "0002.txt"
    assert (
        main(
            [
                "-q",
                "track",
                "--detections",
                str(dets / "0002.txt"),
                "--format",
                "kitti",
                "--class",
                "car",
                "--params",
                str(params),
                "--output",
                str(out),
            ]
        )
        == 0
    )
    assert out.stat().st_size > 0


@pytest.mark.integration
@needs_data
@pytest.mark.parametrize(
    "make_args, message",
    [
        (
            lambda d, t: [
                "--format",
                "kitti",
                "--gt",
                str(d / "kitti/training/label_02/0001.txt"),
                "--detections",
                str(d / "kitti/detections/rrc/car/0001.txt"),
            ],
            "--class is required",
        ),
        (
            lambda d, t: [
                "--format",
                "kitti",
                "--class",
                "car",
                "--gt",
                str(t / "empty.txt"),
                "--detections",
                str(d / "kitti/detections/rrc/car/0001.txt"),
            ],
            "no ground truth of class car",
        ),
        (
            lambda d, t: [
                "--format",
                "kitti",
                "--class",
                "car",
                "--gt",
                str(d / "kitti/training/label_02/0001.txt"),
                "--detections",
                str(d / "kitti/detections/rrc/car/0007.txt"),
            ],
            "ground truth ends at frame 446",
        ),
        (
            lambda d, t: [
                "--format",
                "kitti",
                "--class",
                "car",
                "--gt",
                str(t / "missing.txt"),
                "--detections",
                str(d / "kitti/detections/rrc/car/0001.txt"),
            ],
            "ground-truth file not found",
        ),
        (
            lambda d, t: [
                "--format",
                "kitti",
                "--class",
                "car",
                "--gt",
                str(d / "kitti/training/label_02/0001.txt"),
                "--detections",
                str(d / "kitti/detections/rrc/car/0001.txt"),
                "--gt",
                str(d / "kitti/training/label_02/0004.txt"),
            ],
            "once per sequence",
        ),
    ],
)
def test_cli_errors_are_one_line(tmp_path: Path, capsys, make_args, message: str) -> None:
    (tmp_path / "empty.txt").write_text(
        "0 -1 DontCare -1 -1 -10 1 2 3 4 -1 -1 -1 -1000 -1000 -1000 -10\n"
    )
    out = tmp_path / "p.json"
    assert main(["calibrate", *make_args(SHARED_DATA, tmp_path), "--output", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not out.exists()


def test_a_video_without_the_class_still_counts_its_false_detections() -> None:
    seq = _scene()
    empty = CalibrationSequence(
        "no-objects",
        seq.gt[:0],
        seq.detections[seq.detections.confidence < 0.5],
        0,
        30,
        10.0,
        SIZE,
    )
    both = calibrate([seq, empty])
    assert both.stats["false"] == 2 * calibrate([seq]).stats["false"]
    assert both.stats["true"] == calibrate([seq]).stats["true"]


def _shared_sequences() -> list[tuple[str, list[str]]]:
    """(id, calibrate arguments) of every sequence of ../shared/data with ground truth, per
    benchmark: the files as the benchmark runner finds them."""
    if not SHARED_DATA.is_dir():
        return []
    from sensemaking.benchmark import datasets

    out = []
    for spec, sources in datasets.discover(SHARED_DATA).found:
        for src in sources:
            args = ["--gt", str(src.gt_path), "--detections", str(src.det_path)]
            if spec.output_format == "kitti":
                args += ["--format", "kitti", "--class", str(spec.class_name)]
                args += ["--seqinfo", str(src.seqinfo_path)]
            else:
                args += ["--format", "mot"]
            out.append((f"{spec.name}/{src.name}", args))
    return out


SHARED_SEQUENCES = _shared_sequences()


@pytest.mark.integration
@pytest.mark.slow
@pytest.mark.skipif(not SHARED_SEQUENCES, reason="needs ../shared/data")
def test_calibrate_works_on_every_shared_sequence(tmp_path: Path, capsys) -> None:
    """Every sequence with ground truth of the class gives a valid parameter file; one without
    (a KITTI video with no pedestrian) gives the one-line error, and no file."""
    from sensemaking.io.kitti import read_kitti_labels

    benchmarks = {name.split("/")[0] for name, _ in SHARED_SEQUENCES}
    assert len(benchmarks) == 7, benchmarks  # KITTI RRC / PointRCNN x car / pedestrian, MOT
    written = 0
    for k, (name, args) in enumerate(SHARED_SEQUENCES):
        out = tmp_path / f"{k}.json"
        code = main(["-q", "calibrate", *args, "--output", str(out)])
        gt = Path(args[1])
        has_class = True
        if "--class" in args:
            labels = read_kitti_labels(gt)
            cls = args[args.index("--class") + 1]
            from sensemaking.classes import class_id

            has_class = bool(np.any((labels.class_id == class_id(cls)) & (labels.tracker_id >= 0)))
        err = capsys.readouterr().err
        if has_class:
            assert code == 0, (name, err)
            values = settings.load_params(out)
            assert {"start_confidence", "min_confidence", "min_hits"} <= set(values), name
            assert values["min_confidence"] <= values["start_confidence"], name
            written += 1
        else:
            assert code == 2 and "no ground truth of class" in err and err.count("\n") == 1
            assert not out.exists()
    assert written >= len(SHARED_SEQUENCES) - 10


@pytest.mark.integration
@pytest.mark.slow
@pytest.mark.skipif(not SHARED_SEQUENCES, reason="needs ../shared/data")
def test_each_benchmark_round_trips_through_track_params(tmp_path: Path, capsys) -> None:
    """One sequence of each benchmark: calibrate, then `track --params` with the file; the
    tracker's configuration holds the estimated values; the file with a value in the wrong
    unit is refused in one line."""
    seen: set[str] = set()
    for name, args in SHARED_SEQUENCES:
        bench = name.split("/")[0]
        if bench in seen:
            continue
        params = tmp_path / f"{bench}.json"
        if main(["-q", "calibrate", *args, "--output", str(params)]) != 0:
            continue  # a KITTI video without the class: the next one (the test above)
        seen.add(bench)
        values = settings.load_params(params)
        config = settings.load_config(params)
        for key, value in values.items():
            assert settings.params_of(config)[key] == value, (name, key)
        det_args = args[args.index("--detections") : args.index("--detections") + 2]
        fmt = args[args.index("--format") : args.index("--format") + 2]
        cls = args[args.index("--class") : args.index("--class") + 2] if "--class" in args else []
        out = tmp_path / f"{bench}.txt"
        track = ["-q", "track", *det_args, *fmt, *cls, "--params", str(params)]
        assert main([*track, "--output", str(out)]) == 0, name
        assert out.stat().st_size > 0
        # the same file with a count that is not a whole number: one line, exit 2
        doc = json.loads(params.read_text())
        doc["params"]["min_hits"] = 2.5
        bad = tmp_path / f"{bench}-bad.json"
        bad.write_text(json.dumps(doc))
        capsys.readouterr()
        assert main([*track, "--params", str(bad), "--output", str(tmp_path / "x.txt")]) == 2
        err = capsys.readouterr().err
        assert "min_hits must be an integer" in err and err.count("\n") == 1, err
    assert len(seen) == 7
