"""The fleet archive: one folder of Parquet files per sequence and result key.

Layout (``docs/FLEET.md`` documents every column)::

    ARCHIVE/_fleet.json                               marks the folder as an archive
    ARCHIVE/.lock                                     held (flock) by the batch writing it
    ARCHIVE/_staging/                                 work in progress; emptied when a batch starts
    ARCHIVE/dataset=D/sequence=S/key=K/{tracks,events,warnings,metrics,runs}.parquet
    ARCHIVE/dataset=D/sequence=S/key=K/_DONE.json     status, key, run id: written last

``K`` is :func:`result_key`: input checksums, the sequence's facts, the parameters and the
software version. A sequence's folder is written whole in ``_staging`` and renamed into place:
it appears with all its files or not at all, and a task that runs twice (a retried worker)
leaves one copy. A sequence whose run failed has only ``runs.parquet`` (status ``failed`` and
the error) and its ``_DONE.json``.
"""

from __future__ import annotations

import datetime as dt
import fcntl
import functools
import hashlib
import json
import logging
import os
import platform
import shutil
import socket
import time
import uuid
from collections.abc import Iterator, Sequence
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from sensemaking.errors import TOO_DEEP, InputError, SensemakingError, require
from sensemaking.fleet.specs import SequenceSpec
from sensemaking.io.text import load_json, read_input_text

if TYPE_CHECKING:  # pragma: no cover
    from sensemaking.fleet.run import RunParams, SequenceResult
    from sensemaking.scene import Scene

__all__ = [
    "ARCHIVE_FORMAT",
    "TABLES",
    "Archive",
    "archive_sequence",
    "load_scene",
    "result_key",
    "sequence_dirs",
    "schemas",
]

log = logging.getLogger(__name__)

ARCHIVE_FORMAT = "sensemaking.fleet-archive"
ARCHIVE_VERSION = 1
#: the archive's tables, one Parquet file each per sequence folder
TABLES = ("tracks", "events", "warnings", "metrics", "runs")
DONE = "_DONE.json"
STAGING = "_staging"


def _pa():
    return require("pyarrow", "fleet")


@functools.cache
def schemas() -> dict[str, Any]:
    """Table name -> ``pyarrow.Schema``; the first four columns of every table are
    ``dataset, sequence, class, key``."""
    pa = _pa()
    head = [
        ("dataset", pa.string()),
        ("sequence", pa.string()),
        ("class", pa.string()),
        ("key", pa.string()),
    ]
    i64, f64, s = pa.int64(), pa.float64(), pa.string()
    from sensemaking.evaluation import PER_SEQUENCE_FIELDS as metric_fields

    return {
        "tracks": pa.schema(
            head
            + [
                ("frame", i64),
                ("track_id", i64),
                ("class_id", i64),
                ("object_class", s),
                ("x1", f64),
                ("y1", f64),
                ("x2", f64),
                ("y2", f64),
                ("confidence", f64),
                ("state", s),
                ("occluder", i64),
                ("visibility", s),
                ("hidden_frames", i64),
            ]
        ),
        "events": pa.schema(
            head
            + [
                ("frame", i64),
                ("time_s", f64),
                ("event", s),
                ("track_id", i64),
                ("other_id", i64),
                ("track_class", s),
                ("other_class", s),
            ]
        ),
        "warnings": pa.schema(
            head
            + [
                ("frame", i64),
                ("time_s", f64),
                ("situation", s),
                ("track_id", i64),
                ("other_id", i64),
                ("track_class", s),
                ("other_class", s),
                ("objects", pa.list_(i64)),
                ("lead_frames", i64),
                ("lead_s", f64),
                ("message", s),
                ("details", s),
            ]
        ),
        "metrics": pa.schema(
            head
            + [
                ("rules", s),
                ("frames", i64),
                ("detections", i64),
                ("tracks", i64),
                ("events", i64),
                ("warnings", i64),
                ("seconds", f64),
                ("ms_per_frame", f64),
                ("solve_ms", f64),
                ("monitor_ms", f64),
            ]
            + [(m, f64) for m in metric_fields]
        ),
        "runs": pa.schema(
            head
            + [
                ("status", s),
                ("error", s),
                ("run_id", s),
                ("label", s),
                ("params_id", s),
                ("params", s),
                ("tracker_config", s),
                ("inputs", s),
                ("det_path", s),
                ("gt_path", s),
                ("format", s),
                ("fps", f64),
                ("width", i64),
                ("height", i64),
                ("first_frame", i64),
                ("last_frame", i64),
                ("software_version", s),
                ("clingo_version", s),
                ("python_version", s),
                ("host", s),
                ("node_id", s),
                ("worker_pid", i64),
                ("started", pa.timestamp("us", tz="UTC")),
                ("ended", pa.timestamp("us", tz="UTC")),
                ("seconds", f64),
            ]
        ),
    }


