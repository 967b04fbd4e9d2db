"""The batch driver: every sequence a Ray task that writes its own folder of the archive.

The driver holds no results: each task publishes its sequence's Parquet files itself and returns
a summary of a few fields; at most ``max_in_flight`` tasks are submitted at a time
(``ray.wait``), so the driver's memory does not grow with the number of sequences. Sequences
already archived with the same result key are skipped (``force`` redoes them); a sequence whose
run fails is archived as failed with its error, and the others go on. A worker process that
dies is retried by Ray (``max_retries``); its half-written folder stays in ``_staging`` and
is never published. At the end the new folders are compacted into one segment of the
archive (a few files for queries to read instead of five per sequence).
"""

from __future__ import annotations

import contextlib
import datetime as dt
import logging
import os
import socket
import time
import uuid
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sensemaking.errors import InputError, require
from sensemaking.fleet.archive import Archive, archive_sequence, compact, result_key
from sensemaking.fleet.run import RunParams
from sensemaking.fleet.specs import SequenceSpec, input_checksums

__all__ = ["BatchSummary", "run_batch", "RaySession", "rss_mb"]

log = logging.getLogger(__name__)

#: tasks in flight per worker: one running, one queued so the worker never waits for the driver
IN_FLIGHT_PER_WORKER = 2


def rss_mb() -> float:
    """The resident memory of this process, MB (Linux /proc; 0 elsewhere)."""
    try:
        with open("/proc/self/statm") as fh:
            return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6
    except (OSError, ValueError, IndexError):
        return 0.0


@dataclass
class BatchSummary:
    """What a batch did.

    Attributes:
        run_id: this batch's id (in the ``runs`` table). total: sequences given.
        archived: sequences run and archived ok. skipped: already archived with the same key.
        failed: ``(dataset, sequence, error)`` of each sequence that failed.
        seconds: wall time. nodes: Ray node id -> sequences run there.
        rss_mb: ``(sequences finished, driver resident memory in MB)`` sampled over the run.
        compacted, compact_seconds: folders copied into a new segment at the end, and the time
            it took (:func:`~sensemaking.fleet.archive.compact`); rss_after_compact_mb: the
            driver's resident memory after it.
    """

    run_id: str
    total: int = 0
    archived: int = 0
    skipped: int = 0
    failed: list[tuple[str, str, str]] = field(default_factory=list)
    seconds: float = 0.0
    nodes: Counter = field(default_factory=Counter)
    rss_mb: list[tuple[int, float]] = field(default_factory=list)
    compacted: int = 0
    compact_seconds: float = 0.0
    rss_after_compact_mb: float = 0.0

    @property
    def ok(self) -> bool:
        return not self.failed


def _task(
    spec: SequenceSpec,
    root: str,
    params: RunParams,
    key: str,
    checksums: dict[str, str],
    run_id: str,
    label: str | None,
) -> dict[str, Any]:
    """The Ray task: one sequence into the archive (runs in a worker process)."""
    import ray

    node = ray.get_runtime_context().get_node_id()
    return archive_sequence(spec, root, params, key, checksums, run_id, label, node_id=node)


def check_address(address: str, timeout_s: float = 5.0) -> None:
    """Fail fast when nothing listens at a cluster address (``ray.init`` would wait minutes).

    Raises:
        InputError: ``address`` is not ``host:port`` (or ``ray://host:port``), or no connection.
    """
    if address == "auto":
        return
    hostport = address.split("://", 1)[-1]
    host, sep, port = hostport.rpartition(":")
    if not sep or not host or not port.isdigit():
        raise InputError(f"--address must be host:port or ray://host:port, got {address!r}")
    try:
        with socket.create_connection((host, int(port)), timeout=timeout_s):
            pass
    except OSError as exc:
        raise InputError(f"cannot reach the Ray cluster at {address}: {exc}") from None


class RaySession:
    """``with RaySession(workers, address):`` connects to Ray: the running session if there is
    one, the cluster at ``address``, else a new local Ray with ``workers`` CPUs (no dashboard);
    shuts down only what it started."""

    def __init__(self, workers: int | None = None, address: str | None = None):
        self.workers = workers
        self.address = address
        self._started = False

    def __enter__(self) -> Any:
        ray = require("ray", "fleet")
        if not ray.is_initialized():
            common = {
                "include_dashboard": False,
                "configure_logging": False,
                "log_to_driver": False,
                "logging_level": logging.WARNING,
            }
            if self.address:
                try:
                    ray.init(address=self.address, **common)
                except (ConnectionError, ValueError, RuntimeError) as exc:
                    raise InputError(
                        f"cannot join the Ray cluster at {self.address}: {exc}"
                    ) from None
            else:
                ray.init(num_cpus=self.workers or os.cpu_count() or 1, **common)
            self._started = True
        return ray

    def __exit__(self, *exc: object) -> None:
        if self._started:
            require("ray", "fleet").shutdown()


