"""Issue 16's numbered defects, one test (or more) each: every one failed on the main branch
before the streaming pipeline, the output-path checks, safe queries and scene validation."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import REPO

from sensemaking.cli import main
from sensemaking.detections import Detections
from sensemaking.errors import InputError
from sensemaking.io.mot import read_mot
from sensemaking.synthetic import crossing_scene


def write_det(path: Path, n_frames: int = 30, frame_offset: int = 1) -> Path:
    """A small MOT det.txt: one box per frame moving right."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(
        "".join(
            f"{f + frame_offset},-1,{100 + 3 * f},100,40,80,0.9,-1,-1,-1\n"
            for f in range(n_frames)
        )
    )
    return path


def one_line_error(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err
    lines = [x for x in err.splitlines() if x.strip()]
    assert len(lines) == 1, err
    return lines[0]


# 1. input destroyed ------------------------------------------------------------------------------
@pytest.mark.parametrize("option", ["--output", "--events", "--scene", "--warnings"])
def test_an_output_naming_the_input_is_refused_and_the_input_kept(
    tmp_path: Path, capsys, option
) -> None:
    det = write_det(tmp_path / "d" / "det.txt")
    before = det.read_bytes()
    argv = [
        "track",
        "--detections",
        str(det),
        "--format",
        "mot",
        "--output",
        str(tmp_path / "o.txt"),
    ]
    argv += [option, str(det)] if option != "--output" else []
    if option == "--output":
        argv[-1] = str(det)
    assert main(argv) == 2
    assert "would overwrite the input --detections" in one_line_error(capsys)
    assert det.read_bytes() == before


def test_outputs_naming_the_same_file_are_refused(tmp_path: Path, capsys) -> None:
    det = write_det(tmp_path / "d" / "det.txt")
    same = tmp_path / "out.txt"
    assert (
        main(
            [
                "track",
                "--detections",
                str(det),
                "--format",
                "mot",
                "--output",
                str(same),
                "--events",
                str(same),
                "--scene",
                str(tmp_path / "s.json"),
            ]
        )
        == 2
    )
    assert "name the same file" in one_line_error(capsys)
    assert not same.exists() and not (tmp_path / "s.json").exists()


# 2. ask runs what it is given --------------------------------------------------------------------
@pytest.mark.parametrize(
    "query",
    [
        '#include "secret.lp". #show secret/1.',
        "#script (python)\nimport os\n#end.\nq :- track(_,_).",
        "#external e. q :- e.",
        "q(@f(1)).",
    ],
)
def test_ask_refuses_queries_that_reach_outside_the_scene(
    scene_file: Path, tmp_path: Path, capsys, query, monkeypatch
) -> None:
    (scene_file.parent / "secret.lp").write_text("secret(84611597).\n")
    monkeypatch.chdir(scene_file.parent)
    assert main(["ask", str(scene_file), query]) == 2
    line = one_line_error(capsys)
    assert "not allowed" in line and "84611597" not in line


def test_the_api_refuses_them_too(scene_file: Path) -> None:
    from sensemaking.reasoning.questions import QueryError, ask
    from sensemaking.scene import Scene

    with pytest.raises(QueryError, match="#include is not allowed"):
        ask(Scene.load(scene_file), '#include "x.lp". #show a/0.')
    # an allowed directive's name in a comment or a string is text; a forbidden one is refused
    # anywhere, as clingo's lexer and a text check may disagree on where a string ends (#24)
    answer = ask(
        Scene.load(scene_file), '% #count "x.lp"\nq(T, "#show") :- track(T, _). #show q/2.'
    )
    assert answer.atoms and all("#show" in a for a in answer.atoms)
    with pytest.raises(QueryError, match="#script is not allowed"):
        ask(Scene.load(scene_file), 'q(T, "#script") :- track(T, _). #show q/2.')


@pytest.mark.slow
def test_ask_stops_a_huge_grounding_at_its_limits(scene_file: Path, capsys) -> None:
    t0 = time.monotonic()
    assert (
        main(
            [
                "ask",
                str(scene_file),
                "--timeout",
                "2",
                "--max-memory",
                "400",
                "n(1..3200). p(X,Y) :- n(X), n(Y).",
            ]
        )
        == 2
    )
    assert time.monotonic() - t0 < 30
    line = one_line_error(capsys)
    assert "time limit" in line or "memory" in line
    assert main(["ask", str(scene_file), "--max-atoms", "1000", "n(1..5000)."]) == 2
    assert "more than the limit of 1000" in one_line_error(capsys)


def test_ask_streams_models_as_they_are_found(scene_file: Path, capsys) -> None:
    from sensemaking.reasoning.questions import ask
    from sensemaking.scene import Scene

    seen: list[tuple[str, ...]] = []
    answer = ask(Scene.load(scene_file), "{a;b;c}.", max_models=0, on_model=seen.append)
    assert len(seen) == 8 and tuple(seen) == answer.models
    assert main(["ask", str(scene_file), "--models", "0", "{a;b;c}."]) == 0
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 8 and out[0].startswith("answer 1:") and out[-1].startswith("answer 8:")


# 3. tiny inputs, huge work -----------------------------------------------------------------------
def test_a_frame_number_beyond_the_plausibility_bound_is_an_error(tmp_path: Path, capsys) -> None:
    det = tmp_path / "d" / "det.txt"
    det.parent.mkdir()
    det.write_text("1000000000,-1,10,10,40,80,0.9,-1,-1,-1\n")
    t0 = time.monotonic()
    assert (
        main(
            [
                "track",
                "--detections",
                str(det),
                "--format",
                "mot",
                "--output",
                str(tmp_path / "o.txt"),
            ]
        )
        == 2
    )
    assert time.monotonic() - t0 < 10
    line = one_line_error(capsys)
    assert f"{det}:1:" in line and "beyond the sequence" in line
    assert not (tmp_path / "o.txt").exists()


def test_a_frame_beyond_the_seqinfo_length_is_an_error(tmp_path: Path, capsys) -> None:
    det = write_det(tmp_path / "SEQ" / "det" / "det.txt", n_frames=30)
    (tmp_path / "SEQ" / "seqinfo.ini").write_text(
        "[Sequence]\nframeRate=10\nseqLength=20\nimWidth=640\nimHeight=480\n"
    )
    assert (
        main(
            [
                "track",
                "--detections",
                str(det),
                "--format",
                "mot",
                "--output",
                str(tmp_path / "o.txt"),
            ]
        )
        == 2
    )
    assert (
        f"{det}:21: frame 21 is beyond the sequence: the sequence has frames up to 20"
        in one_line_error(capsys)
    )


def test_a_long_gap_is_skipped_not_looped_over(tmp_path: Path) -> None:
    det = tmp_path / "d" / "det.txt"
    det.parent.mkdir()
    det.write_text(
        "1,-1,10,10,40,80,0.9,-1,-1,-1\n2,-1,12,10,40,80,0.9,-1,-1,-1\n"
        "9000000,-1,10,10,40,80,0.9,-1,-1,-1\n"
    )
    t0 = time.monotonic()
    assert (
        main(
            [
                "-q",
                "track",
                "--detections",
                str(det),
                "--format",
                "mot",
                "--output",
                str(tmp_path / "o.txt"),
                "--scene",
                str(tmp_path / "s.json"),
                "--set",
                "min_hits=2",  # so that the lone box after the gap stays tentative
            ]
        )
        == 0
    )
    assert time.monotonic() - t0 < 20
    assert set(read_mot(tmp_path / "o.txt", kind="results").frame.tolist()) == {
        1,
        2,
    }  # 9000000: tentative
    assert json.loads((tmp_path / "s.json").read_text())["frames"] == [1, 9000000]


def test_a_scene_asking_for_a_billion_frames_is_refused(
    scene_file: Path, tmp_path: Path, capsys
) -> None:
    record = json.loads(scene_file.read_text())
    record["frames"] = [1, 1_000_000_000]
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(record))
    for verb in (["explain", str(bad)], ["ask", str(bad), "tracks"]):
        assert main(verb) == 2
        assert "malformed scene" in one_line_error(capsys)


