"""Fleet faults across processes: the batch driver killed mid-run leaves an archive that a second
batch completes; a two-node Ray cluster on this machine writes the archive a single node writes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ray = pytest.importorskip("ray")
pq = pytest.importorskip("pyarrow.parquet")
pytest.importorskip("duckdb")

from sensemaking.fleet.archive import TABLES  # noqa: E402
from sensemaking.fleet.batch import run_batch  # noqa: E402
from sensemaking.fleet.specs import read_manifest  # noqa: E402
from sensemaking.fleet.synthetic import write_synthetic_fleet  # noqa: E402

#: columns that say when, where and by which process, not what
VOLATILE = {
    "runs": {"run_id", "host", "node_id", "worker_pid", "started", "ended", "seconds"},
    "metrics": {"seconds", "ms_per_frame", "solve_ms", "monitor_ms"},
}


def _published(root: Path) -> list[Path]:
    return sorted(root.glob("dataset=*/sequence=*/key=*"))


def _content(root: Path) -> dict[str, list[tuple]]:
    out = {}
    for table in TABLES:
        rows = []
        for f in sorted(root.glob(f"dataset=*/sequence=*/key=*/{table}.parquet")):
            for r in pq.read_table(f, partitioning=None).to_pylist():
                rows.append(
                    tuple((k, repr(v)) for k, v in r.items() if k not in VOLATILE.get(table, ()))
                )
        out[table] = sorted(rows)
    return out


@pytest.mark.slow
def test_driver_killed_mid_run_leaves_an_archive_a_second_batch_completes(tmp_path: Path) -> None:
    manifest = write_synthetic_fleet(tmp_path / "fleet", 10, n_frames=60)
    arc = tmp_path / "arc"
    cmd = [
        sys.executable,
        "-m",
        "sensemaking",
        "-q",
        "batch",
        "--data",
        str(manifest),
        "--archive",
        str(arc),
        "--workers",
        "1",
    ]
    driver = subprocess.Popen(
        cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True
    )
    try:
        deadline = time.monotonic() + 120
        while len(_published(arc)) < 2 and time.monotonic() < deadline and driver.poll() is None:
            time.sleep(0.05)
        assert driver.poll() is None, "the batch ended before it could be killed"
        # the driver and the local Ray it started (its process group), at once: nothing goes
        # on publishing after the kill, whatever the machine's load
        os.killpg(driver.pid, signal.SIGKILL)
        driver.wait(timeout=30)
    finally:
        if driver.poll() is None:
            driver.kill()
    time.sleep(1.0)  # the worker may publish the sequence it was running
    before = _published(arc)
    assert 2 <= len(before) < 10
    for d in before:  # every published folder is whole
        assert sorted(p.name for p in d.iterdir()) == sorted(
            [f"{t}.parquet" for t in TABLES] + ["_DONE.json"]
        )
    second = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert second.returncode == 0, second.stderr
    after = _published(arc)
    assert len(after) == 10 and set(before) <= set(after)
    runs = [
        r
        for f in arc.glob("dataset=*/sequence=*/key=*/runs.parquet")
        for r in pq.read_table(f, partitioning=None).to_pylist()
    ]
    assert (
        len(runs) == 10 and len({r["run_id"] for r in runs}) == 2
    )  # the first run's results kept
    assert not list((arc / "_staging").iterdir())


@pytest.mark.slow
def test_two_node_cluster_spreads_tasks_and_writes_the_single_node_archive(tmp_path: Path) -> None:
    from ray.cluster_utils import Cluster

    manifest = write_synthetic_fleet(tmp_path / "fleet", 6, n_frames=30)
    specs = read_manifest(manifest)
    cluster = Cluster(
        initialize_head=True,
        head_node_args={
            "num_cpus": 1,
            "include_dashboard": False,
            "object_store_memory": 100 * 2**20,
        },
    )
    try:
        cluster.add_node(num_cpus=1, object_store_memory=100 * 2**20)
        cluster.wait_for_nodes()
        multi = run_batch(specs, tmp_path / "multi", address=cluster.address, workers=2)
    finally:
        ray.shutdown()
        cluster.shutdown()
    assert multi.ok and multi.archived == 6
    assert len(multi.nodes) == 2 and all(n >= 1 for n in multi.nodes.values())
    single = run_batch(specs, tmp_path / "single", workers=1)
    assert single.ok and len(single.nodes) == 1
    a, b = _content(tmp_path / "multi"), _content(tmp_path / "single")
    assert all(a[t] for t in ("tracks", "events", "metrics", "runs"))
    assert a == b
