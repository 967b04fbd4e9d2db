"""Tests of the benchmark runner on a tiny fake data folder (same layout as ../shared/data)."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import load_benchmarks_script

from sensemaking.benchmark import datasets, peers, runner
from sensemaking.benchmark.peers import DISPLAY_NAMES, OursAdapter, PeerAdapter
from sensemaking.classes import CLASS_IDS
from sensemaking.cli import main
from sensemaking.detections import Detections
from sensemaking.errors import InputError, MissingExtraError

report = load_benchmarks_script("benchmark_report")

HAVE_TRACKERS = importlib.util.find_spec("trackers") is not None
needs_trackers = pytest.mark.skipif(
    not HAVE_TRACKERS, reason="needs the 'benchmark' extra (trackers)"
)

N_FRAMES = 12


def _objects(
    n_frames: int,
    starts: list[tuple[float, float, float, float]],
    velocity: list[tuple[float, float]],
):
    """Per object, (frame index, x1, y1, x2, y2) moving at constant velocity."""
    out = []
    for (x1, y1, w, h), (vx, vy) in zip(starts, velocity, strict=False):
        out.append(
            [
                (t, x1 + vx * t, y1 + vy * t, x1 + vx * t + w, y1 + vy * t + h)
                for t in range(n_frames)
            ]
        )
    return out


def make_fake_data(root: Path) -> Path:
    """KITTI (RRC car + pedestrian, no PointRCNN), one MOT17 YOLOX half-val and one MOT15
    sequence."""
    # -- KITTI: 2 cars, 1 pedestrian, one DontCare region, a van (distractor) ---------------------
    kitti = root / "kitti"
    (kitti / "training" / "label_02").mkdir(parents=True)
    (kitti / "training" / "seqinfo.csv").write_text(
        f"seq,num_frames,im_width,im_height,frame_rate\n0000,{N_FRAMES},1242,375,10\n"
    )
    cars = _objects(N_FRAMES, [(100, 150, 120, 80), (600, 160, 100, 70)], [(8, 0), (-6, 1)])
    peds = _objects(N_FRAMES, [(900, 140, 40, 100)], [(2, 0)])
    labels, rrc_car, rrc_ped = [], [], []
    tail = "1.5 1.6 4.0 1.0 1.5 20.0 0.1"
    for oid, track in enumerate(cars):
        for t, x1, y1, x2, y2 in track:
            labels.append(
                (t, f"{t} {oid} Car 0 0 -1.0 {x1:.2f} {y1:.2f} {x2:.2f} {y2:.2f} {tail}")
            )
            rrc_car.append((t, f"{t},{x1 + 1:.3f},{y1:.3f},{x2 + 1:.3f},{y2:.3f},0.9"))
    for oid, track in enumerate(peds, start=len(cars)):
        for t, x1, y1, x2, y2 in track:
            labels.append(
                (t, f"{t} {oid} Pedestrian 0 0 -1.0 {x1:.2f} {y1:.2f} {x2:.2f} {y2:.2f} {tail}")
            )
            rrc_ped.append((t, f"{t},{x1:.3f},{y1 + 1:.3f},{x2:.3f},{y2 + 1:.3f},0.8"))
    for t in range(N_FRAMES):
        labels.append(
            (t, f"{t} -1 DontCare -1 -1 -10 1100 150 1200 200 -1000 -1000 -1000 -10 -1 -1 -1")
        )
        rrc_car.append(
            (t, f"{t},1110.0,155.0,1190.0,195.0,0.4")
        )  # a false positive inside DontCare
    (kitti / "training" / "label_02" / "0000.txt").write_text(
        "\n".join(line for _, line in sorted(labels, key=lambda x: x[0])) + "\n"
    )
    for cls, rows in (("car", rrc_car), ("pedestrian", rrc_ped)):
        d = kitti / "detections" / "rrc" / cls
        d.mkdir(parents=True)
        (d / "0000.txt").write_text(
            "\n".join(line for _, line in sorted(rows, key=lambda x: x[0])) + "\n"
        )

    # -- MOTChallenge: MOT17 (9-column gt with class + flag) and MOT15 (10 columns) --------------
    people = _objects(
        N_FRAMES,
        [(100, 200, 50, 150), (400, 210, 55, 160), (800, 190, 60, 170)],
        [(5, 0), (-4, 0), (0, 2)],
    )
    for folder, gt_line in (
        ("mot17/MOT17-02-YOLOX-half", "{f},{i},{x},{y},{w},{h},1,1,1.0"),
        ("mot15/TUD-Campus", "{f},{i},{x},{y},{w},{h},1,-1,-1,-1"),
    ):
        seq = root / folder
        (seq / "det").mkdir(parents=True)
        (seq / "gt").mkdir()
        (seq / "seqinfo.ini").write_text(
            f"[Sequence]\nname={seq.name}\nimDir=img1\nframeRate=25\nseqLength={N_FRAMES}\n"
            "imWidth=1920\nimHeight=1080\nimExt=.jpg\n"
        )
        det, gt = [], []
        for t in range(N_FRAMES):
            for i, track in enumerate(people, start=1):
                _, x1, y1, x2, y2 = track[t]
                w, h = x2 - x1, y2 - y1
                det.append(f"{t + 1},-1,{x1 + 1:.1f},{y1:.1f},{w:.1f},{h:.1f},0.9,-1,-1,-1")
                gt.append(gt_line.format(f=t + 1, i=i, x=int(x1), y=int(y1), w=int(w), h=int(h)))
            det.append(f"{t + 1},-1,1500.0,100.0,40.0,90.0,0.05,-1,-1,-1")  # a weak false positive
        (seq / "det" / "det.txt").write_text("\n".join(det) + "\n")
        (seq / "gt" / "gt.txt").write_text("\n".join(gt) + "\n")
    return root


@pytest.fixture
def fake_data(tmp_path: Path) -> Path:
    return make_fake_data(tmp_path / "data")


def _tracker_available() -> bool:
    try:
        from sensemaking.tracker import Tracker, TrackerConfig  # noqa: F401
    except ImportError:
        return False
    return True


def _trackers_under_test() -> list[str]:
    names = []
    if _tracker_available():
        names += ["ours", "ours-noabd"]
    if HAVE_TRACKERS:
        names += ["sort", "bytetrack", "ocsort"]
    if not names:
        pytest.skip("neither our tracker nor the peers are importable")
    return names


# -----------------------------------------------------------------------------------------------
def test_discover_reports_missing_parts(fake_data: Path) -> None:
    found = datasets.discover(fake_data)
    assert found.names == ["kitti-rrc-car", "kitti-rrc-pedestrian", "mot17-yolox-halfval", "mot15"]
    skipped = " ".join(found.all_skipped())
    assert "kitti-pointrcnn-car" in skipped and "pointrcnn" in skipped
    assert "mot17-frcnn" in skipped
    # a sequence with its detection file missing is skipped, the benchmark still runs
    (fake_data / "kitti" / "training" / "label_02" / "0001.txt").write_text("")
    found = datasets.discover(fake_data, only=["kitti-rrc-car"])
    assert found.names == ["kitti-rrc-car"]
    assert any("0001" in m for m in found.skipped["kitti-rrc-car"])


def test_select_and_load(fake_data: Path) -> None:
    assert [s.name for s in datasets.select_specs(["kitti-rrc-*"])] == [
        "kitti-rrc-car",
        "kitti-rrc-pedestrian",
    ]
    assert [s.name for s in datasets.select_specs(["mot17"])] == [
        "mot17-yolox-halfval",
        "mot17-frcnn",
    ]
    with pytest.raises(InputError, match="unknown benchmark"):
        datasets.select_specs(["kitti-yolo-car"])
    with pytest.raises(InputError, match="not found"):
        datasets.discover(fake_data / "nope")
    benches = {b.name: b for b in datasets.iter_benchmarks(fake_data)}
    car = benches["kitti-rrc-car"].sequences[0]
    assert car.first_frame == 0 and list(car.frame_numbers) == list(range(N_FRAMES))
    assert set(car.detections.class_id.tolist()) == {CLASS_IDS["car"]}
    assert car.info.fps == 10 and (car.info.width, car.info.height) == (1242, 375)
    mot = benches["mot17-yolox-halfval"].sequences[0]
    assert mot.first_frame == 1 and list(mot.frame_numbers) == list(range(1, N_FRAMES + 1))
    assert set(mot.detections.class_id.tolist()) == {CLASS_IDS["pedestrian"]}
    assert benches["mot15"].rules == "mot15"


def test_parse_trackers() -> None:
    assert runner.parse_trackers(None)[:5] == ["ours", "ours-noabd", "sort", "bytetrack", "ocsort"]
    assert set(runner.parse_trackers(None)[5:]) == set(peers.BOXMOT_PEERS)
    assert runner.parse_trackers("ocsort,ours") == ["ours", "ocsort"]
    assert runner.parse_trackers(["OC-SORT", "byte"]) == ["bytetrack", "ocsort"]
    with pytest.raises(InputError, match="unknown tracker"):
        runner.parse_trackers("deepsort")


@needs_trackers
def test_peer_adapter_round_trip() -> None:
    boxes = np.array([[0, 0, 10, 20], [50, 50, 70, 90], [200, 10, 240, 60.5]], dtype=float)
    ped = CLASS_IDS["pedestrian"]
    peer = PeerAdapter(
        "sort", frame_rate=10, min_score=0.5, kwargs={"minimum_consecutive_frames": 1}
    )
    peer.reset()
    for f in range(3):
        dets = Detections(
            xyxy=boxes + f,
            confidence=[0.9, 0.2, 0.8],
            class_id=ped,
            frame=f,
            source_row=[10 * f + 1, 10 * f + 2, 10 * f + 3],
        )
        tracks, seconds = peer.update(dets, f)
        assert seconds >= 0
    # the 0.2 box was pre-filtered; the others keep their box, class, frame and source row
    assert len(tracks) == 2 and set(tracks.source_row.tolist()) == {21, 23}
    assert (
        np.all(tracks.frame == 2)
        and np.all(tracks.class_id == ped)
        and np.all(tracks.tracker_id >= 1)
    )
    np.testing.assert_array_equal(tracks.xyxy, (boxes + 2)[[0, 2]])
    empty, _ = peer.update(Detections(xyxy=np.zeros((0, 4))), 3)
    assert len(empty) == 0


def test_missing_extra_names_it(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "trackers", None)
    with pytest.raises(MissingExtraError, match=r"sensemaking\[benchmark\]"):
        PeerAdapter("sort")
    with pytest.raises(MissingExtraError, match="benchmark"):
        runner.run(data=".", trackers="sort", output=".")


def test_run_end_to_end_writes_tables(fake_data: Path, tmp_path: Path) -> None:
    names = _trackers_under_test()
    lines: list[str] = []
    summary = runner.run(
        data=fake_data,
        output=tmp_path / "out",
        trackers=names,
        progress=lines.append,
        command="sensemaking benchmark --data fake",
    )
    assert not summary.errors, summary.errors
    assert [b.spec.name for b in summary.benchmarks] == [
        "kitti-rrc-car",
        "kitti-rrc-pedestrian",
        "mot17-yolox-halfval",
        "mot15",
    ]
    assert any("skipped" in line and "pointrcnn" in line for line in lines)
    for b in summary.benchmarks:
        for name in names:
            run_ = b.chosen(name)
            assert run_ is not None and run_.error is None
            assert run_.frames == N_FRAMES and run_.update_seconds > 0
            assert (
                run_.result_dir is not None
                and (run_.result_dir / f"{b.sequences[0]}.txt").is_file()
            )
            # clean synthetic detections: every tracker should track them well
            assert run_.metrics["MOTA"] > 0.6, (b.spec.name, name, run_.metrics["MOTA"])
            assert (run_.legacy is not None) == (b.spec.rules == "kitti")
        if "ours" in names:
            assert b.time_ratio("ours") == pytest.approx(1.0)
    md_path, js_path = report.write_report(summary, tmp_path / "docs" / "BENCHMARKS.md")
    assert js_path == tmp_path / "docs" / "benchmarks.json"
    md = md_path.read_text()
    header = next(
        line for line in md.splitlines() if line.startswith("| Tracking |") and "(devkit)" in line
    )
    for col in (
        "MOTA",
        "MOTP",
        "ML",
        "MT",
        "FP",
        "FN",
        "ID sw.",
        "Frag.",
        "IDF1",
        "HOTA",
        "MOTA (devkit)",
        "ID sw. (devkit)",
        "ms/frame",
        "time ÷ ours",
    ):
        assert f"| {col} |" in header
    for bench in ("kitti-rrc-car", "kitti-rrc-pedestrian", "mot17-yolox-halfval", "mot15"):
        assert f"## {bench}" in md
    for name in names:
        label = DISPLAY_NAMES[name]
        rows = [
            line
            for line in md.splitlines()
            if line.startswith((f"| {label} |", f"| **{label}** |"))
        ]
        assert len(rows) == 4, (name, rows)  # one per benchmark
    assert md.count("*paper Table 2, with abduction*") == 2  # KITTI cars and pedestrians
    assert "sensemaking benchmark --data fake" in md and "Total run time" in md
    assert "kitti-pointrcnn-car" in md  # said what was skipped
    assert md.count("Per-frame update time, median / 95th percentile / slowest frame") == 4
    data = json.loads(js_path.read_text())
    assert data["command"] == "sensemaking benchmark --data fake" and data["machine"]["cores"] >= 1
    bench = data["benchmarks"][0]
    assert bench["name"] == "kitti-rrc-car" and set(bench["trackers"]) == set(names)
    for entry in bench["trackers"].values():
        chosen = entry["variants"][entry["chosen_variant"]]
        for key in (
            "HOTA",
            "MOTA",
            "MOTP",
            "IDF1",
            "IDSW",
            "Frag",
            "MT",
            "ML",
            "CLR_FP",
            "CLR_FN",
        ):
            assert key in chosen["metrics"]
        assert chosen["legacy"]["IDSW"] >= 0 and chosen["ms_per_frame"] > 0
        assert "0000" in chosen["per_sequence"]
    if HAVE_TRACKERS and _tracker_available():
        assert set(bench["trackers"]["sort"]["variants"]) == {"default", "prefilter"}
        assert set(bench["trackers"]["ours"]["variants"]) == {"visible", "predicted"}
    assert data["paper_table2"]["kitti-cars"]["rows"]["with abduction"]["MOTA"] == 50.5
    if HAVE_TRACKERS and _tracker_available():
        targets = md[md.index("## Targets") : md.index("## kitti-rrc-car")]
        assert targets.count("| kitti-rrc-car | ") == 9  # 4 vs ablation, 5 vs peers
        assert "The whole run took" in md


def test_cli_list_and_run(
    fake_data: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["benchmark", "--data", str(fake_data), "--list"]) == 0
    out = capsys.readouterr().out
    assert "kitti-rrc-car" in out and "skipped: kitti-pointrcnn-car" in out
    names = _trackers_under_test()[:1]
    code = main(
        [
            "benchmark",
            "--data",
            str(fake_data),
            "--output",
            str(tmp_path / "o"),
            "--only",
            "mot15",
            "--trackers",
            ",".join(names),
            "--no-crossval",
        ]
    )
    assert code == 0
    # the package's verb: an overview and every number as JSON, no docs
    assert "| [mot15](#mot15) |" in capsys.readouterr().out
    doc = json.loads((tmp_path / "o" / "benchmarks.json").read_text())
    assert "--only mot15" in doc["command"] and doc["units"]["HOTA"] == "fraction"
    assert "paper_table2" not in doc
    # the project's pages: benchmarks/benchmark_report.py, the same options
    docs = tmp_path / "d" / "B.md"
    code = report.main(
        [
            "--data",
            str(fake_data),
            "--output",
            str(tmp_path / "o2"),
            "--only",
            "mot15",
            "--trackers",
            ",".join(names),
            "--docs",
            str(docs),
        ]
    )
    assert code == 0
    assert docs.is_file() and (docs.parent / "benchmarks.json").is_file()
    assert "paper_table2" in json.loads((docs.parent / "benchmarks.json").read_text())
    text = docs.read_text()
    assert "## mot15" in text and "## kitti" not in text and "--only mot15" in text
    assert main(["benchmark", "--data", str(fake_data), "--only", "nope", "--list"]) == 2


@pytest.mark.slow
def test_jobs_run_benchmarks_in_worker_processes(fake_data: Path, tmp_path: Path) -> None:
    names = _trackers_under_test()[-1:]
    one = runner.run(
        data=fake_data, output=tmp_path / "a", only=["mot15", "mot17"], trackers=names
    )
    two = runner.run(
        data=fake_data, output=tmp_path / "b", only=["mot15", "mot17"], trackers=names, jobs=2
    )
    expected = ["mot17-yolox-halfval", "mot15"]
    assert (
        [b.spec.name for b in two.benchmarks] == [b.spec.name for b in one.benchmarks] == expected
    )
    for b1, b2 in zip(one.benchmarks, two.benchmarks, strict=False):
        assert b1.chosen(names[0]).metrics == b2.chosen(names[0]).metrics
    assert two.machine["jobs"] == 2


def test_repeat_keeps_the_results_and_the_fastest_times(
    fake_data: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    names = _trackers_under_test()[:1]
    one = runner.run(data=fake_data, output=tmp_path / "a", only=["mot15"], trackers=names)
    sizes: list[int] = []
    real = runner.run_sequence

    def timed(tracker, seq, frames=None):  # every run reports slower frames than the run before
        tracks, seconds = real(tracker, seq, frames)
        sizes.append(seconds.size)
        return tracks, np.full_like(seconds, 0.01 * len(sizes))

    monkeypatch.setattr(runner, "run_sequence", timed)
    three = runner.run(
        data=fake_data, output=tmp_path / "b", only=["mot15"], trackers=names, repeat=3
    )
    run1, run3 = one.benchmarks[0].chosen(names[0]), three.benchmarks[0].chosen(names[0])
    assert run1.metrics == run3.metrics
    n_seq = len(three.benchmarks[0].sequences)
    assert n_seq >= 1 and len(sizes) == 3 * n_seq
    # the first run of each sequence (calls 1, 4, 7, ...) was its fastest: its times count
    assert run3.update_seconds == pytest.approx(
        sum(0.01 * (3 * i + 1) * sizes[3 * i] for i in range(n_seq))
    )
    assert three.machine["repeat"] == 3
    with pytest.raises(InputError):
        runner.run(data=fake_data, output=tmp_path / "c", only=["mot15"], trackers=names, repeat=0)


def test_a_failing_tracker_is_reported_and_the_others_run(
    fake_data: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    real = runner._make_tracker
    made: list[str] = []

    def flaky(name, variant, spec, seq, min_score):
        made.append(name)
        if name == "ours-noabd":
            raise RuntimeError("boom")
        return real(name, variant, spec, seq, min_score)

    monkeypatch.setattr(runner, "_make_tracker", flaky)
    lines: list[str] = []
    summary = runner.run(
        data=fake_data,
        output=tmp_path / "out",
        only=["mot15"],
        trackers="ours,ours-noabd",
        progress=lines.append,
    )
    bench = summary.benchmarks[0]
    assert bench.chosen("ours-noabd").error == "RuntimeError: boom"
    assert made.count("ours-noabd") == 1 and made.count("ours") == len(bench.sequences)
    assert bench.chosen("ours").error is None and bench.chosen("ours").metrics
    assert summary.errors == ["mot15/ours-noabd/config: RuntimeError: boom"]
    assert any("FAILED" in line for line in lines)


def test_ours_adapter_filters_states() -> None:
    if not _tracker_available():
        pytest.skip("our tracker is not importable yet")
    cfg = runner.ours_config("kitti", fps=10, image_size=(1242, 375))
    adapter = OursAdapter("ours", cfg, states=(0,))
    adapter.reset()
    box = np.array([[100.0, 100.0, 200.0, 180.0]])
    car = CLASS_IDS["car"]
    for f in range(3):
        tracks, _ = adapter.update(
            Detections(xyxy=box + 5 * f, confidence=0.9, class_id=car, frame=f), f
        )
        assert len(tracks) == 1 and tracks.frame[0] == f
    tracks, _ = adapter.update(Detections(xyxy=np.zeros((0, 4))), 3)  # missed: not visible
    assert len(tracks) == 0


def test_pointrcnn_logits_reach_every_tracker_as_probabilities(fake_data: Path) -> None:
    d = fake_data / "kitti" / "detections" / "pointrcnn" / "car"
    d.mkdir(parents=True)
    tail = "1.5,1.6,4.0,1.0,1.5,20.0,0.1,0.2"
    d.joinpath("0000.txt").write_text(
        f"0,2,100,150,220,230,-2.0,{tail}\n1,2,108,150,228,230,0.0,{tail}\n"
        f"2,2,116,150,236,230,3.0,{tail}\n"
    )
    found = datasets.discover(fake_data, only=["kitti-pointrcnn-car"])
    bench = datasets.load_benchmark(*found.found[0])
    conf = bench.sequences[0].detections.confidence
    np.testing.assert_allclose(conf, 1 / (1 + np.exp(-np.array([-2.0, 0.0, 3.0]))))
    assert datasets.SPECS[0].logit_scores is False  # RRC scores are probabilities already


def _fake_run(metrics: dict[str, dict[str, float]], ms: dict[str, float]) -> runner.BenchmarkRun:
    b = runner.BenchmarkRun(datasets.SPECS[0], ["0000"], 100, [])
    for name, m in metrics.items():
        r = runner.TrackerRun(
            tracker=name, variant="visible" if name.startswith("ours") else "default", metrics=m
        )
        r.set_times(np.full(100, ms[name] / 1000))
        b.runs[name] = [r]
    return b


def test_check_targets_states_each_gap_with_its_size() -> None:
    m = {
        "ours": {"HOTA": 0.80, "MOTA": 0.900, "IDF1": 0.85, "IDSW": 10},
        "ours-noabd": {"HOTA": 0.79, "MOTA": 0.91, "IDF1": 0.84, "IDSW": 20},
        "sort": {"HOTA": 0.81, "MOTA": 0.904, "IDF1": 0.80, "IDSW": 12},
        "bytetrack": {"HOTA": 0.70, "MOTA": 0.80, "IDF1": 0.70, "IDSW": 9},
    }
    checks = {
        c.target: c
        for c in report.check_targets(
            _fake_run(m, {"ours": 3.0, "ours-noabd": 1.0, "sort": 1.0, "bytetrack": 2.0})
        )
    }
    assert checks["HOTA: with abduction > without"].met
    assert not checks["MOTA: with abduction > without"].met
    assert checks["MOTA: with abduction > without"].margin == pytest.approx(-1.0)
    hota = checks["HOTA: ahead of every peer"]
    assert not hota.met and hota.margin == pytest.approx(-1.0) and "SORT" in hota.detail
    assert checks["IDF1: ahead of every peer"].met
    assert checks["MOTA: at most 0.5 behind the best peer"].met  # 0.4 behind
    idsw = checks["ID switches: fewer than any peer"]
    assert not idsw.met and idsw.margin == -1 and "ByteTrack" in idsw.detail
    time = checks["time per frame: at most 2x the fastest peer"]
    assert not time.met and time.margin == pytest.approx(-1.0)
    cut = checks["cuts ID switches at least 3x (with vs without abduction)"]  # KITTI cars only
    assert (
        datasets.SPECS[0].class_name == "car" and not cut.met and cut.margin == pytest.approx(-1.0)
    )
    m["ours"]["IDSW"] = 6
    cut = {
        c.target: c
        for c in report.check_targets(
            _fake_run(m, {"ours": 3.0, "ours-noabd": 1.0, "sort": 1.0, "bytetrack": 2.0})
        )
    }[cut.target]
    assert cut.met and "6 vs 20 (3.3x)" in cut.detail
    mot = runner.BenchmarkRun(
        next(s for s in datasets.SPECS if s.family == "motchallenge"), ["x"], 100, []
    )
    mot.runs = _fake_run(m, {"ours": 3.0, "ours-noabd": 1.0, "sort": 1.0, "bytetrack": 2.0}).runs
    assert not any(c.target.startswith("cuts") for c in report.check_targets(mot))
    assert report.check_targets(_fake_run({"sort": m["sort"]}, {"sort": 1.0})) == []
