"""Hostile inputs a fuzz of every verb found still answered by a traceback, an empty message, a
message without the file, unbounded memory or an overwritten input. Each case: exit status 2,
one line naming the file (and line where there is one), nothing written, the input untouched."""

from __future__ import annotations

import json
import os
import threading
from pathlib import Path

import numpy as np
import pytest
from test_hostile import one_line_error, write_det

from sensemaking.cli import main

LONG = "1" * 400  # past every float (an OverflowError where one was made of it)
HUGE = "1" * 5000  # past Python's 4300-digit limit of int("...")
needs_dev_zero = pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="no /dev/zero")


def _track(tmp: Path, *extra: str) -> list[str]:
    det = write_det(tmp / "det.txt", n_frames=12)
    return [
        "track",
        "--detections",
        str(det),
        "--format",
        "mot",
        "--fps",
        "10",
        "--image-size",
        "640x480",
        "--output",
        str(tmp / "out" / "o.txt"),
        *extra,
    ]


def _files(tmp: Path) -> dict[str, bytes]:
    return {str(p): p.read_bytes() for p in sorted(tmp.rglob("*")) if p.is_file()}


def _refused(argv: list[str], tmp: Path, capsys) -> str:
    """Run ``argv``: exit 2, one line, no file written or changed under ``tmp``; the line."""
    (tmp / "out").mkdir(exist_ok=True)
    before = _files(tmp)
    assert main(["-q", *argv]) == 2
    line = one_line_error(capsys)
    assert "internal error" not in line
    assert _files(tmp) == before
    return line


# a device or an endless pipe: read in chunks, refused at its first NUL byte ---------------------
@needs_dev_zero
@pytest.mark.parametrize(
    "extra",
    [
        ["--params", "/dev/zero"],
        ["--warnings", "{out}/w.jsonl", "--lanes", "/dev/zero"],
        [
            "--warnings",
            "{out}/w.jsonl",
            "--camera",
            "721,1.65,170,320",
            "--ego-motion",
            "/dev/zero",
        ],
    ],
    ids=["params", "lanes", "ego-motion"],
)
def test_track_refuses_a_device_at_its_first_nul_byte(tmp_path: Path, capsys, extra) -> None:
    argv = _track(tmp_path, *[e.format(out=tmp_path / "out") for e in extra])
    line = _refused(argv, tmp_path, capsys)
    assert "/dev/zero: a NUL byte at byte 0" in line


@needs_dev_zero
@pytest.mark.parametrize(
    "verb", ["explain", "ask", "evaluate-gt", "evaluate-seqmap", "report-gt", "ask-query-file"]
)
def test_other_verbs_refuse_a_device_too(tmp_path: Path, capsys, scene_file: Path, verb) -> None:
    gt = tmp_path / "gt.txt"
    gt.write_text("".join(f"{f},1,100,100,40,80,1,1,1.0\n" for f in range(1, 13)))
    argv = {
        "explain": ["explain", "/dev/zero"],
        "ask": ["ask", "/dev/zero", "tracks"],
        "evaluate-gt": ["evaluate", "--gt", "/dev/zero", "--results", str(gt)],
        "evaluate-seqmap": ["evaluate", "--gt", str(gt), "--results", str(gt), "--format", "mot"]
        + ["--seqmap", "/dev/zero"],
        "report-gt": ["report", str(scene_file), "-o", str(tmp_path / "out" / "r.html")]
        + ["--gt", "/dev/zero", "--thumbnails", "0", "--no-warnings"],
        "ask-query-file": ["ask", str(scene_file), str(tmp_path / "q.lp")],
    }[verb]
    (tmp_path / "q.lp").symlink_to("/dev/zero")  # a query file ends in .lp
    line = _refused(argv, tmp_path, capsys)
    assert ("q.lp: " if verb == "ask-query-file" else "/dev/zero: ") in line


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes")
def test_a_parameter_file_through_a_pipe_is_read_as_the_file(tmp_path: Path, capsys) -> None:
    params = {"format": "sensemaking-params/1", "base": "mot", "params": {"min_hits": 1}}
    text = json.dumps(params)
    (tmp_path / "out").mkdir()
    (tmp_path / "p.json").write_text(text)
    assert main(_track(tmp_path, "--params", str(tmp_path / "p.json"))) == 0
    want = (tmp_path / "out" / "o.txt").read_bytes()
    (tmp_path / "out" / "o.txt").unlink()
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    writer = threading.Thread(target=fifo.write_text, args=(text,))
    writer.start()
    try:
        assert main(_track(tmp_path, "--params", str(fifo))) == 0
    finally:
        writer.join(timeout=10)
    assert (tmp_path / "out" / "o.txt").read_bytes() == want and want


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes")
def test_ground_truth_read_twice_must_be_a_file(tmp_path: Path, capsys) -> None:
    # evaluate reads the first line for the format, then the whole: a pipe would be empty then
    fifo = tmp_path / "gt.txt"
    os.mkfifo(fifo)
    stop = threading.Event()

    def writer() -> None:  # writes once a reader opens the pipe (none may)
        while not stop.is_set():
            try:
                fd = os.open(fifo, os.O_WRONLY | os.O_NONBLOCK)
            except OSError:  # no reader yet
                stop.wait(0.01)
                continue
            os.write(fd, b"1,1,100,100,40,80,1,1,1.0\n")
            os.close(fd)
            return

    thread = threading.Thread(target=writer)
    thread.start()
    try:
        line = _refused(["evaluate", "--gt", str(fifo), "--results", str(fifo)], tmp_path, capsys)
    finally:
        stop.set()
        thread.join(timeout=10)
    assert f"{fifo}: not a regular file" in line