# 4. memory grows with the input; warnings only at the end ----------------------------------------
def test_warnings_are_written_while_the_run_goes_on_and_kept_on_interruption(
    tmp_path: Path, monkeypatch, capsys
) -> None:
    from sensemaking.reasoning import online
    from sensemaking.reasoning.situations import SituationWarning

    det = write_det(tmp_path / "d" / "det.txt", n_frames=40)
    warnings_path = tmp_path / "w.jsonl"
    seen_during_run: list[str] = []

    def update(self, result):
        parts = list(tmp_path.glob("w.jsonl.part"))
        if parts:
            seen_during_run.append(parts[0].read_text())
        if result.frame == 30:
            raise KeyboardInterrupt
        return [SituationWarning(int(result.frame), "TEST", (1,), f"frame {result.frame}", {})]

    monkeypatch.setattr(online.SituationMonitor, "update", update)
    assert (
        main(
            [
                "-q",
                "track",
                "--detections",
                str(det),
                "--format",
                "mot",
                "--output",
                str(tmp_path / "o.txt"),
                "--events",
                str(tmp_path / "e.jsonl"),
                "--warnings",
                str(warnings_path),
            ]
        )
        == 130
    )
    assert any('"frame": 5' in text for text in seen_during_run)  # flushed as issued
    kept = [json.loads(x) for x in warnings_path.read_text().splitlines()]
    assert [w["frame"] for w in kept] == list(range(1, 30))
    assert not (tmp_path / "o.txt").exists() and not (tmp_path / "e.jsonl").exists()
    assert not list(tmp_path.glob("*.part"))
    assert "interrupted after frame 29" in capsys.readouterr().err


