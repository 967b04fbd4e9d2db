"""Issue 24's numbered cases, one test (or more) each: the trust boundary of every verb
(docs/SECURITY.md). Each failed on the main branch before the sandbox module, the locked-down
query connection and the write-through outputs."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from test_hostile import one_line_error, write_det

from sensemaking.cli import main


# 2. a query that does not parse is refused before clingo sees it
@pytest.mark.parametrize(
    "query",
    [
        'q("abc\n). #include "secret.lp". #show secret/1.',
        'q("\\#include "secret.lp". ").',
        'q(1). %* a comment *% #include "secret.lp".',
    ],
)
def test_a_hidden_include_is_refused_before_clingo_opens_the_file(
    scene_file: Path, capsys, monkeypatch, query: str
) -> None:
    (scene_file.parent / "secret.lp").write_text("secret(84611597).\n")
    monkeypatch.chdir(scene_file.parent)
    assert main(["ask", "--timeout", "5", str(scene_file), query]) == 2
    line = one_line_error(capsys)
    assert "#include is not allowed" in line and "84611597" not in line


def test_a_query_that_does_not_parse_is_refused_with_its_position(
    scene_file: Path, capsys
) -> None:
    assert main(["ask", str(scene_file), 'q("abc\n).']) == 2
    line = one_line_error(capsys)
    assert "invalid query: query:1:" in line


# 1. query: DuckDB reads the archive and nothing else
def make_archive(root: Path, n_frames: int = 10) -> Path:
    """A one-sequence archive written without Ray (the worker's own functions)."""
    pytest.importorskip("pyarrow")
    pytest.importorskip("duckdb")
    from sensemaking.fleet.archive import Archive, archive_sequence
    from sensemaking.fleet.run import RunParams
    from sensemaking.fleet.specs import read_manifest
    from sensemaking.fleet.synthetic import write_synthetic_fleet

    manifest = write_synthetic_fleet(root.parent / f"{root.name}-fleet", 1, n_frames=n_frames)
    with Archive(root):
        archive_sequence(read_manifest(manifest)[0], str(root), RunParams(), "k1", {}, "r1")
    return root


@pytest.fixture(scope="module")
def archive(tmp_path_factory) -> Path:
    return make_archive(tmp_path_factory.mktemp("arc") / "archive")


def _query(archive: Path, sql: str, capsys) -> tuple[int, str, str]:
    code = main(["query", str(archive), sql])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_query_answers_over_the_views(archive: Path, capsys) -> None:
    code, out, _ = _query(archive, "SELECT count(*) AS n FROM tracks", capsys)
    assert code == 0 and int(out.splitlines()[2]) > 0


@pytest.mark.parametrize(
    "sql",
    [
        "SELECT * FROM read_csv('/etc/passwd', header=false, sep=':')",
        "SELECT * FROM read_text('/etc/hostname')",
        "COPY (SELECT 1) TO '{tmp}/x.csv'",
        "ATTACH '{tmp}/new.db'",
        "INSTALL httpfs",
        "SET enable_external_access = true",
        "SELECT 1; COPY (SELECT 1) TO '{tmp}/y.csv'",
        "COPY (SELECT 2 AS a) TO '{tracks}' (FORMAT parquet, USE_TMP_FILE false)",
    ],
)
def test_query_reaches_nothing_outside_the_archive(
    archive: Path, tmp_path: Path, capsys, sql: str
) -> None:
    tracks = next(archive.glob("dataset=*/sequence=*/key=*/tracks.parquet"))
    before = tracks.read_bytes()
    code, out, err = _query(archive, sql.format(tmp=tmp_path, tracks=tracks), capsys)
    assert code == 2 and "root:" not in out and "Traceback" not in err
    assert len([x for x in err.splitlines() if x.strip()]) == 1
    assert not list(tmp_path.iterdir())  # nothing written
    assert tracks.read_bytes() == before


def test_query_rows_are_bounded(archive: Path, capsys) -> None:
    assert (
        main(["query", str(archive), "--max-rows", "1000", "SELECT * FROM range(30000000)"]) == 2
    )
    assert "more than 1000 rows" in one_line_error(capsys)


@pytest.mark.slow
def test_sigterm_stops_a_long_query(archive: Path) -> None:
    import signal
    import subprocess
    import sys
    import time

    sql = "SELECT sum(a.range * b.range) FROM range(100000000) a, range(100000) b"
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).parents[2] / "src")}
    proc = subprocess.Popen(
        [sys.executable, "-m", "sensemaking", "-v", "query", str(archive), sql],
        env=env,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert proc.stderr is not None
    # the signal is sent once the query runs, not while a loaded machine still imports
    seen: list[str] = []
    for line in proc.stderr:
        seen.append(line)
        if "query running" in line:
            break
    assert seen and "query running" in seen[-1], "".join(seen)
    time.sleep(1.0)
    t0 = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    proc.wait(timeout=30)
    assert time.monotonic() - t0 < 5.0 and proc.returncode == 143, proc.stderr.read()


# 8. an archive path with '[' is that archive, not a glob
def test_an_archive_path_with_a_bracket_is_not_a_glob(tmp_path: Path, capsys) -> None:
    mine = make_archive(tmp_path / "a[1]" / "archive", n_frames=8)
    make_archive(tmp_path / "a1" / "archive", n_frames=20)  # what the glob a[1] would match
    frames = "SELECT max(frame) FROM tracks"
    assert main(["query", str(mine), frames]) == 0
    got = int(capsys.readouterr().out.splitlines()[2])
    assert got <= 8


# 3. the user's encodings: no files read, no code run, limits, one-line errors
@pytest.mark.parametrize(
    "option,text,expected",
    [
        ("--rules", '#include "other.lp".\n', "#include is not allowed"),
        ("--rules", "% a comment\n#script (python)\nimport os\n#end.\n", "rules.lp:2: #script"),
        ("--encoding", "q(X) :- not track(X).\n", "unsafe variables"),
        ("--rules", "q(X) :- not track(X).\n", "rules.lp:1:1"),
        ("--rules", "occurs(stops(T)) :- track(T)\n", "does not parse"),
        ("--rules", ":- not nope.\n", "UNSATISFIABLE"),
        ("--rules", ":- track(T).\n", "UNSATISFIABLE"),
        ("--confidence", '#include "other.lp".\n', "#include is not allowed"),
        ("--confidence", "confidence(E,C) :- said_hide(E,_,_).\n", "unsafe variables"),
        ("--situations", '#include "other.lp".\n', "#include is not allowed"),
        ("--situations", "warn(x,(T,)) :- not track(T).\n", "unsafe variables"),
        pytest.param("--situations", "p(1..100000000).\n", "limit", marks=pytest.mark.slow),
        pytest.param("--rules", "p(1..100000000).\n", "limit", marks=pytest.mark.slow),
    ],
)
def test_user_encodings_get_one_line_errors_and_limits(
    tmp_path: Path, capsys, option: str, text: str, expected: str
) -> None:
    det = write_det(tmp_path / "det.txt")
    (tmp_path / "other.lp").write_text("secret(84611597).\n")
    rules = tmp_path / "rules.lp"
    rules.write_text(text)
    out = tmp_path / "out.txt"
    argv = ["track", "--detections", str(det), "--format", "mot", "--output", str(out)]
    argv += [option, str(rules), "--timeout", "5", "--max-memory", "300"]
    if option == "--situations":
        argv += ["--warnings", str(tmp_path / "w.jsonl")]
    assert main(argv) == 2
    line = one_line_error(capsys)
    assert expected in line and "84611597" not in line
    assert not out.exists() and not list(tmp_path.glob("*.part"))


def test_the_api_checks_user_rules_too() -> None:
    from sensemaking.errors import InputError
    from sensemaking.tracker import Tracker

    with pytest.raises(InputError, match="#include is not allowed"):
        Tracker(rules='#include "x.lp".')
    with pytest.raises(InputError, match="UNSATISFIABLE"):
        Tracker(rules=":- not nope.")


def _track(tmp_path: Path, det: Path, *extra: str) -> int:
    return main(["-q", "track", "--detections", str(det), "--format", "mot", *extra])


# 4. outputs to anything but a regular file are written through, never replaced
def test_an_output_symlink_to_a_device_stays_a_symlink(tmp_path: Path) -> None:
    det = write_det(tmp_path / "det.txt")
    link = tmp_path / "out.txt"
    link.symlink_to("/dev/null")
    assert _track(tmp_path, det, "--output", str(link), "--events", str(link) + ".ev") == 0
    assert link.is_symlink() and os.readlink(link) == "/dev/null"


def test_an_output_symlink_to_a_file_keeps_the_link_and_fills_its_target(tmp_path: Path) -> None:
    det = write_det(tmp_path / "det.txt")
    target = tmp_path / "real.txt"
    target.write_text("old\n")
    link = tmp_path / "out.txt"
    link.symlink_to(target)
    assert _track(tmp_path, det, "--output", str(link)) == 0
    assert link.is_symlink() and len(target.read_text().splitlines()) == 30


def test_an_output_fifo_is_written_through(tmp_path: Path) -> None:
    import stat
    import threading

    det = write_det(tmp_path / "det.txt")
    fifo = tmp_path / "out.fifo"
    os.mkfifo(fifo)
    got: list[bytes] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()), daemon=True)
    reader.start()
    assert _track(tmp_path, det, "--output", str(fifo)) == 0
    reader.join(10)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    assert len(got[0].decode().splitlines()) == 30
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".part")]