# JSON: an integer past Python's digit limit is a decode error at its line -----------------------
@pytest.mark.parametrize("digits", [LONG, HUGE], ids=["400", "5000"])
def test_json_integers_past_the_float_range_name_file_and_line(
    tmp_path: Path, capsys, scene_file: Path, digits: str
) -> None:
    out = tmp_path / "out"
    params = tmp_path / "p.json"
    params.write_text('{"format": "sensemaking-params/1",\n "params": {"max_hidden_s": ' + digits)
    params.write_text(params.read_text() + "}}")
    lanes = tmp_path / "lanes.json"
    lanes.write_text(
        '{"lanes": [\n{"id": 1, "points": [[1, 2], [3, ' + digits + ']], "width": 9}]}'
    )
    scene = tmp_path / "scene.json"
    text = scene_file.read_text()
    scene.write_text(text.replace('"fps":', '"x": ' + HUGE + ',\n"fps":', 1))
    events = tmp_path / "events.jsonl"
    events.write_text('{"frame": 1, "event": "starts", "args": [1]}\n{"frame": ' + digits + "}\n")
    gt = tmp_path / "gt.txt"
    gt.write_text("".join(f"{f},1,100,100,40,80,1,1,1.0\n" for f in range(1, 13)))
    cases = [
        (_track(tmp_path, "--params", str(params)), f"{params}:2:"),
        (
            _track(tmp_path, "--warnings", str(out / "w.jsonl"), "--lanes", str(lanes)),
            f"{lanes}:2:",
        ),
        # (a scene is read by its own streaming reader: 400 digits are 'malformed scene: ...')
        *([(["explain", str(scene)], f"{scene}:")] if digits == HUGE else []),
        (
            ["evaluate", "--explanations", "--gt", str(gt), "--results", str(gt), "--format"]
            + ["mot", "--fps", "10", "--image-size", "640x480", "--events", str(events)],
            f"{events}:2:",
        ),
    ]
    for argv, where in cases:
        line = _refused(argv, tmp_path, capsys)
        assert where in line and "an integer of more than 308 digits" in line, line


def test_toml_nested_too_deeply_names_the_file(tmp_path: Path, capsys) -> None:
    params = tmp_path / "p.toml"
    params.write_text("a = " + "[" * 100_000 + "]" * 100_000 + "\n")
    line = _refused(_track(tmp_path, "--params", str(params)), tmp_path, capsys)
    assert f"{params}: not readable JSON: nested too deeply" in line