# 5. tracebacks instead of errors -----------------------------------------------------------------
@pytest.mark.parametrize(
    "case",
    [
        "output_dir",
        "scene_dir",
        "events_dir",
        "parent_is_file",
        "fps_nan",
        "fps_zero",
        "fps_huge_seqinfo",
        "max_solve_neg",
        "max_solve_nan",
        "max_solve_zero",
        "set_abc",
    ],
)
def test_bad_options_get_one_line_and_exit_2_before_any_work(tmp_path: Path, capsys, case) -> None:
    det = write_det(tmp_path / "SEQ" / "det" / "det.txt")
    out = tmp_path / "o.txt"
    extra: list[str] = []
    (tmp_path / "adir").mkdir()
    (tmp_path / "afile").write_text("x")
    if case == "output_dir":
        out = tmp_path / "adir"
    elif case == "scene_dir":
        extra = ["--scene", str(tmp_path / "adir")]
    elif case == "events_dir":
        extra = ["--events", str(tmp_path / "adir")]
    elif case == "parent_is_file":
        out = tmp_path / "afile" / "o.txt"
    elif case == "fps_nan":
        extra = ["--fps", "nan"]
    elif case == "fps_zero":
        extra = ["--fps", "0"]
    elif case == "fps_huge_seqinfo":
        (tmp_path / "SEQ" / "seqinfo.ini").write_text(
            "[Sequence]\nframeRate=1e300\nseqLength=30\nimWidth=640\nimHeight=480\n"
        )
    elif case.startswith("max_solve"):
        extra = [
            "--max-solve-ms",
            {"max_solve_neg": "-1", "max_solve_nan": "nan", "max_solve_zero": "0"}[case],
        ]
    elif case == "set_abc":
        extra = ["--set", "max_hidden_s=abc"]
    code = main(
        ["track", "--detections", str(det), "--format", "mot", "--output", str(out)] + extra
    )
    assert code == 2
    one_line_error(capsys)
    assert not (tmp_path / "o.txt").exists()
    assert not list(tmp_path.rglob("*.part"))


def test_evaluate_json_to_a_directory_is_one_line(tmp_path: Path, capsys) -> None:
    gt = tmp_path / "gt.txt"
    gt.write_text("1,1,10,10,40,80,1,1,1\n")
    res = tmp_path / "res.txt"
    res.write_text("1,1,10,10,40,80,1,-1,-1,-1\n")
    (tmp_path / "adir").mkdir()
    code = main(
        [
            "evaluate",
            "--gt",
            str(gt),
            "--results",
            str(res),
            "--format",
            "mot",
            "--json",
            str(tmp_path / "adir"),
        ]
    )
    assert code == 2
    assert "--json is a directory" in one_line_error(capsys)