def test_an_output_to_a_full_device_names_it(tmp_path: Path, capsys) -> None:
    import stat

    if not (os.path.exists("/dev/full") and stat.S_ISCHR(os.stat("/dev/full").st_mode)):
        pytest.skip("no /dev/full here")
    det = write_det(tmp_path / "det.txt")
    link = tmp_path / "full"  # through a link: a code that replaces outputs replaces the link
    link.symlink_to("/dev/full")
    assert _track(tmp_path, det, "--output", str(link)) == 2
    assert "full" in one_line_error(capsys)
    assert link.is_symlink() and stat.S_ISCHR(os.stat("/dev/full").st_mode)


# 5. stdin and pipes as --detections are read once
def test_detections_from_stdin_and_a_pipe_give_the_tracks_of_the_file(
    tmp_path: Path, monkeypatch
) -> None:
    import io
    import sys
    import threading

    det = write_det(tmp_path / "det.txt")
    assert _track(tmp_path, det, "--output", str(tmp_path / "file.txt")) == 0
    expected = (tmp_path / "file.txt").read_text()
    assert len(expected.splitlines()) == 30

    stdin = io.TextIOWrapper(io.BytesIO(det.read_bytes()))
    monkeypatch.setattr(sys, "stdin", stdin)
    assert (
        main(
            [
                "-q",
                "track",
                "--detections",
                "-",
                "--format",
                "mot",
                "--output",
                str(tmp_path / "stdin.txt"),
            ]
        )
        == 0
    )
    assert (tmp_path / "stdin.txt").read_text() == expected

    fifo = tmp_path / "det.fifo"
    os.mkfifo(fifo)
    writer = threading.Thread(target=lambda: fifo.write_bytes(det.read_bytes()), daemon=True)
    writer.start()
    assert _track(tmp_path, fifo, "--output", str(tmp_path / "fifo.txt")) == 0
    writer.join(10)
    assert (tmp_path / "fifo.txt").read_text() == expected