# seqinfo ---------------------------------------------------------------------------------------
def test_seqinfo_csv_past_the_csv_field_limit_names_its_line(tmp_path: Path, capsys) -> None:
    det = tmp_path / "0001.txt"
    det.write_text("0,10,10,50,90,0.9\n")
    info = tmp_path / "seqinfo.csv"
    info.write_text(
        "seq,num_frames,im_width,im_height,frame_rate\n0001,12,640,480,10\n"
        f'x,"{"a" * 200_000}",1,1,1\n'
    )
    argv = ["track", "--detections", str(det), "--format", "kitti", "--class", "car"]
    argv += ["--seqinfo", str(info), "--output", str(tmp_path / "out" / "o.txt")]
    line = _refused(argv, tmp_path, capsys)
    assert f"{info}:3: not a valid CSV file" in line


@pytest.mark.parametrize("fmt", ["mot", "kitti"])
def test_a_sequence_length_past_the_frame_bound_names_the_seqinfo(
    tmp_path: Path, capsys, fmt: str
) -> None:
    big = 10**30
    if fmt == "mot":
        det = write_det(tmp_path / "seq" / "det" / "det.txt", n_frames=12)
        info = tmp_path / "seq" / "seqinfo.ini"
        info.write_text(
            f"[Sequence]\nname=X\nframeRate=10\nseqLength={big}\nimWidth=640\nimHeight=480\n"
        )
        where = f"{info}: seqLength {big} is beyond the plausibility bound"
    else:
        det = tmp_path / "0001.txt"
        det.write_text("0,10,10,50,90,0.9\n")
        info = tmp_path / "seqinfo.csv"
        info.write_text(f"seq,num_frames,im_width,im_height,frame_rate\n0001,{big},640,480,10\n")
        where = f"{info}:2: num_frames {big} is beyond the plausibility bound"
    argv = ["track", "--detections", str(det), "--format", fmt, "--class", "car"]
    argv += ["--output", str(tmp_path / "out" / "o.txt")]
    assert where in _refused(argv, tmp_path, capsys)


# situations' context files ---------------------------------------------------------------------
def test_a_lane_id_past_32_bits_is_refused_naming_the_file(tmp_path: Path, capsys) -> None:
    lanes = tmp_path / "lanes.json"
    for lane_id in (2**31, -(2**31) - 1, 10**30):
        lanes.write_text(json.dumps({"lanes": [{"id": lane_id, "points": [[1, 2], [3, 400]]}]}))
        argv = _track(tmp_path, "--warnings", str(tmp_path / "out" / "w.jsonl"))
        line = _refused(argv + ["--lanes", str(lanes)], tmp_path, capsys)
        assert f"{lanes}: lanes[0]: lane 'id' must be an integer or a string" in line
        assert "-2147483648..2147483647" in line


def test_an_empty_label_map_names_the_file(tmp_path: Path, capsys) -> None:
    seg = tmp_path / "seg"
    seg.mkdir()
    np.save(seg / "000001.npy", np.zeros((480, 640), dtype=np.uint8))
    (seg / "000002.npy").write_bytes(b"")
    argv = _track(tmp_path, "--warnings", str(tmp_path / "out" / "w.jsonl"))
    line = _refused(argv + ["--segmentation", str(seg)], tmp_path, capsys)
    assert f"{seg / '000002.npy'}: cannot read label map" in line


def test_an_output_over_a_file_of_an_input_folder_is_refused(tmp_path: Path, capsys) -> None:
    seg = tmp_path / "seg"
    seg.mkdir()
    np.save(seg / "000001.npy", np.zeros((480, 640), dtype=np.uint8))
    argv = _track(tmp_path, "--warnings", str(tmp_path / "out" / "w.jsonl"))
    argv[argv.index("--output") + 1] = str(seg / "000001.npy")
    line = _refused(argv + ["--segmentation", str(seg)], tmp_path, capsys)
    assert "would overwrite a file of the input folder --segmentation" in line