def test_render_and_report_on_a_scene_with_a_nan_box_are_one_line(
    scene_file: Path, tmp_path: Path, capsys
) -> None:
    text = scene_file.read_text()
    record = json.loads(text)
    record["tracks"][0]["boxes"][0][0] = float("nan")
    bad = tmp_path / "nan.json"
    bad.write_text(json.dumps(record))  # json writes NaN
    for argv in (
        ["render", str(bad), "-o", str(tmp_path / "r.gif")],
        ["report", str(bad), "-o", str(tmp_path / "r.html")],
    ):
        assert main(argv) == 2
        assert "finite" in one_line_error(capsys)
        assert not (tmp_path / "r.gif").exists() and not (tmp_path / "r.html").exists()


# 6. silent misconfiguration ----------------------------------------------------------------------
def test_class_without_a_kitti_type_fails_before_the_run(tmp_path: Path, capsys) -> None:
    det = tmp_path / "car" / "0001.txt"
    det.parent.mkdir()
    det.write_text("0,10,10,50,90,0.9\n1,12,10,52,90,0.9\n")
    assert (
        main(
            [
                "track",
                "--detections",
                str(det),
                "--format",
                "kitti",
                "--class",
                "crowd",
                "--output",
                str(tmp_path / "o.txt"),
            ]
        )
        == 2
    )
    assert "--class crowd: KITTI results have no type" in one_line_error(capsys)


def test_a_missing_seqinfo_is_named_as_missing(tmp_path: Path, capsys) -> None:
    det = tmp_path / "car" / "0001.txt"
    det.parent.mkdir()
    det.write_text("0,10,10,50,90,0.9\n")
    for fmt in ("kitti", "mot"):
        assert (
            main(
                [
                    "track",
                    "--detections",
                    str(det),
                    "--format",
                    fmt,
                    "--seqinfo",
                    str(tmp_path / "none.csv"),
                    "--output",
                    str(tmp_path / "o.txt"),
                ]
            )
            == 2
        )
        assert "seqinfo file not found" in one_line_error(capsys)


# 7. implausible values accepted ------------------------------------------------------------------
def test_absurd_coordinates_are_refused_with_their_line(tmp_path: Path, capsys) -> None:
    det = write_det(tmp_path / "d" / "det.txt", n_frames=5)
    with det.open("a") as fh:
        fh.write("6,-1,1e300,10,1e308,80,0.9,-1,-1,-1\n")
    assert (
        main(
            [
                "track",
                "--detections",
                str(det),
                "--format",
                "mot",
                "--output",
                str(tmp_path / "o.txt"),
            ]
        )
        == 2
    )
    assert f"{det}:6:" in one_line_error(capsys)


def test_empty_files_are_treated_alike_in_both_formats(tmp_path: Path, caplog) -> None:
    """An empty detection file is a sequence where the detector found nothing (KITTI has such
    files): empty results and a warning, in both formats (before: KITTI exit 0, MOT exit 2)."""
    for fmt, name in (("mot", "det.txt"), ("kitti", "car/0001.txt")):
        det = tmp_path / fmt / name
        det.parent.mkdir(parents=True)
        det.write_text("")
        out = tmp_path / f"{fmt}.txt"
        argv = ["track", "--detections", str(det), "--format", fmt, "--output", str(out)]
        assert main(argv) == 0
        assert out.read_text() == ""
        assert any(
            "no detections in file" in r.getMessage() and str(det) in r.getMessage()
            for r in caplog.records
        )


@pytest.mark.parametrize(
    "dets",
    [
        Detections(xyxy=[[10, 10, 5, 50]]),  # inverted
        Detections(xyxy=[[10, 10, 50, 50]], confidence=[float("nan")]),
        Detections(xyxy=[[10, 10, 50, 50]], class_id=[-5]),
        Detections(xyxy=[[float("nan"), 10, 50, 50]]),
        Detections(xyxy=[[0, 0, 1e300, 50]]),
    ],
)
def test_the_api_validates_like_the_cli_and_a_refused_frame_changes_nothing(dets) -> None:
    from sensemaking.detections import validate_detections
    from sensemaking.pipeline import Pipeline
    from sensemaking.tracker import Tracker, TrackerConfig

    with pytest.raises(InputError):
        validate_detections(dets, (640, 480))
    tracker = Tracker(TrackerConfig(fps=10, image_size=(640, 480)))
    pipe = Pipeline(tracker)
    pipe.step(1, Detections(xyxy=[[100, 100, 140, 180]], confidence=[0.9], class_id=[1]))
    with pytest.raises(ValueError):
        pipe.step(2, dets)
    # the retry with good detections goes on as if the bad frame had never come
    again = pipe.step(2, Detections(xyxy=[[102, 100, 142, 180]], confidence=[0.9], class_id=[1]))
    assert again.result.frame == 2 and len(again.result.visible) == 1


