"""Fleet scale on this machine: ``sensemaking batch`` with 1 and 2 workers on the shared
benchmarks, and a batch of N synthetic sequences with the driver's memory and the named
queries' times.

    python benchmarks/fleet_scale.py workers [--data ../shared/data] [--repeat 2]
    python benchmarks/fleet_scale.py scale [--n 1000] [--frames 40] [--workers 2] [--keep]
    python benchmarks/fleet_scale.py queries ARCHIVE

``workers``: the whole batch command (Ray start included) into a fresh archive, 1 worker and
2 workers alternating ``--repeat`` times; prints each wall time, the medians and their ratio
(target: 2 workers <= 0.6x of 1 worker), and the load average (the machine is shared: other
processes take cores from the workers). ``scale``: writes N synthetic sequences and their
manifest, runs the batch in this process (so the driver's resident memory can be sampled over
the run), then times every named query (best of 5, each in a fresh DuckDB connection).
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def _schedule_bound(arc: Path) -> None:
    """From a 1-worker archive: the tasks' total and longest time, and the best 2-worker
    schedule of those same task times (longest first), i.e. the ratio 2 free cores could give."""
    from sensemaking.fleet.query import run_query

    secs = sorted((r[0] for r in run_query(arc, "SELECT seconds FROM runs").rows), reverse=True)
    loads = [0.0, 0.0]
    for t in secs:
        loads[loads.index(min(loads))] += t
    total = sum(secs)
    print(
        f"  1-worker tasks: {len(secs)}, {total:.1f} s in all, longest {secs[0]:.1f} s; "
        f"longest-first on 2 workers: {max(loads):.1f} s ({max(loads) / total:.2f} of the "
        "tasks' total)",
        flush=True,
    )


def workers(args: argparse.Namespace) -> None:
    data = Path(args.data).resolve()
    times: dict[int, list[float]] = {1: [], 2: []}
    with tempfile.TemporaryDirectory(prefix="fleet-workers-") as tmp:
        for rep in range(args.repeat):
            for n in (1, 2):
                arc = Path(tmp) / f"arc-{n}-{rep}"
                cmd = [
                    sys.executable,
                    "-m",
                    "sensemaking",
                    "-q",
                    "batch",
                    "--data",
                    str(data),
                    "--archive",
                    str(arc),
                    "--workers",
                    str(n),
                ]
                t0 = time.perf_counter()
                proc = subprocess.run(cmd, capture_output=True, text=True)
                wall = time.perf_counter() - t0
                if proc.returncode != 0:
                    sys.exit(f"batch failed ({proc.returncode}): {proc.stderr.strip()[-500:]}")
                times[n].append(wall)
                print(
                    f"repeat {rep + 1}: {n} worker{'s' if n > 1 else ' '} {wall:7.1f} s   "
                    f"(load average {_load()})",
                    flush=True,
                )
                if n == 1 and rep == 0:
                    _schedule_bound(arc)
                shutil.rmtree(arc)
    m1, m2 = statistics.median(times[1]), statistics.median(times[2])
    print(
        f"median: 1 worker {m1:.1f} s, 2 workers {m2:.1f} s, ratio {m2 / m1:.2f} (target <= 0.60)"
    )


def scale(args: argparse.Namespace) -> None:
    from sensemaking.fleet.batch import rss_mb, run_batch
    from sensemaking.fleet.specs import read_manifest
    from sensemaking.fleet.synthetic import write_synthetic_fleet

    tmp = Path(tempfile.mkdtemp(prefix="fleet-scale-"))
    try:
        t0 = time.perf_counter()
        manifest = write_synthetic_fleet(tmp / "fleet", args.n, n_frames=args.frames)
        specs = read_manifest(manifest)
        print(
            f"{args.n} synthetic sequences of {args.frames} frames written in "
            f"{time.perf_counter() - t0:.1f} s; driver RSS before the batch {rss_mb():.0f} MB"
        )
        arc = tmp / "archive"
        summary = run_batch(specs, arc, workers=args.workers)
        print(
            f"batch: {summary.archived} archived, {len(summary.failed)} failed in "
            f"{summary.seconds:.1f} s ({summary.seconds / max(args.n, 1) * 1000:.0f} ms per "
            f"sequence, {args.workers} workers; load average {_load()})"
        )
        print(
            f"  of which compacting {summary.compacted} folders into a segment: "
            f"{summary.compact_seconds:.1f} s; "
            f"driver RSS after it {summary.rss_after_compact_mb:.0f} MB"
        )
        samples = summary.rss_mb
        print(
            "driver RSS (sequences done: MB): "
            + ", ".join(f"{k}: {v:.0f}" for k, v in samples[:: max(1, len(samples) // 10)])
        )
        if samples:
            tail = [v for k, v in samples if k >= args.n // 10]
            print(
                f"driver RSS after 10 % of the batch: min {min(tail):.0f} MB, "
                f"max {max(tail):.0f} MB"
            )
        size = sum(p.stat().st_size for p in arc.rglob("*") if p.is_file())
        print(
            f"archive: {size / 1e6:.1f} MB in "
            f"{sum(1 for _ in arc.rglob('*.parquet'))} Parquet files"
        )
        time_queries(arc)
    finally:
        if args.keep:
            print(f"kept {tmp}")
        else:
            shutil.rmtree(tmp, ignore_errors=True)


def time_queries(arc: Path) -> None:
    """Best of 5 wall times of every named query, each with a fresh connection (views included)."""
    from sensemaking.fleet.query import NAMED_QUERIES, run_query

    for name in NAMED_QUERIES:
        qargs = [name, name] if name == "compare" else []  # no such run: the join itself is timed
        best = float("inf")
        for _ in range(5):
            t = time.perf_counter()
            res = run_query(arc, name, qargs)
            best = min(best, time.perf_counter() - t)
        print(f"query {name:22s} {best * 1000:7.0f} ms  ({len(res.rows)} rows)", flush=True)
    print(run_query(arc, "warnings-by-lead").format("table"))


def main() -> None:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    sub = p.add_subparsers(dest="what", required=True)
    w = sub.add_parser("workers", help="1 vs 2 workers on the shared benchmarks")
    default_data = Path(__file__).resolve().parents[1].parent / "shared" / "data"
    w.add_argument("--data", default=str(default_data))
    w.add_argument("--repeat", type=int, default=2)
    s = sub.add_parser("scale", help="N synthetic sequences: driver memory, query times")
    s.add_argument("--n", type=int, default=1000)
    s.add_argument("--frames", type=int, default=40)
    s.add_argument("--workers", type=int, default=2)
    s.add_argument("--keep", action="store_true", help="keep the archive (its path is printed)")
    q = sub.add_parser("queries", help="time the named queries on an existing archive")
    q.add_argument("archive", type=Path)
    args = p.parse_args()
    if args.what == "queries":
        time_queries(args.archive)
    else:
        workers(args) if args.what == "workers" else scale(args)


if __name__ == "__main__":
    main()