def params_id(params: RunParams) -> str:
    """12 hex digits naming a parameter set (with the software version)."""
    from sensemaking import __version__

    text = json.dumps({"params": params.to_json(), "version": __version__}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def result_key(spec: SequenceSpec, checksums: dict[str, str], params: RunParams) -> str:
    """16 hex digits: what a sequence's results depend on (inputs' bytes, the sequence's facts,
    the parameters, the software version); not the file paths."""
    facts = {
        k: v
        for k, v in asdict(spec).items()
        if k not in ("det_path", "gt_path", "dataset", "sequence")
    }
    text = json.dumps(
        {"inputs": checksums, "facts": facts, "params": params_id(params)},
        sort_keys=True,
        default=list,
    )
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def sequence_dirs(root: str | Path, dataset: str, sequence: str) -> Path:
    return Path(root) / f"dataset={dataset}" / f"sequence={sequence}"


def check_marker(root: Path) -> None:
    """Refuse a folder whose ``_fleet.json`` is not this format and version (a newer or a
    foreign archive would be misread)."""
    marker = root / "_fleet.json"
    try:
        info = load_json(read_input_text(marker))
    except InputError:
        raise
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(
            f"unreadable archive marker: {' '.join(str(exc).split())}", marker
        ) from None
    except RecursionError:
        raise InputError(TOO_DEEP, marker) from None
    if not isinstance(info, dict) or info.get("format") != ARCHIVE_FORMAT:
        raise InputError(f"not a sensemaking archive marker (format {ARCHIVE_FORMAT!r})", marker)
    if info.get("version") != ARCHIVE_VERSION:
        raise InputError(
            f"archive version {info.get('version')!r}; this sensemaking reads version "
            f"{ARCHIVE_VERSION}",
            marker,
        )


def _done(path: Path) -> dict[str, Any] | None:
    try:
        return load_json(read_input_text(path / DONE))
    except (OSError, ValueError, RecursionError):  # a damaged marker: the folder is run again
        return None


class Archive:
    """A batch's handle on an archive folder (created when missing).

    ``with Archive(root) as a:`` takes the archive's lock (one batch writes at a time) and empties
    ``_staging`` (what killed runs left).

    Raises:
        InputError: ``root`` is a file, or a non-empty folder that is not an archive, or another
            batch holds the lock.
    """

    def __init__(self, root: str | Path):
        self.root = Path(root)
        self._lock: Any = None

    def __enter__(self) -> Archive:
        root = self.root
        if root.exists() and not root.is_dir():
            raise InputError("archive must be a folder", root)
        marker = root / "_fleet.json"
        if root.is_dir() and any(root.iterdir()) and not marker.is_file():
            raise InputError(
                "folder exists and is not a sensemaking archive (no _fleet.json)", root
            )
        if marker.is_file():
            check_marker(root)
        root.mkdir(parents=True, exist_ok=True)
        if not marker.is_file():
            from sensemaking.io.atomic import atomic_write

            with atomic_write(marker) as fh:
                json.dump({"format": ARCHIVE_FORMAT, "version": ARCHIVE_VERSION}, fh)
        self._lock = open(root / ".lock", "a")
        try:
            fcntl.flock(self._lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            self._lock.close()
            self._lock = None
            raise InputError(
                "another batch is writing this archive (its .lock is held)", root
            ) from None
        shutil.rmtree(root / STAGING, ignore_errors=True)
        (root / STAGING).mkdir()
        return self

    def __exit__(self, *exc: object) -> None:
        if self._lock is not None:
            fcntl.flock(self._lock, fcntl.LOCK_UN)
            self._lock.close()
            self._lock = None

    def status(self, spec: SequenceSpec, key: str) -> str | None:
        """``ok`` / ``failed`` when this sequence is archived under ``key``, else None."""
        folder = sequence_dirs(self.root, spec.dataset, spec.sequence) / f"key={key}"
        done = _done(folder)
        if done is None:
            return None
        damaged = _damaged(folder, [t for t in TABLES if (folder / f"{t}.parquet").exists()])
        if damaged is not None:  # a truncated file: run the sequence again
            log.warning("archived %s is damaged (%s): it is run again", folder, damaged)
            shutil.rmtree(folder, ignore_errors=True)
            return None
        return str(done.get("status"))


# -- writing one sequence ------------------------------------------------------------------------
def _now() -> dt.datetime:
    return dt.datetime.now(dt.UTC)


def _class_names(ids: np.ndarray) -> list[str]:
    from sensemaking.classes import class_name

    cache: dict[int, str] = {}
    return [cache.setdefault(i, class_name(i)) for i in ids.tolist()]


def _columns(result: SequenceResult, head: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """Table name -> column name -> values (the ``head`` columns repeated)."""
    from sensemaking.results import TrackState, Visibility

    scene = result.scene
    tracks = list(scene.tracks.values())
    first = scene.first_frame or 0
    fps = scene.fps
    if tracks:
        cat = {
            k: np.concatenate([getattr(t, k) for t in tracks])
            for k in ("frames", "confidence", "state", "occluder", "visibility", "hidden_frames")
        }
        xyxy = np.concatenate([t.xyxy for t in tracks])
        tid = np.concatenate([np.full(len(t), t.id, dtype=np.int64) for t in tracks])
        cid = np.concatenate([np.full(len(t), t.class_id, dtype=np.int64) for t in tracks])
        order = np.lexsort((tid, cat["frames"]))
    else:
        cat = {
            k: np.zeros(0)
            for k in ("frames", "confidence", "state", "occluder", "visibility", "hidden_frames")
        }
        xyxy, tid, cid = np.zeros((0, 4)), np.zeros(0, np.int64), np.zeros(0, np.int64)
        order = np.zeros(0, np.int64)
    states = [s.name.lower() for s in TrackState]
    vis = [v.asp for v in Visibility]
    track_class: dict[int | str, str] = {t.id: t.class_name for t in tracks}
    cols: dict[str, dict[str, Any]] = {}
    cols["tracks"] = {
        "frame": cat["frames"][order].astype(np.int64),
        "track_id": tid[order],
        "class_id": cid[order],
        "object_class": _class_names(cid[order]),
        "x1": xyxy[order, 0],
        "y1": xyxy[order, 1],
        "x2": xyxy[order, 2],
        "y2": xyxy[order, 3],
        "confidence": cat["confidence"][order].astype(np.float64),
        "state": [states[int(v)] for v in cat["state"][order]],
        "occluder": cat["occluder"][order].astype(np.int64),
        "visibility": [vis[int(v)] for v in cat["visibility"][order]],
        "hidden_frames": cat["hidden_frames"][order].astype(np.int64),
    }
    ev = scene.events
    cols["events"] = {
        "frame": [e.frame for e in ev],
        "time_s": [(e.frame - first) / fps for e in ev],
        "event": [e.name for e in ev],
        "track_id": [e.args[0] for e in ev],
        "other_id": [e.args[1] if len(e.args) > 1 else None for e in ev],
        "track_class": [track_class.get(e.args[0]) for e in ev],
        "other_class": [track_class.get(e.args[1]) if len(e.args) > 1 else None for e in ev],
    }
    ws = result.warnings

    def lead(w: Any, k: str, conv: Any) -> Any:
        v = w.details.get(k)
        return None if v is None else conv(v)

    cols["warnings"] = {
        "frame": [w.frame for w in ws],
        "time_s": [(w.frame - first) / fps for w in ws],
        "situation": [w.situation for w in ws],
        "track_id": [w.objects[0] for w in ws],
        "other_id": [w.objects[1] if len(w.objects) > 1 else None for w in ws],
        "track_class": [track_class.get(w.objects[0]) for w in ws],
        "other_class": [track_class.get(w.objects[1]) if len(w.objects) > 1 else None for w in ws],
        "objects": [list(w.objects) for w in ws],
        "lead_frames": [lead(w, "lead_frames", int) for w in ws],
        "lead_s": [lead(w, "lead_s", float) for w in ws],
        "message": [w.message for w in ws],
        "details": [json.dumps(w.details, sort_keys=True, default=str) for w in ws],
    }
    st = result.stats
    m = result.metrics or {}
    cols["metrics"] = {
        "rules": [result.spec.rules if result.metrics is not None else None],
        "frames": [int(st["frames"])],
        "detections": [int(st["detections"])],
        "tracks": [len(tracks)],
        "events": [len(ev)],
        "warnings": [len(ws)],
        "seconds": [st["seconds"]],
        "ms_per_frame": [1000.0 * st["seconds"] / max(st["frames"], 1)],
        "solve_ms": [st["solve_ms"]],
        "monitor_ms": [st["monitor_ms"]],
    }
    from sensemaking.evaluation import PER_SEQUENCE_FIELDS

    for name in PER_SEQUENCE_FIELDS:
        cols["metrics"][name] = [m.get(name)]
    for table in cols.values():
        rows = len(next(iter(table.values())))
        for k, v in head.items():
            table[k] = [v] * rows
    return cols


def _write(table: str, columns: dict[str, Any], path: Path) -> None:
    pa = _pa()
    pq = require("pyarrow.parquet", "fleet")
    schema = schemas()[table]
    arrays = [pa.array(columns[f.name], type=f.type) for f in schema]
    pq.write_table(
        pa.Table.from_arrays(arrays, schema=schema), path / f"{table}.parquet", compression="zstd"
    )


def _publish(root: Path, staged: Path, final: Path) -> None:
    """Rename ``staged`` to ``final``; an older ``final`` is moved aside first and then deleted."""
    final.parent.mkdir(parents=True, exist_ok=True)
    try:
        os.rename(staged, final)
        return
    except OSError:
        if not final.exists():
            raise
    old = root / STAGING / f"replaced-{uuid.uuid4().hex}"
    os.rename(final, old)
    os.rename(staged, final)
    shutil.rmtree(old, ignore_errors=True)


def _versions() -> dict[str, str]:
    import clingo

    from sensemaking import __version__

    return {
        "software_version": __version__,
        "clingo_version": clingo.__version__,
        "python_version": platform.python_version(),
    }


def archive_sequence(
    spec: SequenceSpec,
    root: str,
    params: RunParams,
    key: str,
    checksums: dict[str, str],
    run_id: str,
    label: str | None = None,
    node_id: str | None = None,
    failed: str | None = None,
) -> dict[str, Any]:
    """Run one sequence and publish its folder in the archive (``ok`` or ``failed``).

    ``failed``: do not run; archive the sequence as failed with this error (the driver's record
    of a task that died beyond its retries).

    Every exception of the run is recorded as the sequence's failure (its type and message);
    only failures of writing the archive itself propagate. Returns a small summary:
    ``dataset, sequence, key, status, error, seconds, frames, node_id, pid``.
    """
    from sensemaking.fleet.run import run_sequence, tracker_config

    started = _now()
    t0 = time.perf_counter()
    result: SequenceResult | None = None
    error: str | None = failed
    try:
        if failed is None:
            result = run_sequence(spec, params)
    except SensemakingError as exc:
        error = str(exc)
    except Exception as exc:  # noqa: BLE001 - a bad sequence must not stop the batch
        error = f"{type(exc).__name__}: {exc}"
        log.exception("sequence %s/%s failed", spec.dataset, spec.sequence)
    root_path = Path(root)
    staged = root_path / STAGING / f"{spec.dataset}.{spec.sequence}.{key}.{uuid.uuid4().hex}"
    staged.mkdir(parents=True)
    head = {
        "dataset": spec.dataset,
        "sequence": spec.sequence,
        "class": spec.class_name,
        "key": key,
    }
    fps: float | None
    if result is not None:
        for table, cols in _columns(result, head).items():
            _write(table, cols, staged)
        config = result.config
        first, last = result.scene.first_frame, result.scene.last_frame
        fps, size = result.scene.fps, result.scene.image_size
    else:
        try:
            config = _jsonable_config(tracker_config(spec, params))
        except SensemakingError:
            config = None
        first = last = None
        fps, size = spec.fps, spec.image_size
    ended = _now()
    runs = {
        **head,
        "status": "ok" if error is None else "failed",
        "error": error,
        "run_id": run_id,
        "label": label,
        "params_id": params_id(params),
        "params": json.dumps(params.to_json(), sort_keys=True),
        "tracker_config": None if config is None else json.dumps(config, sort_keys=True),
        "inputs": json.dumps(checksums, sort_keys=True),
        "det_path": spec.det_path,
        "gt_path": spec.gt_path,
        "format": spec.fmt,
        "fps": fps,
        "width": size[0] if size else None,
        "height": size[1] if size else None,
        "first_frame": first,
        "last_frame": last,
        **_versions(),
        "host": socket.gethostname(),
        "node_id": node_id,
        "worker_pid": os.getpid(),
        "started": started,
        "ended": ended,
        "seconds": time.perf_counter() - t0,
    }
    _write("runs", {k: [v] for k, v in runs.items()}, staged)
    done = {"status": runs["status"], "key": key, "run_id": run_id, "ended": ended.isoformat()}
    (staged / DONE).write_text(json.dumps(done) + "\n", encoding="utf-8")
    _publish(
        root_path, staged, sequence_dirs(root_path, spec.dataset, spec.sequence) / f"key={key}"
    )
    return {
        "dataset": spec.dataset,
        "sequence": spec.sequence,
        "key": key,
        "status": runs["status"],
        "error": error,
        "seconds": runs["seconds"],
        "frames": result.stats["frames"] if result is not None else 0,
        "node_id": node_id,
        "pid": os.getpid(),
    }


def _jsonable_config(config: Any) -> dict[str, Any]:
    from sensemaking.fleet.run import _jsonable

    return _jsonable(config.to_dict())


# -- reading ------------------------------------------------------------------------------------
def _archived(root: Path, dataset: str, sequence: str) -> Iterator[tuple[Path, dict[str, Any]]]:
    base = sequence_dirs(root, dataset, sequence)
    if not base.is_dir():
        return
    for d in sorted(base.glob("key=*")):
        done = _done(d)
        if done is not None:
            yield d, done


def load_scene(root: str | Path, dataset: str, sequence: str, key: str | None = None) -> Scene:
    """The scene of an archived sequence (the newest successful result, or the one of ``key``),
    for ``sensemaking ask`` and ``explain``.

    Raises:
        InputError: not an archive, or no successful result for the sequence (the message lists
            what is archived).
    """
    from sensemaking.results import Event, TrackState, Visibility
    from sensemaking.scene import Scene, Track

    root = Path(root)
    if not (root / "_fleet.json").is_file():
        raise InputError("not a sensemaking archive (no _fleet.json)", root)
    check_marker(root)
    found = [
        (d, done)
        for d, done in _archived(root, dataset, sequence)
        if done.get("status") == "ok" and (key is None or d.name == f"key={key}")
    ]
    if not found:
        have = sorted(
            p.name[len("sequence=") :] for p in (root / f"dataset={dataset}").glob("sequence=*")
        )
        hint = (
            f"; sequences of {dataset}: {', '.join(have[:20])}"
            if have
            else (
                "; datasets: "
                + ", ".join(sorted(p.name[len("dataset=") :] for p in root.glob("dataset=*")))
            )
        )
        what = f" with key {key}" if key else ""
        raise InputError(
            f"no successful result for dataset {dataset!r} sequence {sequence!r}{what}" + hint,
            root,
        )
    folder, _ = max(found, key=lambda item: str(item[1].get("ended")))
    pq = require("pyarrow.parquet", "fleet")
    runs = pq.read_table(folder / "runs.parquet", partitioning=None).to_pylist()[0]
    tr = pq.read_table(folder / "tracks.parquet", partitioning=None).to_pydict()
    ev = pq.read_table(folder / "events.parquet", partitioning=None).to_pydict()
    states = {s.name.lower(): int(s) for s in TrackState}
    vis = {v.asp: int(v) for v in Visibility}
    tid = np.asarray(tr["track_id"], dtype=np.int64)
    frames = np.asarray(tr["frame"], dtype=np.int64)
    order = np.lexsort((frames, tid))
    tracks: dict[int, Track] = {}
    if order.size:
        cuts = np.flatnonzero(np.diff(tid[order])) + 1
        xyxy = np.column_stack(
            [np.asarray(tr[c], dtype=np.float64) for c in ("x1", "y1", "x2", "y2")]
        )
        conf = np.asarray(tr["confidence"], dtype=np.float64)
        state = np.asarray([states[s] for s in tr["state"]], dtype=np.int8)
        occ = np.asarray(tr["occluder"], dtype=np.int64)
        visibility = np.asarray([vis[v] for v in tr["visibility"]], dtype=np.int8)
        hidden = np.asarray(tr["hidden_frames"], dtype=np.int64)
        cls = np.asarray(tr["class_id"], dtype=np.int64)
        for chunk in np.split(order, cuts):
            t = int(tid[chunk[0]])
            classes, counts = np.unique(cls[chunk], return_counts=True)
            tracks[t] = Track(
                id=t,
                class_id=int(classes[np.argmax(counts)]),
                frames=frames[chunk],
                xyxy=xyxy[chunk],
                confidence=conf[chunk],
                state=state[chunk],
                occluder=occ[chunk],
                visibility=visibility[chunk],
                hidden_frames=hidden[chunk],
            )
    events = [
        Event(int(f), str(name), (int(a),) if b is None else (int(a), int(b)))
        for f, name, a, b in zip(
            ev["frame"], ev["event"], ev["track_id"], ev["other_id"], strict=True
        )
    ]
    first, last = runs["first_frame"], runs["last_frame"]
    frame_numbers = np.arange(first, last + 1) if first is not None else np.zeros(0, np.int64)
    size = (runs["width"], runs["height"]) if runs["width"] else None
    return Scene(
        tracks,
        events,
        frame_numbers,
        fps=float(runs["fps"] or 10.0),
        image_size=size,
        metadata={
            "dataset": dataset,
            "sequence": sequence,
            "source": runs["det_path"],
            "key": runs["key"],
            "archive": str(root),
        },
    )


# -- segments: the published folders compacted into a few files, for fast queries ---------------
SEGMENTS = "_segments"
#: rows buffered per table before a row group is written while compacting
_ROW_GROUP = 65536


def _folder_id(path: Path) -> tuple[int, int]:
    st = path.stat()
    return st.st_ino, st.st_mtime_ns


def published(root: str | Path) -> Iterator[tuple[str, str, str, Path]]:
    """``(dataset, sequence, key, folder)`` of every published result folder."""
    for d in Path(root).glob("dataset=*/sequence=*/key=*"):
        if (d / DONE).is_file():
            yield (
                d.parent.parent.name[len("dataset=") :],
                d.parent.name[len("sequence=") :],
                d.name[len("key=") :],
                d,
            )


def segment_members(root: str | Path) -> Iterator[tuple[Path, dict[str, list]]]:
    """Each segment folder with its members' columns (dataset, sequence, key, ino, mtime_ns).

    Raises:
        InputError: a segment is damaged (truncated, not Parquet); the next batch rebuilds it
            (:func:`drop_damaged_segments`).
    """
    pq = require("pyarrow.parquet", "fleet")
    for seg in sorted((Path(root) / SEGMENTS).glob("seg-*")):
        damaged = _damaged(seg)
        if damaged is not None:
            raise InputError(
                f"damaged archive segment ({damaged}): the next `sensemaking batch` on this "
                "archive rebuilds it (segments are derived from the sequence folders)",
                seg,
            )
        yield seg, pq.read_table(seg / "members.parquet", partitioning=None).to_pydict()


def _damaged(seg: Path, names: Sequence[str] = ("members", *TABLES)) -> str | None:
    """Why a segment (or a sequence folder, with its ``names``) cannot be read (a file
    missing, truncated, not Parquet), or None."""
    pq = require("pyarrow.parquet", "fleet")
    for name in names:
        try:
            pq.ParquetFile(seg / f"{name}.parquet").metadata  # noqa: B018 - reads the footer
        except Exception as exc:  # noqa: BLE001 - pyarrow raises several kinds
            return f"{name}.parquet: {' '.join(str(exc).split())[:200]}"
    return None


def drop_damaged_segments(root: str | Path) -> list[Path]:
    """Delete the segments that cannot be read (derived data: their members are read from the
    sequence folders again and compacted anew). Returns the segments dropped."""
    dropped = []
    for seg in sorted((Path(root) / SEGMENTS).glob("seg-*")):
        why = _damaged(seg)
        if why is not None:
            log.warning("dropping damaged segment %s (%s); it is rebuilt", seg, why)
            shutil.rmtree(seg, ignore_errors=True)
            dropped.append(seg)
    return dropped


def compact(root: str | Path) -> int:
    """Copy every published folder not yet in a segment into one new segment
    (``_segments/seg-<time>/<table>.parquet`` and ``members.parquet``), written in ``_staging``
    and renamed into place. Memory: at most ``_ROW_GROUP`` buffered rows per table. A folder
    replaced later (``--force``) is recognised by its inode and time and read from the folder
    again. Segments are derived: deleting ``_segments`` loses nothing. Returns the folders added.
    """
    pa = _pa()
    pq = require("pyarrow.parquet", "fleet")
    root = Path(root)
    drop_damaged_segments(root)
    known: set[tuple[str, str, str, int, int]] = set()
    for _, m in segment_members(root):
        known.update(
            zip(m["dataset"], m["sequence"], m["key"], m["ino"], m["mtime_ns"], strict=True)
        )
    loose = []
    for dataset, sequence, key, folder in published(root):
        ino, mtime = _folder_id(folder)
        if (dataset, sequence, key, ino, mtime) not in known:
            loose.append((dataset, sequence, key, ino, mtime, folder))
    readable = []
    for row in loose:  # a damaged folder stays out (the batch that has it runs it again)
        folder = row[-1]
        why = _damaged(folder, [t for t in TABLES if (folder / f"{t}.parquet").exists()])
        if why is None:
            readable.append(row)
        else:
            log.warning("not compacting the damaged %s (%s)", folder, why)
    loose = readable
    if not loose:
        return 0
    name = (
        "seg-" + dt.datetime.now(dt.UTC).strftime("%Y%m%dT%H%M%S%f") + "-" + uuid.uuid4().hex[:6]
    )
    staged = root / STAGING / name
    staged.mkdir(parents=True)
    sch = schemas()
    writers = {
        t: pq.ParquetWriter(staged / f"{t}.parquet", sch[t], compression="zstd") for t in TABLES
    }
    buffers: dict[str, list[Any]] = {t: [] for t in TABLES}
    counts = dict.fromkeys(TABLES, 0)

    def flush(table: str) -> None:
        if buffers[table]:
            writers[table].write_table(pa.concat_tables(buffers[table]))
            buffers[table], counts[table] = [], 0

    try:
        for *_, folder in loose:
            for table in TABLES:
                f = folder / f"{table}.parquet"
                if f.is_file():
                    part = pq.read_table(f, schema=sch[table], partitioning=None)
                    buffers[table].append(part)
                    counts[table] += part.num_rows
                    if counts[table] >= _ROW_GROUP:
                        flush(table)
        for table in TABLES:
            flush(table)
    finally:
        for w in writers.values():
            w.close()
    cols = list(zip(*[row[:5] for row in loose], strict=True))
    members = pa.table(
        {
            "dataset": list(cols[0]),
            "sequence": list(cols[1]),
            "key": list(cols[2]),
            "ino": pa.array(cols[3], pa.int64()),
            "mtime_ns": pa.array(cols[4], pa.int64()),
        }
    )
    pq.write_table(members, staged / "members.parquet")
    (root / SEGMENTS).mkdir(exist_ok=True)
    os.rename(staged, root / SEGMENTS / name)
    return len(loose)
