"""Fleet: batch on Ray into the Parquet archive, idempotent re-runs, failures, a worker killed
mid-sequence, queries, and ask/explain from the archive. One local Ray session (2 CPUs) for the
module."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA

ray = pytest.importorskip("ray")
pq = pytest.importorskip("pyarrow.parquet")
pytest.importorskip("duckdb")

from sensemaking.cli import main  # noqa: E402
from sensemaking.errors import InputError  # noqa: E402
from sensemaking.fleet.archive import TABLES, load_scene  # noqa: E402
from sensemaking.fleet.batch import run_batch  # noqa: E402
from sensemaking.fleet.query import NAMED_QUERIES, run_query  # noqa: E402
from sensemaking.fleet.run import RunParams, run_sequence  # noqa: E402
from sensemaking.fleet.specs import find_sequences, read_manifest  # noqa: E402
from sensemaking.fleet.synthetic import write_synthetic_fleet  # noqa: E402


@pytest.fixture(scope="module")
def ray_local():
    ray.init(
        num_cpus=2,
        include_dashboard=False,
        configure_logging=False,
        log_to_driver=False,
        object_store_memory=100 * 2**20,
    )
    yield
    ray.shutdown()


@pytest.fixture(scope="module")
def fleet(tmp_path_factory) -> Path:
    """A manifest of 4 synthetic sequences (car, pedestrian, cyclist, car)."""
    return write_synthetic_fleet(tmp_path_factory.mktemp("fleet"), 4, n_frames=30)


def _dirs(root: Path) -> list[Path]:
    return sorted(root.glob("dataset=*/sequence=*/key=*"))


def _rows(root: Path, table: str) -> list[dict]:
    files = sorted(root.glob(f"dataset=*/sequence=*/key=*/{table}.parquet"))
    return [r for f in files for r in pq.read_table(f, partitioning=None).to_pylist()]


@pytest.mark.slow
def test_batch_archives_every_table_then_skips_then_forces(
    ray_local, fleet: Path, tmp_path: Path
) -> None:
    arc = tmp_path / "arc"
    specs = read_manifest(fleet)
    seen: list[str] = []
    first = run_batch(specs, arc, workers=2, progress=lambda info: seen.append(info["status"]))
    assert (first.archived, first.skipped, first.failed) == (4, 0, []) and seen == ["ok"] * 4
    dirs = _dirs(arc)
    assert len(dirs) == 4 and not list((arc / "_staging").iterdir())
    for d in dirs:
        assert sorted(p.name for p in d.iterdir()) == sorted(
            [f"{t}.parquet" for t in TABLES] + ["_DONE.json"]
        )
    for table in TABLES:
        rows = _rows(arc, table)
        assert {(r["dataset"], r["sequence"]) for r in rows} <= {
            ("synthetic", s.sequence) for s in specs
        }
        assert all(r["class"] in ("car", "pedestrian", "cyclist") for r in rows)
    # the archive holds what the tracker produced, every box (visible and hidden)
    direct = run_sequence(specs[0])
    tracks = [r for r in _rows(arc, "tracks") if r["sequence"] == specs[0].sequence]
    assert len(tracks) == sum(len(t) for t in direct.scene.tracks.values())
    assert {r["state"] for r in tracks} >= {"visible"}
    events = [r for r in _rows(arc, "events") if r["sequence"] == specs[0].sequence]
    assert [(r["frame"], r["event"]) for r in events] == [(e.frame, e.name) for e in direct.events]
    metrics = {r["sequence"]: r for r in _rows(arc, "metrics")}
    assert metrics[specs[0].sequence]["HOTA"] == pytest.approx(direct.metrics["HOTA"])
    done_times = [(d / "_DONE.json").stat().st_mtime_ns for d in dirs]

    again = run_batch(specs, arc, workers=2)
    assert (again.archived, again.skipped) == (0, 4)
    assert (
        _dirs(arc) == dirs and [(d / "_DONE.json").stat().st_mtime_ns for d in dirs] == done_times
    )

    forced = run_batch(specs, arc, workers=2, force=True)
    assert (forced.archived, forced.skipped) == (4, 0)
    assert _dirs(arc) == dirs  # same keys, replaced: one copy each
    # the segment written by the first batch holds the replaced folders: queries read them once
    assert first.compacted == 4 and again.compacted == 0 and forced.compacted == 4
    assert len(list((arc / "_segments").iterdir())) == 2
    assert run_query(arc, "SELECT count(*) FROM tracks").rows == [(len(_rows(arc, "tracks")),)]
    assert run_query(arc, f"SELECT count(*) FROM runs WHERE run_id = '{forced.run_id}'").rows == [
        (4,)
    ]
    runs = _rows(arc, "runs")
    assert len(runs) == 4 and {r["run_id"] for r in runs} == {forced.run_id}
    assert all(json.loads(r["inputs"])["det"] and r["clingo_version"] for r in runs)

    # other parameters: archived beside, and the two runs compare
    ablation = run_batch(specs, arc, RunParams(abduction=False), workers=2, label="noabd")
    assert ablation.archived == 4 and len(_dirs(arc)) == 8
    compared = run_query(arc, "compare", [runs[0]["params_id"], "noabd"])
    assert compared.columns[:3] == ["dataset", "sequence", "HOTA_a"] and len(compared.rows) == 4
    across = run_query(arc, "metrics-across-runs")
    assert len(across.rows) == 8


@pytest.mark.slow
def test_bad_sequence_is_archived_as_failed_and_the_others_go_on(
    ray_local, fleet: Path, tmp_path: Path
) -> None:
    bad = tmp_path / "bad.txt"
    bad.write_text("this is not a detections file\n")
    manifest = tmp_path / "manifest.csv"
    good = read_manifest(fleet)[1]
    manifest.write_text(
        "dataset,sequence,path,format,class\n"
        f"mixed,good,{good.det_path},mot,pedestrian\nmixed,bad,bad.txt,mot,car\n"
    )
    specs, _ = find_sequences([manifest])
    arc = tmp_path / "arc"
    summary = run_batch(specs, arc, workers=2)
    assert summary.archived == 1 and not summary.ok
    ((dataset, sequence, error),) = summary.failed
    assert (dataset, sequence) == ("mixed", "bad") and "bad.txt" in error
    runs = {r["sequence"]: r for r in _rows(arc, "runs")}
    assert runs["bad"]["status"] == "failed" and "bad.txt" in runs["bad"]["error"]
    assert runs["good"]["status"] == "ok" and runs["good"]["error"] is None
    (failed_dir,) = (arc / "dataset=mixed" / "sequence=bad").glob("key=*")
    assert sorted(p.name for p in failed_dir.iterdir()) == ["_DONE.json", "runs.parquet"]
    statuses = {(row[1], row[4]) for row in run_query(arc, "sequences").rows}
    assert statuses == {("good", "ok"), ("bad", "failed")}
    # a failed sequence is tried again by the next batch (its input may have been mended); the
    # command's exit status says that not all succeeded
    assert main(["-q", "batch", "--data", str(manifest), "--archive", str(arc)]) == 1
    runs = {r["sequence"]: r for r in _rows(arc, "runs")}
    assert runs["good"]["run_id"] == summary.run_id and runs["bad"]["run_id"] != summary.run_id


@pytest.mark.slow
def test_worker_killed_mid_sequence_is_retried_and_archived_once(
    ray_local, fleet: Path, tmp_path: Path
) -> None:
    marker = tmp_path / "killed-once"
    arc = tmp_path / "arc"

    def dies_once(spec, root, params, key, sums, run_id, label):
        """The first attempt kills its own worker process after writing 2 of the 5 tables."""
        import os
        import signal

        from sensemaking.fleet import archive as arc_mod

        if spec.sequence == "000002" and not marker.exists():
            marker.write_text(str(os.getpid()))
            real, written = arc_mod._write, []

            def write_then_die(table, columns, path):
                real(table, columns, path)
                written.append(table)
                if len(written) == 2:
                    os.kill(os.getpid(), signal.SIGKILL)

            arc_mod._write = write_then_die
        return arc_mod.archive_sequence(spec, root, params, key, sums, run_id, label)

    specs = read_manifest(fleet)
    summary = run_batch(specs, arc, workers=2, task=dies_once)
    assert marker.exists(), "the fault was not injected"
    assert summary.ok and summary.archived == 4
    assert len(list((arc / "dataset=synthetic" / "sequence=000002").glob("key=*"))) == 1
    direct = run_sequence(specs[2])
    tracks = [r for r in _rows(arc, "tracks") if r["sequence"] == "000002"]
    assert len(tracks) == sum(len(t) for t in direct.scene.tracks.values())
    runs = [r for r in _rows(arc, "runs") if r["sequence"] == "000002"]
    assert len(runs) == 1 and runs[0]["worker_pid"] != int(marker.read_text())
    # the killed attempt's half-written folder is left in _staging, never published
    assert len(list((arc / "_staging").iterdir())) == 1


@pytest.mark.slow
def test_scene_from_archive_equals_the_recorded_scene(
    ray_local, fleet: Path, tmp_path: Path
) -> None:
    specs = read_manifest(fleet)[:1]
    arc = tmp_path / "arc"
    run_batch(specs, arc, workers=1)
    got = load_scene(arc, "synthetic", specs[0].sequence)
    want = run_sequence(specs[0]).scene
    assert list(got.tracks) == list(want.tracks) and got.events == want.events
    assert (
        np.array_equal(got.frame_numbers, want.frame_numbers) and got.image_size == want.image_size
    )
    for tid, t in want.tracks.items():
        g = got.tracks[tid]
        assert g.class_id == t.class_id and np.array_equal(g.frames, t.frames)
        assert np.array_equal(g.xyxy, t.xyxy) and np.array_equal(g.state, t.state)
        assert np.array_equal(g.occluder, t.occluder) and np.array_equal(
            g.visibility, t.visibility
        )
    with pytest.raises(InputError, match="no successful result"):
        load_scene(arc, "synthetic", "nope")


@pytest.mark.slow
def test_queries_answer_and_fail_cleanly(ray_local, fleet: Path, tmp_path: Path) -> None:
    arc = tmp_path / "arc"
    run_batch(read_manifest(fleet), arc, workers=2)
    n_tracks = len(_rows(arc, "tracks"))
    res = run_query(arc, "SELECT count(*) AS n FROM tracks")
    assert res.rows == [(n_tracks,)]
    for name, q in NAMED_QUERIES.items():
        if all(d is not None for _, d in q.args):
            assert run_query(arc, name).columns, name
    by_lead = run_query(arc, "warnings-by-lead")
    assert sum(r[by_lead.columns.index("warnings")] for r in by_lead.rows) == len(
        _rows(arc, "warnings")
    )
    assert json.loads(res.format("json")) == [{"n": n_tracks}]
    assert res.format("csv") == f"n\n{n_tracks}\n"
    with pytest.raises(InputError, match="query failed"):
        run_query(arc, "SELECT nonsense FROM tracks")
    with pytest.raises(InputError, match="usage: compare"):
        run_query(arc, "compare", ["only-one"])
    with pytest.raises(InputError, match="not a sensemaking archive"):
        run_query(tmp_path, "sequences")


@pytest.mark.slow
def test_cli_batch_query_ask_explain(ray_local, fleet: Path, tmp_path: Path, capsys) -> None:
    arc = tmp_path / "arc"
    assert (
        main(
            [
                "-q",
                "batch",
                "--data",
                str(fleet),
                "--archive",
                str(arc),
                "--workers",
                "2",
                "--only",
                "synthetic/00000[01]",
            ]
        )
        == 0
    )
    assert len(_dirs(arc)) == 2
    assert main(["query", str(arc), "sequences", "--format", "csv"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("dataset,sequence,class,run,status") and len(out) == 3
    assert (
        main(["explain", "--archive", str(arc), "--sequence", "synthetic/000000", "--json"]) == 0
    )
    stories = json.loads(capsys.readouterr().out)
    scene = load_scene(arc, "synthetic", "000000")
    assert sorted(int(k) for k in stories) == sorted(scene.tracks)
    first = min(scene.tracks)
    assert (
        main(
            [
                "ask",
                "--archive",
                str(arc),
                "--sequence",
                "synthetic/000000",
                f"q(T) :- track(T,_), T = {first}. #show q/1.",
            ]
        )
        == 0
    )
    assert capsys.readouterr().out.strip() == f"q({first})"
    # bad input: one line, exit status 2, nothing written
    assert (
        main(["batch", "--data", str(tmp_path / "missing"), "--archive", str(tmp_path / "a2")])
        == 2
    )
    assert (
        main(["batch", "--data", str(fleet), "--archive", str(tmp_path / "a3"), "--workers", "0"])
        == 2
    )
    assert main(["query", str(tmp_path), "sequences"]) == 2
    nobody = ["--address", "127.0.0.1:9", "--archive", str(tmp_path / "a4")]
    assert main(["batch", "--data", str(fleet), *nobody]) == 2
    assert main(["explain", "--archive", str(arc), "--sequence", "nodataset"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("error:") == 5
    assert not any((tmp_path / a).exists() for a in ("a2", "a3", "a4"))


def test_manifest_errors_name_file_and_line(tmp_path: Path) -> None:
    m = tmp_path / "manifest.csv"
    m.write_text("path,format,fps\nx.txt,mot,ten\n")
    with pytest.raises(InputError, match=r"manifest.csv:2: column 'fps': not a number"):
        read_manifest(m)
    m.write_text("path,format,gt\nx.txt,mot,gt.txt\n")
    with pytest.raises(InputError, match="'rules' is needed"):
        read_manifest(m)
    m.write_text("path,format\n" + "x" * 200_000 + ",mot\n")  # over the csv module's field limit
    with pytest.raises(InputError, match="manifest.csv:2: not a valid CSV file"):
        read_manifest(m)
    m.write_text("path,colour\nx.txt,red\n")
    with pytest.raises(InputError, match="format"):
        read_manifest(m)


@pytest.mark.integration
@pytest.mark.skipif(not (SHARED_DATA / "kitti").is_dir(), reason="needs ../shared/data")
@pytest.mark.slow
def test_readme_lines_on_a_few_shared_sequences(ray_local, tmp_path: Path, capsys) -> None:
    """The README's two lines, restricted to three sequences."""
    arc = tmp_path / "archive"
    assert (
        main(
            [
                "-q",
                "batch",
                "--data",
                str(SHARED_DATA),
                "--archive",
                str(arc),
                "--only",
                "kitti-rrc-car/000[56]",
                "--only",
                "mot15/TUD-Campus",
            ]
        )
        == 0
    )
    assert main(["query", str(arc), "metrics-across-runs", "--format", "json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert {(r["dataset"], r["sequence"]) for r in rows} == {
        ("kitti-rrc-car", "0005"),
        ("kitti-rrc-car", "0006"),
        ("mot15", "TUD-Campus"),
    }
    assert all(30 < r["HOTA"] <= 100 for r in rows)


def test_a_huge_stated_length_does_not_make_work(fleet: Path, tmp_path: Path) -> None:
    """Work is bounded by the files: frames past the content only while a track can live on."""
    det = read_manifest(fleet)[0].det_path
    m = tmp_path / "manifest.csv"
    m.write_text(f"path,format,class,fps,frames\n{det},mot,car,10,1000000000\n")
    spec = read_manifest(m)[0]
    result = run_sequence(spec)
    from sensemaking.tracker import TrackerConfig

    config = TrackerConfig.for_dataset("mot", fps=10.0)
    from sensemaking.io.formats import read_detections

    last_det = int(read_detections(det, "mot").frame.max())
    horizon = config.max_hidden_frames + config.max_missing_frames + 1
    assert last_det < result.scene.last_frame <= last_det + horizon
    assert not result.scene.tracks or max(t.last for t in result.scene.tracks.values()) < (
        result.scene.last_frame
    )