# 8. SIGTERM --------------------------------------------------------------------------------------
@pytest.mark.slow
def test_sigterm_leaves_no_part_files_and_says_so(tmp_path: Path) -> None:
    det = write_det(tmp_path / "d" / "det.txt", n_frames=20000)
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"))
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "sensemaking",
            "-q",
            "track",
            "--detections",
            str(det),
            "--format",
            "mot",
            "--output",
            str(tmp_path / "o.txt"),
            "--events",
            str(tmp_path / "e.jsonl"),
            "--scene",
            str(tmp_path / "s.json"),
        ],
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    deadline = time.monotonic() + 60
    while not list(tmp_path.glob(".e.jsonl.*.part")) and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.3)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143
    assert "terminated" in err and "Traceback" not in err
    assert not list(tmp_path.glob("*.part")) and not (tmp_path / "o.txt").exists()


def test_same_run_same_bytes_with_the_streaming_pipeline(tmp_path: Path) -> None:
    """The streaming run writes what the whole-file writers write: results read back equal the
    Pipeline's frame results."""
    from sensemaking.io.mot import write_mot
    from sensemaking.tracker import Tracker

    scene = crossing_scene(0, gap=12, far_speed=8.0)
    seq = tmp_path / "X"
    (seq / "det").mkdir(parents=True)
    d = scene.detections
    lines = [
        f"{d.frame[i] + 1},-1,{x:.2f},{y:.2f},{w:.2f},{h:.2f},{d.confidence[i]:.3f},-1,-1,-1"
        for i, (x, y, w, h) in zip(
            np.argsort(d.frame, kind="stable"),
            d.xywh[np.argsort(d.frame, kind="stable")],
            strict=False,
        )
    ]
    (seq / "det" / "det.txt").write_text("\n".join(lines) + "\n")
    assert (
        main(
            [
                "-q",
                "track",
                "--detections",
                str(seq / "det" / "det.txt"),
                "--format",
                "mot",
                "--fps",
                "10",
                "--image-size",
                "1242x375",
                "--output",
                str(tmp_path / "stream.txt"),
            ]
        )
        == 0
    )
    import argparse

    from sensemaking.cli.track import tracker_config

    args = argparse.Namespace(format="mot", no_abduction=False, max_solve_ms=None, params=[])
    tracker = Tracker(tracker_config(args, 10.0, (1242, 375)))
    dets = read_mot(seq / "det" / "det.txt", kind="det")
    by_frame = dict(dets.frames())
    out = [
        tracker.update(by_frame.get(f, Detections.empty()), frame=f).visible
        for f in range(1, int(dets.frame.max()) + 1)
    ]
    write_mot(tmp_path / "whole.txt", Detections.concatenate(out))
    assert (tmp_path / "stream.txt").read_bytes() == (tmp_path / "whole.txt").read_bytes()