# calibrate -------------------------------------------------------------------------------------
def test_calibrate_names_the_detections_file_and_keeps_the_seqinfo(tmp_path: Path, capsys) -> None:
    det = write_det(tmp_path / "det" / "det.txt", n_frames=12)
    info = tmp_path / "seqinfo.ini"
    info.write_text("[Sequence]\nname=X\nframeRate=10\nseqLength=12\nimWidth=640\nimHeight=480\n")
    gt = tmp_path / "gt.txt"
    gt.write_text("".join(f"{f},1,{97 + 3 * f},100,40,80,1,1,1.0\n" for f in range(1, 11)))
    argv = ["calibrate", "--gt", str(gt), "--detections", str(det), "--format", "mot"]
    line = _refused(argv + ["--output", str(tmp_path / "out" / "p.json")], tmp_path, capsys)
    assert f"{det}: detections reach frame 12, the ground truth ends at frame 10" in line
    line = _refused(argv + ["--output", str(info)], tmp_path, capsys)
    assert f"{info}: --output would overwrite the input seqinfo" in line


def test_running_out_of_memory_says_so(monkeypatch, capsys) -> None:
    import sensemaking.cli.explain as explain

    def boom(args):
        raise MemoryError()

    monkeypatch.setattr(explain, "run", boom)
    assert main(["explain", "x.json"]) == 2
    assert one_line_error(capsys) == "sensemaking explain: error: out of memory"


@pytest.mark.parametrize(
    "item",
    [f"min_hits={LONG}", f"min_hits={HUGE}", f"image_size=1x{HUGE}", f"max_hidden_s={LONG}"]
    + ['class_confidence={"pedestrian": {"min_confidence": ' + LONG + "}}"],
    ids=["int-400", "int-5000", "size-5000", "float-400", "table-400"],
)
def test_set_values_past_the_float_range_are_one_line(tmp_path: Path, capsys, item: str) -> None:
    line = _refused(_track(tmp_path, "--set", item), tmp_path, capsys)
    assert line.startswith(f"sensemaking track: error: --set {item.split('=')[0]} ")


# the user's program on a frame's facts --------------------------------------------------------
@pytest.mark.parametrize(
    ("rules", "limit", "problem"),
    [
        (
            "{x(1..2)}. :- x(1), track(T). :- not x(1), track(T).",
            "5000000",
            "frame 2: the encoding has no answer set for a frame's facts (UNSATISFIABLE)",
        ),
        ("ok.", "50", "frame 2: the encoding (one frame) grounds to"),
    ],
    ids=["unsatisfiable", "atom-limit"],
)
def test_a_frame_the_users_rules_fail_on_names_the_rules_and_the_frame(
    tmp_path: Path, capsys, rules: str, limit: str, problem: str
) -> None:
    lp = tmp_path / "mine.lp"
    lp.write_text(rules + "\n")
    argv = _track(tmp_path, "--events", str(tmp_path / "out" / "e.jsonl"), "--rules", str(lp))
    (tmp_path / "det.txt").write_text(  # two boxes a frame: the solver runs from frame 2 on
        "".join(
            f"{f},-1,{100 + 3 * f + 60 * i},{100 + 5 * i},40,80,0.9,-1,-1,-1\n"
            for f in range(1, 13)
            for i in range(2)
        )
    )
    line = _refused(argv + ["--max-atoms", limit], tmp_path, capsys)
    assert f"{lp}: {problem}" in line


@needs_dev_zero
def test_detections_from_a_device_stop_at_the_first_nul_byte(tmp_path: Path, capsys) -> None:
    argv = _track(tmp_path)
    argv[argv.index("--detections") + 1] = "/dev/zero"
    line = _refused(argv, tmp_path, capsys)
    assert "/dev/zero: a NUL byte at byte 0" in line