# 6. an output never overwrites an input or another output's .part; write errors name the file
def test_output_over_params_or_seqinfo_is_refused(tmp_path: Path, capsys) -> None:
    det = write_det(tmp_path / "seq" / "det" / "det.txt")
    seqinfo = tmp_path / "seq" / "seqinfo.ini"
    seqinfo.write_text(
        "[Sequence]\nname=seq\nframeRate=10\nseqLength=30\nimWidth=1000\nimHeight=500\n"
    )
    params = tmp_path / "params.json"
    params.write_text("{}\n")
    before = seqinfo.read_bytes(), params.read_bytes()
    assert _track(tmp_path, det, "--output", str(seqinfo)) == 2
    assert "seqinfo" in one_line_error(capsys)
    assert _track(tmp_path, det, "--output", str(params), "--params", str(params)) == 2
    assert "--params" in one_line_error(capsys)
    assert (seqinfo.read_bytes(), params.read_bytes()) == before


def test_an_output_named_like_the_warnings_part_is_refused(tmp_path: Path, capsys) -> None:
    det = write_det(tmp_path / "det.txt")
    w = tmp_path / "w.jsonl"
    assert _track(tmp_path, det, "--output", f"{w}.part", "--warnings", str(w)) == 2
    assert "--warnings is written" in one_line_error(capsys)


