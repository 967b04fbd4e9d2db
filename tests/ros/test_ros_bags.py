"""ROS 2 bags in, MCAP out (extra 'ros'), without ROS: bags written with rosbags from detection
files, tracked through the CLI, the output MCAP read back with the mcap library."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rosbags")
pytest.importorskip("mcap")

from conftest import SHARED_DATA  # noqa: E402
from ros_bags import (  # noqa: E402
    bag_from_text,
    mcap_file,
    read_channels,
    result_rows,
    track_rows,
)

from sensemaking.cli import main  # noqa: E402
from sensemaking.detections import Detections  # noqa: E402
from sensemaking.io.kitti import read_kitti_labels  # noqa: E402
from sensemaking.io.mot import read_mot  # noqa: E402
from sensemaking.synthetic import crossing_scene  # noqa: E402

KITTI_0001 = SHARED_DATA / "kitti" / "detections" / "rrc" / "car" / "0001.txt"
MOT17_05 = SHARED_DATA / "mot17" / "MOT17-05-YOLOX-half" / "det" / "det.txt"
CHANNELS = {
    "/sensemaking/tracks": "sensemaking.Tracks",
    "/sensemaking/annotations": "foxglove.ImageAnnotations",
    "/sensemaking/events": "sensemaking.Event",
    "/sensemaking/warnings": "sensemaking.Warning",
    "/sensemaking/log": "foxglove.Log",
    "/sensemaking/stories": "sensemaking.Story",
}


def one_line_error(capsys, code: int) -> str:
    """The error of a refused run: exit 2, one line on stderr, no traceback."""
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    return err


@pytest.fixture()
def crossing(tmp_path: Path) -> tuple[Path, Path, int]:
    """A synthetic KITTI-format detection file (two cars crossing, one hidden) and its bag."""
    scene = crossing_scene(0, gap=12, far_speed=8.0)
    d = scene.detections
    text = tmp_path / "car" / "0042.txt"
    text.parent.mkdir()
    order = np.argsort(d.frame, kind="stable")
    text.write_text(
        "".join(
            f"{d.frame[i]},{x1:.3f},{y1:.3f},{x2:.3f},{y2:.3f},{d.confidence[i]:.4f}\n"
            for i, (x1, y1, x2, y2) in zip(order, d.xyxy[order], strict=True)
        )
    )
    bag = bag_from_text(
        text,
        "kitti",
        tmp_path / "bag",
        first=0,
        last=scene.n_frames - 1,
        fps=10.0,
        image_size=(1242, 375),
        class_name="car",
    )
    return text, bag, scene.n_frames


def test_bag_tracks_like_its_text_file_and_mcap_holds_the_run(crossing, tmp_path, capsys) -> None:
    text, bag, n = crossing
    common = ["--image-size", "1242x375", "--fps", "10"]
    assert (
        main(
            [
                "-q",
                "track",
                "--detections",
                str(text),
                "--format",
                "kitti",
                "--class",
                "car",
                "--output",
                str(tmp_path / "text.txt"),
                "--write-hidden",
                "--events",
                str(tmp_path / "text.jsonl"),
                *common,
            ]
        )
        == 0
    )
    # the folder and the bare .mcap file in it read the same; the topic found by its type
    for source in (bag, mcap_file(bag)):
        out = tmp_path / f"bag-{source.suffix or 'dir'}.txt"
        assert (
            main(
                [
                    "-q",
                    "track",
                    "--detections",
                    str(source),
                    "--format",
                    "kitti",
                    "--output",
                    str(out),
                    "--write-hidden",
                ]
            )
            == 0
        )
        assert out.read_bytes() == (tmp_path / "text.txt").read_bytes()
    run = tmp_path / "run.mcap"
    assert (
        main(
            [
                "-q",
                "track",
                "--detections",
                str(bag),
                "--topic",
                "/detections",
                "--output",
                str(run),
                "--stories",
                "--warnings",
                str(tmp_path / "w.jsonl"),
                "--scene",
                str(tmp_path / "scene.json"),
            ]
        )
        == 0
    )
    channels = read_channels(run)
    _check_stories(channels, tmp_path / "scene.json", capsys)
    # without --stories the run keeps no scene and tells none
    plain = tmp_path / "plain.mcap"
    assert main(["-q", "track", "--detections", str(bag), "--output", str(plain)]) == 0
    assert not read_channels(plain).get("/sensemaking/stories")
    text_out = str(tmp_path / "t.txt")
    assert main(["-q", "track", "--detections", str(bag), "--output", text_out, "--stories"]) == 2
    assert "--stories needs" in capsys.readouterr().err
    # the warnings, start and end records, as the --warnings file of the same run has them
    said = [json.loads(s) for s in (tmp_path / "w.jsonl").read_text().splitlines()]
    got = [
        {k: v for k, v in m.items() if k != "timestamp"}
        for _, m in channels["/sensemaking/warnings"]
    ]
    assert got == said and {r["record"] for r in said} == {"start", "end"}
    assert sum(m["level"] == 3 for _, m in channels["/sensemaking/log"]) == len(
        [r for r in said if r["record"] == "start"]
    )
    assert set(CHANNELS) <= set(channels)
    # every box (hidden tracks at their predicted boxes too) of the text run, exactly
    expected = result_rows(read_kitti_labels(tmp_path / "text.txt"))
    np.testing.assert_array_equal(track_rows(run, visible_only=False), expected)
    states = {t["state"] for _, m in channels["/sensemaking/tracks"] for t in m["tracks"]}
    assert "hidden" in states
    # every event, as the --events file has it, stamped with its frame's header stamp
    events = [json.loads(s) for s in (tmp_path / "text.jsonl").read_text().splitlines()]
    got = [
        {k: v for k, v in m.items() if k != "timestamp"}
        for _, m in channels["/sensemaking/events"]
    ]
    assert got == events and any(e["event"] == "hides_behind" for e in events)
    t0 = 1_700_000_000_000_000_000
    for log_time, m in channels["/sensemaking/events"]:
        assert log_time == t0 + m["frame"] * 100_000_000
        assert m["timestamp"] == {"sec": log_time // 10**9, "nsec": log_time % 10**9}
    logs = [m["message"] for _, m in channels["/sensemaking/log"]]
    assert any(s.startswith("hides_behind(") for s in logs)
    # the annotations: one box and one label per track of the frame, in the frame's time
    tracks = dict(channels["/sensemaking/tracks"])
    for log_time, m in channels["/sensemaking/annotations"]:
        assert len(m["points"]) == len(tracks[log_time]["tracks"])
        assert all(p["type"] == 2 and len(p["points"]) == 4 for p in m["points"])
    labels = [t["text"] for _, m in channels["/sensemaking/annotations"] for t in m["texts"]]
    assert any("(hidden)" in s for s in labels) and any(
        s.startswith("hides_behind(") for s in labels
    )


def _check_stories(channels: dict, scene: Path, capsys) -> None:
    """One story per output track, at its last frame's time, its text what `sensemaking
    explain --track ID` prints for the --scene file of the same run."""
    tracks = {t["id"]: t for _, m in channels["/sensemaking/tracks"] for t in m["tracks"]}
    frames = {}
    for _, m in channels["/sensemaking/tracks"]:
        for t in m["tracks"]:
            frames.setdefault(t["id"], []).append(m["frame"])
    stories = channels["/sensemaking/stories"]
    assert sorted(m["track"] for _, m in stories) == sorted(tracks) and len(tracks) >= 2
    told = {}
    for log_time, m in stories:
        tid = m["track"]
        assert (m["first_frame"], m["last_frame"]) == (min(frames[tid]), max(frames[tid]))
        assert log_time == 1_700_000_000_000_000_000 + m["last_frame"] * 100_000_000
        assert m["class"] == tracks[tid]["class"] and m["class_id"] == tracks[tid]["class_id"]
        assert m["text"] == " ".join(m["sentences"])
        told[tid] = m["text"]
    capsys.readouterr()
    for tid, text in told.items():
        main(["explain", str(scene), "--track", str(tid)])
        assert text == capsys.readouterr().out.strip()
    assert any("hides behind" in t for t in told.values())  # a story with the occlusion
    logged = [m["message"] for _, m in channels["/sensemaking/log"] if m["name"].endswith("ies")]
    assert sorted(logged) == sorted(told.values())


def test_mcap_schemas_and_passthrough(crossing, tmp_path) -> None:
    from mcap.reader import make_reader

    _, bag, n = crossing
    run = tmp_path / "run.mcap"
    assert (
        main(["-q", "track", "--detections", str(bag), "--output", str(run), "--passthrough"]) == 0
    )
    with open(run, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    names = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
    for topic, schema in CHANNELS.items():
        assert names[topic] == schema
    assert names["/detections"] == "vision_msgs/msg/Detection2DArray"
    assert names["/camera/camera_info"] == "sensor_msgs/msg/CameraInfo"
    counts = {
        summary.channels[c].topic: k for c, k in summary.statistics.channel_message_counts.items()
    }
    assert counts["/detections"] == n and counts["/camera/camera_info"] == 1
    # copied byte for byte
    with open(mcap_file(bag), "rb") as a, open(run, "rb") as b:
        src = [m.data for _, c, m in make_reader(a).iter_messages(topics=["/detections"])]
        dst = [m.data for _, c, m in make_reader(b).iter_messages(topics=["/detections"])]
    assert src == dst


def test_db3_bag_reads_the_same(crossing, tmp_path) -> None:
    text, bag, n = crossing
    db3 = bag_from_text(
        text,
        "kitti",
        tmp_path / "db3bag",
        first=0,
        last=n - 1,
        fps=10.0,
        image_size=(1242, 375),
        class_name="car",
        storage="sqlite3",
    )
    assert list(db3.glob("*.db3"))
    a, b = tmp_path / "a.txt", tmp_path / "b.txt"
    assert main(["-q", "track", "--detections", str(bag), "--output", str(a)]) == 0
    assert main(["-q", "track", "--detections", str(db3), "--output", str(b)]) == 0
    assert a.read_bytes() == b.read_bytes() and a.stat().st_size > 0


def test_irregular_stamps_map_to_frames_by_the_nominal_rate(tmp_path) -> None:
    from sensemaking.ros.convert import write_detection_bag
    from sensemaking.ros.reader import BagReader, ClassTable

    box = Detections(np.array([[10.0, 10.0, 50.0, 90.0]]), 0.9, 3)
    # 10 fps with jitter, the message of 0.4 s dropped, two close together at 0.6 s
    times = [0.0, 0.1, 0.21, 0.29, 0.5, 0.6, 0.62, 0.8, 0.9, 1.0, 1.1]
    bag = write_detection_bag(tmp_path / "b", [(t * 10, box) for t in times], fps=10.0)
    reader = BagReader(bag, None, ClassTable(), first_frame=0)
    summary = reader.scan(None)
    assert summary.fps == 10.0 and summary.messages == len(times)
    frames = [f for f, _ in reader.frames(None)]
    assert frames == [0, 1, 2, 3, 5, 6, 7, 8, 9, 10, 11]
    assert summary.last == 11
    reader.close()


def test_class_table(tmp_path, capsys) -> None:
    from sensemaking.ros.reader import ClassTable

    table = ClassTable.parse("0=pedestrian,2=car,7=ignore")
    assert table.lookup("2") == 3 and table.lookup("0") == 1 and table.lookup("7") is None
    assert table.lookup("cyclist") == 16  # our names need no table
    with pytest.raises(ValueError, match="--classes 5=NAME"):
        table.lookup("5")
    path = tmp_path / "classes.json"
    path.write_text('{"2": "car"}')
    assert ClassTable.parse(str(path)).lookup("2") == 3
    with pytest.raises(ValueError, match="unknown class name"):
        ClassTable.parse("2=spaceship")


def test_an_output_over_the_class_table_is_refused(crossing, tmp_path, capsys) -> None:
    _, bag, _ = crossing
    table = tmp_path / "classes.json"
    table.write_text('{"2": "car"}')
    argv = ["track", "--detections", str(bag), "--classes", str(table), "--output", str(table)]
    err = one_line_error(capsys, main(argv))
    assert "would overwrite the input --classes" in err  # it was overwritten by the tracks
    assert table.read_text() == '{"2": "car"}'


def test_numbered_classes_need_the_table(tmp_path, capsys) -> None:
    # a COCO-numbered detector: class_id "2" (car) and "0" (person)
    import sensemaking.ros.convert as convert
    from sensemaking.ros.convert import write_detection_bag

    frames = [
        (
            f,
            Detections(
                np.array([[10.0 + f, 10.0, 60.0 + f, 90.0], [300, 20, 340, 120]]),
                0.9,
                np.array([2, 0]),
            ),
        )
        for f in range(8)
    ]
    names = {2: "2", 0: "0"}
    original = convert.class_name
    convert.class_name = lambda c: names[int(c)]  # noqa: E731 - the detector's own names
    try:
        bag = write_detection_bag(tmp_path / "coco", frames, fps=10.0)
    finally:
        convert.class_name = original
    out = tmp_path / "o.txt"
    err = one_line_error(capsys, main(["track", "--detections", str(bag), "--output", str(out)]))
    assert "class_id '" in err and "--classes" in err
    assert (
        main(
            [
                "-q",
                "track",
                "--detections",
                str(bag),
                "--output",
                str(out),
                "--classes",
                "2=car,0=ignore",
            ]
        )
        == 0
    )
    res = read_kitti_labels(out)
    assert len(res) and set(res.class_id.tolist()) == {3}


def test_bad_input_is_one_line(crossing, tmp_path, capsys) -> None:
    _, bag, n = crossing
    out = str(tmp_path / "o.mcap")
    err = one_line_error(
        capsys, main(["track", "--detections", str(bag), "--topic", "/nope", "--output", out])
    )
    assert "/nope" in err and "/detections (vision_msgs/msg/Detection2DArray)" in err
    assert "/camera/camera_info (sensor_msgs/msg/CameraInfo)" in err
    err = one_line_error(
        capsys,
        main(
            ["track", "--detections", str(bag), "--topic", "/camera/camera_info", "--output", out]
        ),
    )
    assert "sensor_msgs/msg/CameraInfo messages" in err
    # a truncated file: the recorder died
    cut = tmp_path / "cut.mcap"
    data = mcap_file(bag).read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    err = one_line_error(capsys, main(["track", "--detections", str(cut), "--output", out]))
    assert str(cut) in err
    # the output would overwrite the input
    err = one_line_error(
        capsys,
        main(["track", "--detections", str(mcap_file(bag)), "--output", str(mcap_file(bag))]),
    )
    assert "overwrite the input" in err
    err = one_line_error(
        capsys,
        main(
            [
                "track",
                "--detections",
                str(bag),
                "--passthrough",
                "--output",
                str(tmp_path / "o.txt"),
            ]
        ),
    )
    assert "--passthrough" in err
    err = one_line_error(
        capsys,
        main(
            [
                "track",
                "--detections",
                str(tmp_path / "x.txt"),
                "--format",
                "mot",
                "--topic",
                "/d",
                "--output",
                out,
            ]
        ),
    )
    assert "--topic reads a ROS 2 bag" in err
    assert not (tmp_path / "o.mcap").exists()


def test_unsorted_stamps_are_refused(tmp_path, capsys) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer

    from sensemaking.ros.convert import _array, _time
    from sensemaking.ros.msgs import DETECTION_ARRAY, typestore

    box = Detections(np.array([[10.0, 10.0, 50.0, 90.0]]), 0.9, 3)
    store = typestore()
    bag = tmp_path / "b"
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conn = w.add_connection("/detections", DETECTION_ARRAY, typestore=store)
        # logged in this order, but the third message's header stamp is before the second's
        for k, stamp in enumerate([0, 200, 100, 300]):
            msg = _array(store, box, _time(store, 10**9 + stamp * 10**6), "camera")
            w.write(conn, 10**9 + k, store.serialize_cdr(msg, DETECTION_ARRAY))
    err = one_line_error(
        capsys, main(["track", "--detections", str(bag), "--output", str(tmp_path / "o.txt")])
    )
    assert "message 3" in err and "stamps must increase" in err


def test_wrong_message_layout_is_refused(tmp_path, capsys) -> None:
    """Bytes that are not a Detection2DArray on a Detection2DArray topic: one line."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    from sensemaking.ros.msgs import DETECTION_ARRAY, typestore

    with Writer(tmp_path / "b", version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conn = w.add_connection("/detections", DETECTION_ARRAY, typestore=typestore())
        w.write(conn, 1, b"\x00\x01\x00\x00garbage")
    err = one_line_error(
        capsys,
        main(["track", "--detections", str(tmp_path / "b"), "--output", str(tmp_path / "o.txt")]),
    )
    assert "message 1" in err and "cannot decode" in err


def test_missing_extra_names_it(crossing, tmp_path, capsys, monkeypatch) -> None:
    _, bag, _ = crossing
    monkeypatch.setitem(sys.modules, "rosbags.highlevel", None)  # as if not installed
    err = one_line_error(
        capsys, main(["track", "--detections", str(bag), "--output", str(tmp_path / "o.txt")])
    )
    assert "sensemaking[ros]" in err


def _round_trip(
    text: Path, fmt: str, seqlen: int, fps: float, size, tmp_path: Path, cls: str | None
) -> None:
    first = 1 if fmt == "mot" else 0
    bag = bag_from_text(
        text,
        fmt,
        tmp_path / "bag",
        first=first,
        last=first + seqlen - 1,
        fps=fps,
        image_size=size,
        class_name=cls,
    )
    ref = tmp_path / "ref.txt"
    args = ["--class", cls] if cls else []
    assert (
        main(
            [
                "-q",
                "track",
                "--detections",
                str(text),
                "--format",
                fmt,
                "--output",
                str(ref),
                *args,
            ]
        )
        == 0
    )
    out, run = tmp_path / "bag.txt", tmp_path / "run.mcap"
    assert (
        main(["-q", "track", "--detections", str(bag), "--format", fmt, "--output", str(out)]) == 0
    )
    assert (
        main(["-q", "track", "--detections", str(bag), "--format", fmt, "--output", str(run)]) == 0
    )
    read = read_kitti_labels if fmt == "kitti" else (lambda p: read_mot(p, kind="results"))
    expected = result_rows(read(ref))
    if fmt == "kitti":  # corners with 6 decimals come back as the file's very numbers
        assert out.read_bytes() == ref.read_bytes()
        np.testing.assert_array_equal(track_rows(run, visible_only=True), expected)
    # MOT's x2 = x + w of the text reader is not always the double nearest to its decimal, so
    # a box through center and size may differ in the last bit: the same tracks, boxes to 1e-9
    for got in (result_rows(read(out)), track_rows(run, visible_only=True)):
        assert got.shape == expected.shape
        np.testing.assert_array_equal(got[:, :2], expected[:, :2])  # frames and ids
        np.testing.assert_allclose(got[:, 2:], expected[:, 2:], rtol=0, atol=1e-9)


@pytest.mark.integration
@pytest.mark.slow
@pytest.mark.skipif(not KITTI_0001.is_file(), reason="../shared/data is absent")
def test_kitti_0001_round_trip(tmp_path) -> None:
    _round_trip(KITTI_0001, "kitti", 447, 10.0, (1242, 375), tmp_path, "car")


@pytest.mark.integration
@pytest.mark.slow
@pytest.mark.skipif(not MOT17_05.is_file(), reason="../shared/data is absent")
def test_mot17_05_round_trip(tmp_path) -> None:
    _round_trip(MOT17_05, "mot", 418, 14.0, (640, 480), tmp_path, None)


def test_direct_reading_equals_the_generic_decoder(crossing) -> None:
    """The vision_msgs 4 layout read directly gives what rosbags' decoder gives, and a
    definition that differs is left to the decoder."""
    from mcap.reader import make_reader
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from sensemaking.ros.reader import _generic, has_layout, parse_detection_array

    _, bag, _ = crossing
    with open(mcap_file(bag), "rb") as f:
        reader = make_reader(f)
        schema = next(
            s
            for s in reader.get_summary().schemas.values()
            if s.name == "vision_msgs/msg/Detection2DArray"
        )
        text = schema.data.decode()
        store = get_typestore(Stores.EMPTY)
        store.register(get_types_from_msg(text, schema.name))
        n = boxes = 0
        for _, _, m in reader.iter_messages(topics=["/detections"]):
            fast = parse_detection_array(m.data)
            assert fast == _generic(store.deserialize_cdr(m.data, schema.name))
            n += 1
            boxes += len(fast[1])
    assert n > 10 and boxes > n
    assert has_layout(text)
    # as ROS 2 writes its own .msg files: comments, same-package types unqualified, defaults
    ros_style = (
        text.replace(
            "vision_msgs/Detection2D[] detections", "# proposals\nDetection2D[] detections"
        )
        .replace("vision_msgs/Pose2D center", "Pose2D center  # the box's center")
        .replace("float64 w", "float64 w 1")
        .replace("float64 theta", "float64 theta\nuint8 NONE=0")
    )
    assert ros_style != text and has_layout(ros_style)
    assert not has_layout(text.replace("float64 score", "float32 score"))
    assert not has_layout(text.replace("vision_msgs/Pose2D center", "geometry_msgs/Pose2D center"))
    assert parse_detection_array(m.data[:-9]) is None  # cut short: not this layout


def test_a_long_bag_is_read_again_not_kept(crossing, monkeypatch) -> None:
    """The checking pass keeps a short bag's boxes for the run; past KEEP_BOXES the run reads
    the bag again: the same frames either way."""
    from sensemaking.ros.reader import BagReader, ClassTable

    _, bag, _ = crossing

    def frames() -> list[tuple[int, list]]:
        reader = BagReader(bag, "/detections", ClassTable())
        reader.scan((1242, 375))
        kept = reader._kept is not None
        got = [(f, d.xyxy.tolist(), d.class_id.tolist()) for f, d in reader.frames((1242, 375))]
        reader.close()
        return kept, got

    kept, short = frames()
    monkeypatch.setattr(BagReader, "KEEP_BOXES", 5)
    again, long = frames()
    assert kept and not again
    assert short == long and len(short) > 10


def test_preview_draws_a_frame_of_the_annotations(crossing, tmp_path) -> None:
    image_mod = pytest.importorskip("PIL.Image")
    from sensemaking.ros.preview import render_annotations

    _, bag, _ = crossing
    run = tmp_path / "run.mcap"
    assert main(["-q", "track", "--detections", str(bag), "--output", str(run)]) == 0
    frame = render_annotations(run, tmp_path / "f.png")
    with image_mod.open(tmp_path / "f.png") as im:
        assert im.size == (1242, 375)
        # the boxes are drawn: more than the canvas's one colour
        assert len(im.convert("RGB").getcolors(1 << 16)) > 2
    tracks = {m["frame"]: m for _, m in read_channels(run)["/sensemaking/tracks"]}
    assert len(tracks[frame]["tracks"]) == max(len(m["tracks"]) for m in tracks.values())


@pytest.mark.slow
def test_damaged_bags_never_give_a_traceback(tmp_path, capsys) -> None:
    """Bytes flipped, cut or repeated anywhere in a bag's MCAP file: a run or one line, exit 2."""
    import random

    from sensemaking.ros.convert import write_detection_bag

    frames = [
        (
            f,
            Detections(
                np.array([[10.0 + f, 20.0, 60.0 + f, 90.0], [200.0, 30.0, 260.0, 140.0]]),
                0.9,
                np.array([3, 1]),
            ),
        )
        for f in range(12)
    ]
    bag = write_detection_bag(tmp_path / "b", frames, fps=10.0, image_size=(640, 480))
    data = bytearray(mcap_file(bag).read_bytes())
    rng = random.Random(25)
    for k in range(60):
        bad = bytearray(data)
        how = k % 3
        at = rng.randrange(len(bad))
        if how == 0:
            for _ in range(rng.randint(1, 8)):
                bad[rng.randrange(len(bad))] = rng.randrange(256)
        elif how == 1:
            bad = bad[:at]
        else:
            bad[at:at] = bad[at : at + rng.randint(1, 64)]
        path = tmp_path / f"bad{k}.mcap"
        path.write_bytes(bytes(bad))
        code = main(
            [
                "-q",
                "track",
                "--detections",
                str(path),
                "--output",
                str(tmp_path / f"o{k}.mcap"),
                "--passthrough",
            ]
        )
        err = capsys.readouterr().err
        assert code in (0, 2), (k, how, err)
        assert "Traceback" not in err and "internal error" not in err, (k, how, err)
        if code == 2:
            assert len(err.strip().splitlines()) == 1, err