def test_a_symlink_loop_is_one_line_in_query_and_render(
    tmp_path: Path, capsys, scene_file: Path
) -> None:
    pytest.importorskip("PIL")
    loop = tmp_path / "loop"
    loop.symlink_to(loop.name)
    (tmp_path / "out").mkdir()
    _refused(
        ["render", str(scene_file), "-o", str(tmp_path / "out") + "/", "--images", str(loop)]
        + ["--frames", "0:1"],
        tmp_path,
        capsys,
    )
    # a PNG folder output that cannot be renamed into place leaves no .part folder behind
    _refused(["render", str(scene_file), "-o", f"{loop}/", "--frames", "0:1"], tmp_path, capsys)
    assert not list(tmp_path.glob(".*part*"))
    if pytest.importorskip("duckdb"):
        assert "not a sensemaking archive" in _refused(
            ["query", str(loop), "sequences"], tmp_path, capsys
        )


# batch manifests: a line's values are checked where the line is known --------------------------
@pytest.mark.parametrize(
    ("row", "problem"),
    [
        ("a,1,det.txt,mot,1e30,", ":3: column 'fps' must be in [0.01, 1000]"),
        ("a,1,det.txt,mot,10,,1,200000", ":3: column 'height' must be in [1, 100000]"),
        ("a,0,det.txt,mot,10,", ":3: dataset 'a' sequence '0' is listed twice (first on line 2)"),
    ],
    ids=["fps", "height", "twice"],
)
def test_a_manifest_line_past_the_bounds_is_named(
    tmp_path: Path, capsys, row: str, problem: str
) -> None:
    write_det(tmp_path / "det.txt", n_frames=12)
    manifest = tmp_path / "manifest.csv"
    manifest.write_text(
        f"dataset,sequence,path,format,fps,frames,width,height\na,0,det.txt,mot,10,,,\n{row}\n"
    )
    argv = ["batch", "--data", str(manifest), "--archive", str(tmp_path / "out" / "arc")]
    assert f"{manifest}{problem}" in _refused(argv, tmp_path, capsys)


def test_an_archive_marker_nested_too_deeply_names_it(tmp_path: Path, capsys) -> None:
    pytest.importorskip("duckdb")
    archive = tmp_path / "arc"
    archive.mkdir()
    marker = archive / "_fleet.json"
    marker.write_text("[" * 100_000 + "]" * 100_000)
    line = _refused(["query", str(archive), "sequences"], tmp_path, capsys)
    assert f"{marker}: not readable JSON: nested too deeply" in line


def test_a_memory_limit_past_any_machine_is_no_limit(tmp_path: Path, capsys) -> None:
    lp = tmp_path / "mine.lp"
    lp.write_text("ok.\n")
    (tmp_path / "out").mkdir()
    argv = _track(tmp_path, "--rules", str(lp), "--max-memory", "9" * 23)
    assert main(["-q", *argv]) == 0  # was 'OverflowError: Python int too large ...' (exit 2)
    assert (tmp_path / "out" / "o.txt").read_text()


def test_query_with_a_memory_limit_past_any_machine_answers(tmp_path: Path, capsys) -> None:
    from test_trust_boundary import make_archive

    archive = make_archive(tmp_path / "archive")
    capsys.readouterr()
    code = main(["-q", "query", str(archive), "--max-memory", "9" * 23, "sequences"])
    out = capsys.readouterr()
    assert code == 0, out.err  # was an internal error (DuckDB: memory value out of range)
    assert "synthetic" in out.out


def test_a_frame_the_users_situations_rule_out_names_them_and_the_frame(
    tmp_path: Path, capsys
) -> None:
    # was a run without warnings, exit 0: a silent fallback
    from test_track_situations import LANES, parked_car_det

    det, lanes = parked_car_det(tmp_path), tmp_path / "lanes.json"
    lanes.write_text(json.dumps(LANES))
    lp = tmp_path / "mine.lp"
    lp.write_text(":- warn(S, O).\n")
    argv = ["track", "--detections", str(det), "--format", "mot", "--fps", "10"]
    argv += ["--image-size", "1242x375", "--output", str(tmp_path / "out" / "o.txt")]
    argv += ["--warnings", str(tmp_path / "out" / "w.jsonl"), "--lanes", str(lanes)]
    line = _refused(argv + ["--situations", str(lp)], tmp_path, capsys)
    assert f"{lp}: frame " in line and "the situations have no answer set" in line