def test_a_write_error_names_the_file_and_leaves_no_part(tmp_path: Path) -> None:
    import subprocess
    import sys

    det = tmp_path / "det.txt"
    det.write_text(
        "".join(f"{f},-1,{100 + f % 300},100,40,80,0.9,-1,-1,-1\n" for f in range(1, 601))
    )
    script = (
        "import resource, sys; resource.setrlimit(resource.RLIMIT_FSIZE, (8192, 8192)); "
        "from sensemaking.cli import main; sys.exit(main(sys.argv[1:]))"
    )
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).parents[2] / "src")}
    out = tmp_path / "out"
    out.mkdir()
    proc = subprocess.run(
        [
            sys.executable,
            "-c",
            script,
            "-q",
            "track",
            "--detections",
            str(det),
            "--format",
            "mot",
            "--output",
            str(out / "t.txt"),
            "--events",
            str(out / "e.jsonl"),
            "--scene",
            str(out / "s.json"),
        ],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 2, proc.stderr
    lines = [x for x in proc.stderr.splitlines() if x.strip()]
    assert len(lines) == 1 and "File too large" in lines[0]
    assert any(
        str(out / n) in lines[0] or f"'{n}'" in lines[0] or n in lines[0]
        for n in ("t.txt", "e.jsonl", "s.json")
    )
    assert list(out.iterdir()) == []


# 10. benchmark on a folder without benchmarks exits 2 and writes nothing
def test_benchmark_on_an_empty_folder_writes_nothing(tmp_path: Path, capsys, monkeypatch) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    assert main(["benchmark", "--data", str(empty)]) == 2
    assert "no benchmark found" in one_line_error(capsys)
    assert list(work.rglob("*")) == [] and list(empty.iterdir()) == []


# 8. damaged archives: one-line errors, segments rebuilt, foreign versions refused
def _truncate(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def test_a_truncated_segment_is_one_line_and_rebuilt(tmp_path: Path, capsys) -> None:
    from sensemaking.fleet.archive import compact

    root = make_archive(tmp_path / "archive")
    assert compact(root) == 1
    seg = next((root / "_segments").glob("seg-*"))
    _truncate(seg / "tracks.parquet")
    code, _, err = _query(root, "SELECT count(*) FROM tracks", capsys)
    assert code == 2 and "damaged archive segment" in err and len(err.strip().splitlines()) == 1
    assert compact(root) == 1  # what batch runs at its end: the segment is made again
    code, out, _ = _query(root, "SELECT count(*) FROM tracks", capsys)
    assert code == 0 and int(out.splitlines()[2]) > 0


def test_a_truncated_sequence_file_is_one_line_and_run_again(tmp_path: Path, capsys) -> None:
    from sensemaking.fleet.archive import Archive
    from sensemaking.fleet.specs import read_manifest

    root = make_archive(tmp_path / "archive")
    tracks = next(root.glob("dataset=*/sequence=*/key=*/tracks.parquet"))
    _truncate(tracks)
    code, _, err = _query(root, "SELECT count(*) FROM tracks", capsys)
    assert code == 2 and "Traceback" not in err and len(err.strip().splitlines()) == 1
    spec = read_manifest(tmp_path / "archive-fleet" / "manifest.csv")[0]
    with Archive(root) as arc:
        assert arc.status(spec, "k1") is None  # the batch runs it again
    assert not tracks.exists()


def test_an_archive_of_an_unknown_version_is_refused(tmp_path: Path, capsys) -> None:
    root = make_archive(tmp_path / "archive")
    marker = root / "_fleet.json"
    marker.write_text(json.dumps({**json.loads(marker.read_text()), "version": 99}))
    code, _, err = _query(root, "SELECT count(*) FROM tracks", capsys)
    assert code == 2 and "archive version 99" in err


# 7. batch finds MOT sequences by their layout and names what it skips
def test_mot_sequences_are_found_by_layout_and_skips_are_named(tmp_path: Path) -> None:
    from sensemaking.fleet.specs import find_sequences

    info = "[Sequence]\nname={}\nframeRate=30\nseqLength=30\nimWidth=1920\nimHeight=1080\n"
    for name in ("MOT17-09-SDP", "MOT17-09-DPM", "MOT17-10-FRCNN"):
        write_det(tmp_path / "mot17" / name / "det" / "det.txt")
        (tmp_path / "mot17" / name / "seqinfo.ini").write_text(info.format(name))
    (tmp_path / "mot17" / "MOT17-11-SDP").mkdir()
    (tmp_path / "mot17" / "MOT17-11-SDP" / "seqinfo.ini").write_text(info.format("x"))
    specs, skipped = find_sequences([tmp_path])
    names = {s.sequence for s in specs}
    assert {"MOT17-09-SDP", "MOT17-09-DPM", "MOT17-10-FRCNN"} <= names
    assert len(specs) == len({(s.dataset, s.sequence) for s in specs})  # none twice
    assert any("MOT17-11-SDP" in m and "det/det.txt" in m for m in skipped)


# 11. user mistakes that were "internal error (a bug)" are one-line errors
def _make(tmp_path: Path, case: str) -> list[str]:
    det = write_det(tmp_path / "det.txt")
    base = [
        "track",
        "--detections",
        str(det),
        "--format",
        "mot",
        "--output",
        str(tmp_path / "out" / "o.txt"),
    ]
    warn = ["--warnings", str(tmp_path / "out" / "w.jsonl")]
    if case.startswith("lanes"):
        width = {"lanes-string": '"x"', "lanes-null": "null"}[case]
        lanes = tmp_path / "lanes.json"
        lanes.write_text(f'{{"lanes":[{{"id":1,"points":[[0,0],[10,10]],"width":{width}}}]}}')
        return base + warn + ["--lanes", str(lanes)]
    if case == "deep-params":
        params = tmp_path / "p.json"
        params.write_text("[" * 100_000 + "]" * 100_000)
        return base + ["--params", str(params)]
    if case == "empty-npy":
        import numpy as np

        np.save(tmp_path / "z.npy", np.zeros((0, 0), np.uint8))
        return base + warn + ["--segmentation", str(tmp_path / "z.npy")]
    if case == "symlink-loop":
        (tmp_path / "a.txt").symlink_to(tmp_path / "b.txt")
        (tmp_path / "b.txt").symlink_to(tmp_path / "a.txt")
        return [
            "track",
            "--detections",
            str(tmp_path / "a.txt"),
            "--format",
            "mot",
            "--output",
            str(tmp_path / "out" / "o.txt"),
        ]
    if case == "corrupt-onnx":
        pytest.importorskip("onnxruntime")
        (tmp_path / "m.onnx").write_bytes(bytes(range(256)) * 4)
        return [
            "track",
            "--source",
            str(det),
            "--detector",
            str(tmp_path / "m.onnx"),
            "--output",
            str(tmp_path / "out" / "o.txt"),
        ]
    if case == "events-1e400":
        gt = tmp_path / "gt.txt"
        gt.write_text("1,1,100,100,40,80,1,1,1.0\n")
        ev = tmp_path / "ev.jsonl"
        ev.write_text('{"frame": 1e400, "event": "starts", "args": [1]}\n')
        return [
            "evaluate",
            "--explanations",
            "--gt",
            str(gt),
            "--results",
            str(det),
            "--format",
            "mot",
            "--events",
            str(ev),
        ]
    raise AssertionError(case)


@pytest.mark.parametrize(
    "case",
    [
        "lanes-string",
        "lanes-null",
        "deep-params",
        "empty-npy",
        "symlink-loop",
        "corrupt-onnx",
        "events-1e400",
    ],
)
def test_user_mistakes_are_one_line_errors(tmp_path: Path, capsys, case: str) -> None:
    argv = _make(tmp_path, case)
    assert main(argv) == 2
    line = one_line_error(capsys)
    assert "internal error" not in line
    out = tmp_path / "out"
    assert not out.exists() or not list(out.iterdir())


def test_a_scene_with_a_vanishing_frame_rate_is_refused(scene_file: Path, capsys) -> None:
    record = json.loads(scene_file.read_text())
    record["fps"] = 1e-300
    scene_file.write_text(json.dumps(record))
    assert main(["explain", str(scene_file)]) == 2
    assert "fps" in one_line_error(capsys)


def test_a_scene_track_wrote_near_max_frame_loads_in_explain_ask_report(
    tmp_path: Path, capsys
) -> None:
    """A gap past SCENE_SPAN_FRAMES is not recorded as frames: the scene holds the frames
    stepped, so it loads and costs what its content costs; the recorder agrees with the file."""
    import tracemalloc

    import numpy as np

    from sensemaking.detections import MAX_FRAME
    from sensemaking.io.stream import iter_detection_frames
    from sensemaking.pipeline import Pipeline
    from sensemaking.scene import SCENE_SPAN_FRAMES, Scene, SceneRecorder
    from sensemaking.sinks import SceneSink
    from sensemaking.tracker import Tracker

    last = MAX_FRAME - 1
    det = tmp_path / "det.txt"
    det.write_text(f"1,-1,100,100,40,80,0.9,-1,-1,-1\n{last},-1,100,100,40,80,0.9,-1,-1,-1\n")
    scene = tmp_path / "s.json"
    out = tmp_path / "o.txt"
    argv = ["track", "--detections", str(det), "--format", "mot", "--output", str(out)]
    assert main([*argv, "--scene", str(scene)]) == 0
    tracemalloc.start()
    loaded = Scene.load(scene)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert (loaded.first_frame, loaded.last_frame) == (1, last)
    assert len(loaded) < 1_000 and peak < 10_000_000  # not one entry per frame of the span
    assert {t.last for t in loaded.tracks.values()} >= {last}
    capsys.readouterr()
    assert main(["explain", str(scene)]) == 0
    assert str(last) in capsys.readouterr().out
    assert main(["ask", str(scene), "q(F) :- frame(F). #show q/1."]) == 0
    assert f"q({last})" in capsys.readouterr().out
    assert main(["report", str(scene), "-o", str(tmp_path / "r.html")]) == 0
    # the in-memory recorder records the same frames as the file
    rec = SceneRecorder(fps=30.0)
    sink = SceneSink(tmp_path / "sink.json", fps=30.0)
    with Pipeline(Tracker(), recorder=rec, sinks=[sink]) as pipe:
        pipe.run(iter_detection_frames(det, "mot"), first_frame=1)
    from_sink = Scene.load(tmp_path / "sink.json")
    assert np.array_equal(rec.scene().frame_numbers, from_sink.frame_numbers)
    # within SCENE_SPAN_FRAMES the skipped gap is the scene's frames, as before
    near = SCENE_SPAN_FRAMES // 2
    det.write_text(f"1,-1,100,100,40,80,0.9,-1,-1,-1\n{near},-1,100,100,40,80,0.9,-1,-1,-1\n")
    assert main([*argv, "--scene", str(scene)]) == 0
    assert len(Scene.load(scene)) == near
    assert '"frame_numbers"' not in scene.read_text()


# 9. dense frames: a documented per-frame limit, refused before any square-sized array
def test_a_dense_frame_is_refused_with_its_line(tmp_path: Path, capsys) -> None:
    from sensemaking.detections import MAX_DETECTIONS_PER_FRAME as LIMIT

    det = tmp_path / "dense.txt"
    n = LIMIT + 500
    det.write_text(
        "".join(
            f"{f},-1,{(i % 100) * 10},{(i // 100) * 10},40,80,0.9,-1,-1,-1\n"
            for f in (1, 2)
            for i in range(n)
        )
    )
    out = tmp_path / "out.txt"
    assert main(["track", "--detections", str(det), "--format", "mot", "--output", str(out)]) == 2
    line = one_line_error(capsys)
    assert f"dense.txt:{LIMIT + 1}:" in line and "per-frame limit" in line
    assert not out.exists()


def test_the_api_refuses_a_dense_frame_too() -> None:
    import numpy as np

    from sensemaking.detections import MAX_DETECTIONS_PER_FRAME as LIMIT
    from sensemaking.errors import InputError
    from sensemaking.tracker import Tracker

    n = LIMIT + 1
    boxes = np.column_stack([np.arange(n) % 100 * 10.0, np.arange(n) // 100 * 10.0])
    xyxy = np.hstack([boxes, boxes + 40.0])
    tracker = Tracker()
    with pytest.raises(InputError, match="per-frame limit"):
        tracker.update(np.column_stack([xyxy, np.full(n, 0.9)]), frame=1)
    assert tracker.n_tracks == 0


def _grid(n: int, x0: float) -> np.ndarray:
    """(n, 5) boxes on a grid starting at ``x0``, 50 px apart, none overlapping another."""
    i = np.arange(n)
    xy = np.column_stack([x0 + i % 20 * 50.0, i // 20 * 50.0])
    return np.column_stack([xy, xy + 30.0, np.full(n, 0.9)])


def test_live_tracks_are_bounded_by_the_detections_of_the_last_frames() -> None:
    """The rules end a track unseen past its limit: live tracks <= the detections of the last
    max(max_hidden_frames, max_missing_frames) + 1 frames (what MAX_LIVE_TRACKS caps)."""
    from sensemaking.config import TrackerConfig
    from sensemaking.tracker import Tracker

    rng = np.random.default_rng(7)
    config = TrackerConfig(fps=10.0, max_hidden_s=0.5, max_missing_s=0.3)
    window = max(config.max_hidden_frames, config.max_missing_frames) + 1
    tracker = Tracker(config)
    counts: list[int] = []
    for f in range(1, 41):
        n = int(rng.integers(20, 60))
        xy = rng.uniform(0, 1000, size=(n, 2))
        boxes = np.column_stack([xy, xy + rng.uniform(20, 60, size=(n, 2)), np.full(n, 0.9)])
        tracker.update(boxes, frame=f)
        counts.append(n)
        assert 0 < tracker.n_tracks <= sum(counts[-window:])


def test_a_frame_past_the_live_track_limit_is_refused(tmp_path: Path, capsys, monkeypatch) -> None:
    import sensemaking.detections as detections
    from sensemaking.errors import InputError
    from sensemaking.tracker import Tracker

    monkeypatch.setattr(detections, "MAX_LIVE_TRACKS", 50)
    tracker = Tracker()
    tracker.update(_grid(40, 0.0), frame=1)
    tracker.update(_grid(40, 2000.0), frame=2)  # elsewhere: 40 new tracks, 40 kept unseen
    live = tracker.n_tracks
    assert live > 50
    with pytest.raises(InputError, match=f"frame 3: {live} live tracks.*limit of 50"):
        tracker.update(_grid(40, 0.0), frame=3)
    assert tracker.n_tracks == live and tracker.stats["frames"] == 2  # unchanged
    det = tmp_path / "dense.txt"
    det.write_text(
        "".join(
            f"{f},-1,{b[0]},{b[1]},30,30,0.9,-1,-1,-1\n"
            for f, x0 in ((1, 0.0), (2, 2000.0), (3, 0.0))
            for b in _grid(40, x0).tolist()
        )
    )
    out = tmp_path / "out.txt"
    assert main(["track", "--detections", str(det), "--format", "mot", "--output", str(out)]) == 2
    assert "dense.txt: frame 3: " in one_line_error(capsys)
    assert not out.exists()