def run_batch(
    specs: Iterable[SequenceSpec],
    archive: str | Path,
    params: RunParams | None = None,
    *,
    workers: int | None = None,
    address: str | None = None,
    force: bool = False,
    label: str | None = None,
    max_retries: int = 3,
    progress: Callable[[dict[str, Any]], None] | None = None,
    task: Callable[..., dict[str, Any]] | None = None,
) -> BatchSummary:
    """Track every sequence of ``specs`` into ``archive`` on Ray.

    Args:
        specs: the sequences (run longest first, by detection file size).
        archive: the archive folder (created when missing).
        params: the parameters for every sequence (default: each family's set).
        workers: sequences run at once (local Ray: its CPUs; default all cores; with
            ``address``: tasks in flight, default twice the cluster's CPUs).
        address: a Ray cluster to join (``ray://...`` or ``host:port``); None starts a local Ray
            (or uses the session already running in this process).
        force: redo sequences already archived with the same key.
        label: a name for this parameter set, stored in ``runs.label`` (for comparing runs).
        max_retries: times Ray reruns a task whose worker process died.
        progress: called with each finished sequence's summary (``status`` ``ok``, ``failed``
            or ``skipped``).
        task: the Ray task function (tests inject faults here); default runs and archives.

    Raises:
        InputError: the archive cannot be used, or Ray cannot be reached.
    """
    params = params or RunParams()
    if workers is not None and workers < 1:
        raise InputError(f"--workers must be >= 1, got {workers}")
    if address:
        check_address(address)
    ordered = sorted(specs, key=lambda s: -s.cost)
    run_id = dt.datetime.now(dt.UTC).strftime("%Y%m%dT%H%M%SZ-") + uuid.uuid4().hex[:6]
    summary = BatchSummary(run_id, total=len(ordered))
    t0 = time.perf_counter()
    sample_every = max(1, len(ordered) // 50)
    with Archive(archive) as arc, contextlib.ExitStack() as stack:
        root = str(arc.root.resolve())
        finished = 0

        def done(info: dict[str, Any]) -> None:
            nonlocal finished
            finished += 1
            if finished % sample_every == 0 or finished == summary.total:
                summary.rss_mb.append((finished, round(rss_mb(), 1)))
            if progress is not None:
                progress(info)

        # the skip check first: a batch with nothing to do starts no Ray
        todo: list[tuple[SequenceSpec, str, dict[str, str]]] = []
        for spec in ordered:
            sums = input_checksums(spec)
            key = result_key(spec, sums, params)
            if not force and arc.status(spec, key) == "ok":
                summary.skipped += 1
                info = {"dataset": spec.dataset, "sequence": spec.sequence, "key": key}
                done({**info, "status": "skipped", "error": None})
            else:
                todo.append((spec, key, sums))
        if todo:
            ray = stack.enter_context(RaySession(workers, address))
            remote = ray.remote(task or _task).options(
                num_cpus=1, max_retries=max_retries, retry_exceptions=False
            )
            if workers is not None:
                limit = workers * (1 if address else IN_FLIGHT_PER_WORKER)
            else:
                cpus = int(ray.cluster_resources().get("CPU", 1))
                limit = IN_FLIGHT_PER_WORKER * max(1, cpus)
        pending: dict[Any, tuple[SequenceSpec, str, dict[str, str]]] = {}

        def collect(ready: list[Any]) -> None:
            for ref in ready:
                spec, key, sums = pending.pop(ref)
                try:
                    info = ray.get(ref)
                except Exception as exc:  # noqa: BLE001 - the task died beyond its retries
                    error = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
                    info = archive_sequence(
                        spec, root, params, key, sums, run_id, label, failed=error
                    )
                if info["status"] == "ok":
                    summary.archived += 1
                    summary.nodes[info.get("node_id")] += 1
                else:
                    summary.failed.append((spec.dataset, spec.sequence, str(info["error"])))
                done(info)

        for item in todo:
            while len(pending) >= limit:
                ready, _ = ray.wait(list(pending), num_returns=1)
                collect(ready)
            spec, key, sums = item
            pending[remote.remote(spec, root, params, key, sums, run_id, label)] = item
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            collect(ready)
        t1 = time.perf_counter()
        summary.compacted = compact(arc.root)
        summary.compact_seconds = time.perf_counter() - t1
        summary.rss_after_compact_mb = round(rss_mb(), 1)
    summary.seconds = time.perf_counter() - t0
    return summary
