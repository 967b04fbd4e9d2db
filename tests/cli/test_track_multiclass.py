"""`track` of several classes at once: class files of one sequence tracked jointly, so that a
cyclist can hide behind a car; results written per class in the benchmark's layout."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA

from sensemaking.classes import CLASS_IDS
from sensemaking.cli import main
from sensemaking.io.kitti import read_kitti_labels
from sensemaking.synthetic import crossing_scene

CAR, CYCLIST, PEDESTRIAN = CLASS_IDS["car"], CLASS_IDS["cyclist"], CLASS_IDS["pedestrian"]


def write_rrc(path: Path, dets) -> None:
    """KITTI RRC detections ``frame,x1,y1,x2,y2,score`` (the class is the folder's name)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    order = np.argsort(dets.frame, kind="stable")
    path.write_text(
        "".join(
            f"{dets.frame[i]},{x1:.2f},{y1:.2f},{x2:.2f},{y2:.2f},{dets.confidence[i]:.3f}\n"
            for i, (x1, y1, x2, y2) in zip(order, dets.xyxy[order], strict=False)
        )
    )


@pytest.fixture()
def car_and_cyclist(tmp_path: Path) -> tuple[Path, Path]:
    """A cyclist passing behind a car (its detections missing for 10 frames), as two KITTI RRC
    class files ``car/0042.txt`` and ``cyclist/0042.txt`` of sequence 0042."""
    scene = crossing_scene(3, gap=10, far_speed=6.0, near_class=CAR, far_class=CYCLIST)
    d = scene.detections
    root = tmp_path / "dets"
    write_rrc(root / "car" / "0042.txt", d[d.class_id == CAR])
    write_rrc(root / "cyclist" / "0042.txt", d[d.class_id == CYCLIST])
    (root / "seqinfo.csv").write_text(
        f"seq,num_frames,im_width,im_height,frame_rate\n0042,{scene.n_frames},1242,375,10\n"
    )
    return root / "car" / "0042.txt", root / "cyclist" / "0042.txt"


def events_of(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_joint_run_hides_the_cyclist_behind_the_car(tmp_path: Path, car_and_cyclist) -> None:
    car, cyclist = car_and_cyclist
    out, ev = tmp_path / "joint" / "{class}" / "0042.txt", tmp_path / "joint.jsonl"
    assert (
        main(
            [
                "-q",
                "track",
                "--format",
                "kitti",
                "--detections",
                str(car),
                str(cyclist),
                "--output",
                str(out),
                "--events",
                str(ev),
            ]
        )
        == 0
    )
    cars = read_kitti_labels(tmp_path / "joint" / "car" / "0042.txt")
    cyclists = read_kitti_labels(tmp_path / "joint" / "cyclist" / "0042.txt")
    assert set(cars.class_id.tolist()) == {CAR} and set(cyclists.class_id.tolist()) == {CYCLIST}
    # one shared id space: no id in both files; the cyclist keeps its one id across the car
    assert not set(cars.tracker_id.tolist()) & set(cyclists.tracker_id.tolist())
    assert len(np.unique(cyclists.tracker_id)) == 1
    (cyc_id,), (car_id,) = np.unique(cyclists.tracker_id), np.unique(cars.tracker_id)
    records = events_of(ev)
    hides = [r for r in records if r["event"] == "hides_behind"]
    unhides = [r for r in records if r["event"] == "unhides_from_behind"]
    assert [r["args"] for r in hides] == [[int(cyc_id), int(car_id)]]
    assert [r["args"] for r in unhides] == [[int(cyc_id), int(car_id)]]

    # tracked alone (its own run, as before), the cyclist has nothing to hide behind
    alone = tmp_path / "alone.jsonl"
    assert (
        main(
            [
                "-q",
                "track",
                "--format",
                "kitti",
                "--detections",
                str(cyclist),
                "--output",
                str(tmp_path / "alone.txt"),
                "--events",
                str(alone),
            ]
        )
        == 0
    )
    assert not [r for r in events_of(alone) if r["event"] == "hides_behind"]


def test_per_class_files_are_the_one_file_split_by_class(tmp_path: Path, car_and_cyclist) -> None:
    """The {class} layout writes exactly the lines of the single KITTI results file, each in its
    class's file; `evaluate` scores both the same."""
    car, cyclist = car_and_cyclist
    one = tmp_path / "one" / "0042.txt"
    split = tmp_path / "split" / "{class}" / "0042.txt"
    for out in (one, split):
        assert (
            main(
                [
                    "-q",
                    "track",
                    "--format",
                    "kitti",
                    "--detections",
                    str(car),
                    str(cyclist),
                    "--output",
                    str(out),
                ]
            )
            == 0
        )
    lines = one.read_text().splitlines()
    for name, kitti in (("car", "Car"), ("cyclist", "Cyclist")):
        part = (tmp_path / "split" / name / "0042.txt").read_text().splitlines()
        assert part == [line for line in lines if line.split()[2] == kitti]
        assert part  # both classes were tracked
    assert not (tmp_path / "split" / "pedestrian").exists()


def pointrcnn_lines(dets) -> list[tuple[int, str]]:
    """(frame, PointRCNN line) of each detection: type 1 pedestrian, 2 car, 3 cyclist; the score
    a logit; the depth (z, metres) falls as the box bottom goes down the image, as on a road."""
    code = {PEDESTRIAN: 1, CAR: 2, CYCLIST: 3}
    out = []
    for i, (x1, y1, x2, y2) in enumerate(dets.xyxy):
        p = min(float(dets.confidence[i]), 0.999)
        logit = np.log(p / (1 - p))
        out.append(
            (
                int(dets.frame[i]),
                f"{dets.frame[i]},{code[int(dets.class_id[i])]},{x1:.2f},"
                f"{y1:.2f},{x2:.2f},{y2:.2f},{logit:.4f},1.5,0.6,1.7,2.0,1.6,"
                f"{4000 / y2:.2f},0.1,0.2\n",
            )
        )
    return out


def test_one_multiclass_file_is_the_class_files_together(tmp_path: Path) -> None:
    """A PointRCNN file with every class (its type column) tracks as the class files do."""
    scene = crossing_scene(3, gap=10, far_speed=6.0, near_class=CAR, far_class=CYCLIST)
    d = scene.detections
    d = d[np.lexsort((d.class_id, d.frame))]  # by frame, cars (3) before cyclists (16)
    root = tmp_path / "pointrcnn"
    for c in ("car", "cyclist", "all"):
        (root / c).mkdir(parents=True)
    lines = pointrcnn_lines(d)
    (root / "all" / "0042.txt").write_text("".join(line for _, line in lines))
    for c, cid in (("car", CAR), ("cyclist", CYCLIST)):
        (root / c / "0042.txt").write_text(
            "".join(line for (_, line), k in zip(lines, d.class_id, strict=True) if k == cid)
        )
    (root / "seqinfo.csv").write_text(
        f"seq,num_frames,im_width,im_height,frame_rate\n0042,{scene.n_frames},1242,375,10\n"
    )
    one, two = tmp_path / "one" / "{class}" / "0042.txt", tmp_path / "two" / "{class}" / "0042.txt"
    ev1, ev2 = tmp_path / "one.jsonl", tmp_path / "two.jsonl"
    assert (
        main(
            [
                "-q",
                "track",
                "--format",
                "kitti",
                "--detections",
                str(root / "all" / "0042.txt"),
                "--output",
                str(one),
                "--events",
                str(ev1),
            ]
        )
        == 0
    )
    assert (
        main(
            [
                "-q",
                "track",
                "--format",
                "kitti",
                "--detections",
                str(root / "car" / "0042.txt"),
                str(root / "cyclist" / "0042.txt"),
                "--output",
                str(two),
                "--events",
                str(ev2),
            ]
        )
        == 0
    )
    for c in ("car", "cyclist"):
        a = (tmp_path / "one" / c / "0042.txt").read_text()
        assert a and a == (tmp_path / "two" / c / "0042.txt").read_text()
    assert ev1.read_text() == ev2.read_text()
    assert "hides_behind" in ev1.read_text()


def test_empty_class_file_still_gets_its_results_file(tmp_path: Path, car_and_cyclist) -> None:
    car, _ = car_and_cyclist
    ped = car.parent.parent / "pedestrian" / "0042.txt"
    ped.parent.mkdir()
    ped.write_text("")
    assert (
        main(
            [
                "-q",
                "track",
                "--format",
                "kitti",
                "--detections",
                str(car),
                str(ped),
                "--output",
                str(tmp_path / "r" / "{class}" / "0042.txt"),
            ]
        )
        == 0
    )
    assert (tmp_path / "r" / "pedestrian" / "0042.txt").read_text() == ""
    assert len(read_kitti_labels(tmp_path / "r" / "car" / "0042.txt")) > 0


def test_repeated_option_is_the_same_as_a_list(tmp_path: Path, car_and_cyclist) -> None:
    car, cyclist = car_and_cyclist
    a, b = tmp_path / "a.txt", tmp_path / "b.txt"
    assert (
        main(
            [
                "-q",
                "track",
                "--format",
                "kitti",
                "--detections",
                str(car),
                str(cyclist),
                "--output",
                str(a),
            ]
        )
        == 0
    )
    assert (
        main(
            [
                "-q",
                "track",
                "--format",
                "kitti",
                "--detections",
                str(car),
                "--detections",
                str(cyclist),
                "--output",
                str(b),
            ]
        )
        == 0
    )
    assert a.read_text() == b.read_text()


def test_classes_apart_track_as_in_separate_runs(tmp_path: Path) -> None:
    """Cars and pedestrians that never overlap, without the shared motion prior: the joint run's
    per-class files are the separate runs' files but for the id numbers (one id space)."""
    cars = crossing_scene(1, gap=6, near_class=CAR, far_class=CAR).detections
    peds = crossing_scene(2, gap=9, far_speed=5.0).detections
    peds = peds.with_(xyxy=peds.xyxy + np.array([0.0, 500.0, 0.0, 500.0]))  # below the cars
    root = tmp_path / "dets"
    write_rrc(root / "car" / "0005.txt", cars)
    write_rrc(root / "pedestrian" / "0005.txt", peds)
    n = int(max(cars.frame.max(), peds.frame.max())) + 1
    (root / "seqinfo.csv").write_text(
        f"seq,num_frames,im_width,im_height,frame_rate\n0005,{n},1242,1000,10\n"
    )
    files = [root / "car" / "0005.txt", root / "pedestrian" / "0005.txt"]
    common = ["-q", "track", "--format", "kitti", "--set", "inherit_motion=false"]
    assert (
        main(
            [
                *common,
                "--detections",
                *map(str, files),
                "--output",
                str(tmp_path / "joint" / "{class}" / "0005.txt"),
            ]
        )
        == 0
    )
    for f in files:
        c = f.parent.name
        assert (
            main(
                [
                    *common,
                    "--detections",
                    str(f),
                    "--output",
                    str(tmp_path / "sep" / c / "0005.txt"),
                ]
            )
            == 0
        )
        joint = read_kitti_labels(tmp_path / "joint" / c / "0005.txt")
        sep = read_kitti_labels(tmp_path / "sep" / c / "0005.txt")
        assert len(joint) == len(sep) > 0
        assert np.array_equal(joint.frame, sep.frame) and np.array_equal(joint.xyxy, sep.xyxy)
        ids = dict(zip(joint.tracker_id.tolist(), sep.tracker_id.tolist(), strict=True))
        assert len(set(ids.values())) == len(ids)  # a one-to-one renaming of the ids
        assert [ids[t] for t in joint.tracker_id.tolist()] == sep.tracker_id.tolist()


@pytest.mark.parametrize(
    ("problem", "expected"),
    [
        ("other_sequence", "different sequences"),
        ("same_file", "given twice"),
        ("same_class", "class car is also in"),
        ("unknown_class", "unknown class name 'bogus'"),
        ("class_count", "one class per file"),
        ("too_long", "beyond the sequence"),
        ("mot_one_file", "no class column"),
        ("overwrite_input", "--output (car) would overwrite the input"),
    ],
)
def test_bad_multiclass_input_is_one_line_exit_2(
    tmp_path: Path, car_and_cyclist, capsys, problem: str, expected: str
) -> None:
    car, cyclist = car_and_cyclist
    files, extra, fmt = [car, cyclist], [], "kitti"
    out = tmp_path / "out" / "{class}" / "0042.txt"
    if problem == "other_sequence":
        other = cyclist.with_name("0043.txt")
        other.write_text(cyclist.read_text())
        files = [car, other]
    elif problem == "same_file":
        files = [car, car.parent / ".." / "car" / "0042.txt"]
    elif problem == "same_class":
        twin = tmp_path / "twin" / "car" / "0042.txt"
        twin.parent.mkdir(parents=True)
        twin.write_text(car.read_text())
        files = [car, twin]
    elif problem == "unknown_class":
        extra = ["--class", "car,bogus"]
    elif problem == "class_count":
        extra = ["--class", "car"]
    elif problem == "too_long":
        n = len(car.read_text().splitlines())
        cyclist.write_text(cyclist.read_text() + "9999,10,10,50,50,0.9\n")
        assert len(car.read_text().splitlines()) == n
    elif problem == "mot_one_file":
        fmt, out = "mot", tmp_path / "out" / "res.txt"
        seq = tmp_path / "SEQ-01" / "det"
        seq.mkdir(parents=True)
        (seq / "det.txt").write_text("1,-1,10,10,20,20,0.9\n")
        other = tmp_path / "SEQ-01" / "det2"
        other.mkdir()
        files = [seq / "det.txt", other / "SEQ-01.txt"]
        (other / "SEQ-01.txt").write_text("1,-1,100,10,20,20,0.9\n")
        extra = ["--class", "pedestrian,car"]
    elif problem == "overwrite_input":
        extra = ["--output", str(car.parent.parent / "{class}" / "0042.txt")]  # the last wins
    before = {f: f.read_bytes() for f in files if f.exists()}
    code = main(
        [
            "track",
            "--format",
            fmt,
            "--detections",
            *map(str, files),
            "--output",
            str(out),
            "--events",
            str(tmp_path / "out" / "ev.jsonl"),
            *extra,
        ]
    )
    err = capsys.readouterr().err
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert expected in err
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").rglob("*"))
    assert {f: f.read_bytes() for f in before} == before  # the input untouched


def test_class_field_needs_detection_files(tmp_path: Path, capsys) -> None:
    video = tmp_path / "frames"
    video.mkdir()
    code = main(
        [
            "track",
            "--source",
            str(video),
            "--detector",
            str(tmp_path / "m.onnx"),
            "--output",
            str(tmp_path / "{class}" / "r.txt"),
        ]
    )
    assert code == 2
    assert "{class} needs --detections" in capsys.readouterr().err


# -- KITTI PointRCNN: the paper's case on real data ---------------------------------------------
KITTI = SHARED_DATA / "kitti"
POINTRCNN = KITTI / "detections" / "pointrcnn"
#: a sequence where a cyclist passes behind a car (ground-truth cyclist 4 behind car 1, ~frame 91)
CYCLIST_BEHIND_CAR_SEQUENCE = "0002"


@pytest.mark.slow
@pytest.mark.skipif(not POINTRCNN.is_dir(), reason="../shared/data not present")
def test_kitti_cyclist_hides_behind_a_car_in_a_joint_run(tmp_path: Path) -> None:
    from sensemaking.evaluation.explanations import GroundTruth, evaluate_explanations
    from sensemaking.records import event_from_record

    seq = CYCLIST_BEHIND_CAR_SEQUENCE
    files = [POINTRCNN / c / f"{seq}.txt" for c in ("car", "pedestrian", "cyclist")]
    ev, one = tmp_path / "ev.jsonl", tmp_path / "all" / f"{seq}.txt"
    assert (
        main(
            [
                "-q",
                "track",
                "--format",
                "kitti",
                "--detections",
                *map(str, files),
                "--output",
                str(tmp_path / "{class}" / f"{seq}.txt"),
                "--events",
                str(ev),
            ]
        )
        == 0
    )
    classes: dict[int, int] = {}
    for c in ("car", "pedestrian", "cyclist"):
        res = read_kitti_labels(tmp_path / c / f"{seq}.txt")
        assert set(res.class_id.tolist()) <= {CLASS_IDS[c]}
        classes.update(dict.fromkeys(res.tracker_id.tolist(), CLASS_IDS[c]))
    events = [event_from_record(r) for r in events_of(ev)]
    across = [
        e
        for e in events
        if e.name == "hides_behind"
        and classes.get(e.args[0]) == CYCLIST
        and classes.get(e.args[1]) == CAR
    ]
    assert across, [e for e in events if e.name == "hides_behind"]
    # judged against the multi-class ground truth: the cyclist was occluded, the car in front
    # covering it, and the same cyclist came out again
    assert (
        main(
            [
                "-q",
                "track",
                "--format",
                "kitti",
                "--detections",
                *map(str, files),
                "--output",
                str(one),
            ]
        )
        == 0
    )
    labels = read_kitti_labels(KITTI / "training" / "label_02" / f"{seq}.txt")
    truth = GroundTruth.from_kitti(
        labels, image_size=(1242, 375), classes=("car", "pedestrian", "cyclist")
    )
    verdicts = evaluate_explanations(truth, read_kitti_labels(one), events).events
    judged = [v for v in verdicts if v.event in across]
    assert any(v.verdict == "plausible" and v.identity == "kept" for v in judged), judged
    gt_class = {int(i): int(c) for i, c in zip(labels.tracker_id, labels.class_id, strict=True)}
    good = next(v for v in judged if v.verdict == "plausible")
    assert [gt_class[g] for g in good.gt] == [CYCLIST, CAR]
    # the same verdict from `evaluate --explanations` with cyclists among the classes
    verdicts_json = tmp_path / "verdicts.json"
    assert (
        main(
            [
                "-q",
                "evaluate",
                "--explanations",
                "--gt",
                str(KITTI / "training" / "label_02" / f"{seq}.txt"),
                "--results",
                str(one),
                "--events",
                str(ev),
                "--classes",
                "car,pedestrian,cyclist",
                "--json",
                str(verdicts_json),
            ]
        )
        == 0
    )
    doc = json.loads(verdicts_json.read_text())["sequences"][seq]["events"]
    assert {
        "frame": good.event.frame,
        "event": "hides_behind",
        "args": list(good.event.args),
        "verdict": "plausible",
    }.items() <= next(
        r
        for r in doc
        if r["event"] == "hides_behind"
        and r["args"] == list(good.event.args)
        and r["frame"] == good.event.frame
    ).items()

    # the per-class files score as the one file does (KITTI scores a class's rows only)
    gt_file = KITTI / "training" / "label_02" / f"{seq}.txt"
    scores = {}
    for c in ("car", "pedestrian"):
        for name, results in ((f"{c}-split", tmp_path / c / f"{seq}.txt"), (f"{c}-one", one)):
            out = tmp_path / f"{name}.json"
            assert (
                main(
                    [
                        "-q",
                        "evaluate",
                        "--gt",
                        str(gt_file),
                        "--results",
                        str(results),
                        "--benchmark",
                        "kitti",
                        "--classes",
                        c,
                        "--json",
                        str(out),
                    ]
                )
                == 0
            )
            scores[name] = json.loads(out.read_text())["classes"][c]["combined"]
        assert scores[f"{c}-split"] == scores[f"{c}-one"]
    assert scores["car-one"]["HOTA"] > 0.3 and scores["pedestrian-one"]["HOTA"] > 0.1