# 9. a wall-clock budget makes results depend on load, and nothing said so ------------------------
def test_the_wall_clock_budget_says_results_depend_on_load(capsys) -> None:
    with pytest.raises(SystemExit):
        main(["track", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "--max-solve-ms" in text and "depend on the machine's load" in text
    readme = " ".join((REPO / "README.md").read_text().split())
    assert "results then depend on the machine's load" in readme


def test_an_output_reaching_the_input_through_a_link_is_refused(tmp_path: Path, capsys) -> None:
    det = write_det(tmp_path / "d" / "det.txt")
    before = det.read_bytes()
    (tmp_path / "sym.txt").symlink_to(det)
    os.link(det, tmp_path / "hard.txt")
    for link in ("sym.txt", "hard.txt"):
        argv = [
            "track",
            "--detections",
            str(det),
            "--format",
            "mot",
            "--output",
            str(tmp_path / link),
        ]
        assert main(argv) == 2
        assert "would overwrite the input" in one_line_error(capsys)
    assert det.read_bytes() == before


def test_argument_errors_are_one_line_too(capsys) -> None:
    for argv in (
        ["track", "--detections", "x", "--format", "mot", "--output", "y", "--fps", "abc"],
        ["track"],
        ["ask"],
        ["nonsense-verb"],
    ):
        with pytest.raises(SystemExit) as exc:
            main(argv)
        assert exc.value.code == 2
        assert "error:" in one_line_error(capsys)


def test_render_frames_beyond_the_scene_ask_for_no_work(
    scene_file: Path, tmp_path: Path, capsys
) -> None:
    pytest.importorskip("PIL")
    out = tmp_path / "r.gif"
    t0 = time.monotonic()
    assert (
        main(
            [
                "-q",
                "render",
                str(scene_file),
                "-o",
                str(out),
                "--frames",
                "0:1000000000",
                "--no-warnings",
                "--scale",
                "0.2",
            ]
        )
        == 0
    )
    assert time.monotonic() - t0 < 30 and out.exists()
    assert (
        main(["render", str(scene_file), "-o", str(tmp_path / "x.gif"), "--frames", "5000:6000"])
        == 2
    )
    assert "none of them in that range" in one_line_error(capsys)


def test_evaluate_refuses_a_billion_frame_ground_truth_before_allocating(
    tmp_path: Path, capsys
) -> None:
    gt, res = tmp_path / "gt.txt", tmp_path / "res.txt"
    gt.write_text("1,1,10,10,40,80,1,1,1\n1000000000,1,10,10,40,80,1,1,1\n")
    res.write_text("1,1,10,10,40,80,1,-1,-1,-1\n")
    assert main(["evaluate", "--gt", str(gt), "--results", str(res), "--format", "mot"]) == 2
    assert f"{gt}:2: frame 1000000000 is beyond the plausibility bound" in one_line_error(capsys)


def test_report_and_render_do_not_overwrite_their_inputs(
    scene_file: Path, tmp_path: Path, capsys
) -> None:
    pytest.importorskip("PIL")
    before = scene_file.read_bytes()
    assert main(["report", str(scene_file), "-o", str(scene_file)]) == 2
    assert "would overwrite the input SCENE" in one_line_error(capsys)
    frames = tmp_path / "frames"
    frames.mkdir()
    (frames / "000000.png").write_bytes(b"not really a png")
    assert main(["render", str(scene_file), "-o", str(frames) + "/", "--images", str(frames)]) == 2
    assert "would write over the input --images" in one_line_error(capsys)
    assert scene_file.read_bytes() == before
    assert (frames / "000000.png").read_bytes() == b"not really a png"


# JSON nested deeper than Python's reader goes: every reader names its file -------------------
@pytest.mark.parametrize("reader", ["params", "lanes", "scene"])
def test_json_nested_too_deeply_is_one_line_naming_the_file(
    tmp_path: Path, capsys, reader: str
) -> None:
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000 + "\n")
    det = write_det(tmp_path / "d" / "det.txt")
    track = ["track", "--detections", str(det), "--format", "mot"]
    out = ["--output", str(tmp_path / "o.txt")]
    argv = {
        "params": [*track, "--params", str(deep), *out],
        "lanes": [*track, "--warnings", str(tmp_path / "w.jsonl"), "--lanes", str(deep), *out],
        "scene": ["ask", str(deep), "tracks"],
    }[reader]
    assert main(argv) == 2
    line = one_line_error(capsys)
    assert str(deep) in line and "nested too deeply" in line, line
    assert not (tmp_path / "o.txt").exists()


def test_event_logs_and_class_tables_nested_too_deeply_name_their_file(tmp_path: Path) -> None:
    from sensemaking.records import read_events
    from sensemaking.ros.reader import ClassTable

    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000 + "\n")
    for read in (read_events, ClassTable.parse):
        with pytest.raises(InputError, match="nested too deeply") as err:
            read(str(deep))
        assert str(deep) in str(err.value)
