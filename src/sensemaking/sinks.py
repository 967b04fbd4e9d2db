"""Output sinks of a :class:`~sensemaking.pipeline.Pipeline` (beside it: they write what the
pipeline's layers produce, in the formats of :mod:`sensemaking.records` and
:mod:`sensemaking.scene`): tracks, events, warnings and the
scene written frame by frame into temporary files beside their targets, renamed into place when
the run ends (so a final file appears whole or not at all), and memory bounded by the live
tracks, not by the length of the run.

A sink has ``frame(result, warnings)`` (once per frame stepped), ``skip(first, last)`` (frames
``first..last`` seen without any detection and not stepped: nothing was live, nothing happened),
``finish()`` (the run ended: make the file) and ``abort(interrupted)`` (the run failed, or was
interrupted by Ctrl-C / SIGTERM when ``interrupted``: delete what was written; the warnings sink
keeps its file then, as a record of what was said). :func:`check_output_paths` refuses
outputs that would clobber an input or each other before any work is done.
"""

from __future__ import annotations

import heapq
import json
import math
import os
import tempfile
from collections.abc import Callable, Iterable, Iterator, Mapping
from pathlib import Path
from typing import IO, Any, Protocol

import numpy as np

from sensemaking.detections import Detections
from sensemaking.errors import InputError
from sensemaking.io.atomic import NamedIO, PartFile
from sensemaking.io.kitti import format_kitti
from sensemaking.io.mot import format_mot
from sensemaking.records import (
    end_record,
    event_from_record,
    event_record,
    json_line,
    start_record,
)
from sensemaking.results import Event, FrameResult
from sensemaking.scene import (
    TRACK_COLUMNS,
    JsonArray,
    RawJson,
    records_gap,
    scene_parts,
    track_json_parts,
    write_scene,
)

__all__ = [
    "Sink",
    "TracksSink",
    "ClassTracksSink",
    "EventsSink",
    "WarningsSink",
    "SceneSink",
    "check_output_paths",
    "class_paths",
    "CLASS_FIELD",
]

#: an event as the scene file orders it: (frame, name, args)
#: an event's order (``Event.sort_key``: ids before constants) and the event
_EventKey = tuple[tuple[int, str, tuple[tuple[int, int, str], ...]], Event]

PathLike = str | os.PathLike[str]


class Sink(Protocol):
    def frame(self, result: FrameResult, warnings: list[Any]) -> None: ...
    def skip(self, first: int, last: int) -> None: ...
    def finish(self) -> None: ...
    def abort(self, interrupted: bool = False) -> None: ...


def check_output_paths(
    outputs: Mapping[str, PathLike | None], inputs: Mapping[str, PathLike | None] = {}
) -> None:  # noqa: B006 - read only
    """Refuse, before any work, an output that is an input or an existing file of an input
    folder, another output, a directory, or whose parent cannot be created (a file on the way,
    or no write permission).

    ``outputs`` and ``inputs`` map an option name (for the message, e.g. ``"--events"``) to a
    path or None (not given).
    """
    seen: dict[str, str] = {}
    ins = {name: Path(p) for name, p in inputs.items() if p is not None}
    keys = {
        os.path.normcase(os.path.realpath(raw)): name
        for name, raw in outputs.items()
        if raw is not None
    }
    for name, raw in outputs.items():
        if raw is None:
            continue
        path = Path(raw)
        key = os.path.normcase(os.path.realpath(path))
        if key in seen:
            raise InputError(
                f"{name} and {seen[key]} name the same file: each output needs its own", path
            )
        seen[key] = name
        if key.endswith(".part") and key[: -len(".part")] in keys:  # written there meanwhile
            raise InputError(
                f"{name} is where {keys[key[: -len('.part')]]} is written while the run goes "
                "on: choose another name",
                path,
            )
        for in_name, in_path in ins.items():
            same = key == os.path.normcase(os.path.realpath(in_path))
            if not same and path.exists() and in_path.exists():
                try:
                    same = os.path.samefile(path, in_path)
                except OSError:
                    same = False
            inside = (
                not same
                and path.exists()
                and in_path.is_dir()
                and Path(key).is_relative_to(os.path.realpath(in_path))
            )
            if same or inside:
                where = "a file of the input folder" if inside else "the input"
                raise InputError(
                    f"{name} would overwrite {where} {in_name}: choose another output file", path
                )
        if path.is_dir() or os.fspath(raw).endswith(("/", os.sep)):
            raise InputError(f"{name} is a directory, expected a file name", path)
        parent = path.absolute().parent
        while not parent.exists():
            parent = parent.parent
        if not parent.is_dir():
            raise InputError(f"{name}: cannot create the file: {parent} is not a directory", path)
        if not os.access(parent, os.W_OK | os.X_OK):
            raise InputError(f"{name}: cannot write in {parent} (permission denied)", path)


class TracksSink:
    """Tracking results in MOTChallenge (``fmt="mot"``) or KITTI format, as
    :func:`~sensemaking.io.formats.write_results` writes them (the same bytes). Frames are
    formatted in batches of up to ``BATCH_ROWS`` boxes (numpy's per-call cost is then paid per
    batch, not per frame)."""

    BATCH_ROWS = 16384

    def __init__(self, path: PathLike, fmt: str, *, write_hidden: bool = False):
        if fmt not in ("mot", "kitti"):
            raise ValueError(f"unknown format {fmt!r}; expected 'mot' or 'kitti'")
        self.path = Path(path)
        self._format = format_mot if fmt == "mot" else (lambda t: format_kitti(t, self.path))
        self.write_hidden = write_hidden
        self.boxes = 0
        self.ids: set[int] = set()
        self._batch: list[Detections] = []
        self._batch_rows = 0
        self._file = PartFile(self.path)

    def frame(self, result: FrameResult, warnings: list[Any]) -> None:
        tracks: Detections = result.tracks if self.write_hidden else result.visible
        if len(tracks):
            self._batch.append(tracks)
            self._batch_rows += len(tracks)
            if self._batch_rows >= self.BATCH_ROWS:
                self._flush()

    def _flush(self) -> None:
        if self._batch:
            tracks = Detections.concatenate(self._batch)
            self._batch, self._batch_rows = [], 0
            self._file.handle.write(self._format(tracks))
            self.boxes += len(tracks)
            assert tracks.tracker_id is not None  # set by __post_init__
            self.ids.update(np.unique(tracks.tracker_id).tolist())

    def skip(self, first: int, last: int) -> None:
        pass

    def finish(self) -> None:
        self._flush()
        self._file.commit()

    def abort(self, interrupted: bool = False) -> None:
        self._file.discard()


#: the field of an output path replaced by each class's name (``runs/{class}/0001.txt``)
CLASS_FIELD = "{class}"


def class_paths(template: PathLike, classes: Iterable[int]) -> dict[int, Path]:
    """Class id -> output path: ``template`` with :data:`CLASS_FIELD` replaced by the class's
    name (``runs/{class}/0001.txt`` -> ``runs/car/0001.txt``, the KITTI benchmark's layout of
    one results folder per class). Raises ValueError if ``template`` has no such field."""
    from sensemaking.classes import class_name

    text = os.fspath(template)
    if CLASS_FIELD not in text:
        raise ValueError(f"output path {text!r} has no {CLASS_FIELD} field")
    return {int(c): Path(text.replace(CLASS_FIELD, class_name(c))) for c in sorted(classes)}


class ClassTracksSink:
    """Tracking results written per class: one :class:`TracksSink` per class id of ``paths``
    (e.g. from :func:`class_paths`), each row to the file of its track's class, so that a joint
    run of several classes gives the files of separate runs (the benchmark's per-class layout)
    and is scored class by class the same way. Every file is made, empty for a class without
    tracks; a track of a class not in ``paths`` is a ValueError. ``boxes`` and ``ids`` count
    over all classes."""

    def __init__(self, paths: Mapping[int, PathLike], fmt: str, *, write_hidden: bool = False):
        if not paths:
            raise ValueError("ClassTracksSink needs at least one class")
        self.paths = {int(c): Path(p) for c, p in paths.items()}
        self.write_hidden = write_hidden
        self._sinks: dict[int, TracksSink] = {}
        try:
            for c, p in self.paths.items():
                self._sinks[c] = TracksSink(p, fmt, write_hidden=write_hidden)
        except BaseException:
            close_all(self._sinks.values(), ok=False)
            raise
        self._classes = np.array(sorted(self._sinks), dtype=np.int64)

    @property
    def boxes(self) -> int:
        return sum(s.boxes for s in self._sinks.values())

    @property
    def ids(self) -> set[int]:
        return set().union(*(s.ids for s in self._sinks.values()))

    def frame(self, result: FrameResult, warnings: list[Any]) -> None:
        tracks = result.tracks
        assert tracks.class_id is not None  # set by __post_init__
        if len(tracks) == 0:
            return
        unknown = ~np.isin(tracks.class_id, self._classes)
        if unknown.any():
            from sensemaking.classes import class_name

            c = int(tracks.class_id[np.argmax(unknown)])
            raise ValueError(f"a track of class {c} ({class_name(c)}) has no results file")
        for c, sink in self._sinks.items():
            rows = tracks.class_id == c
            if rows.any():
                part = tracks if rows.all() else tracks[rows]
                sink.frame(FrameResult(frame=result.frame, tracks=part, events=[]), warnings)

    def skip(self, first: int, last: int) -> None:
        pass

    def finish(self) -> None:
        close_all(self._sinks.values(), ok=True)

    def abort(self, interrupted: bool = False) -> None:
        close_all(self._sinks.values(), ok=False, interrupted=interrupted)


class EventsSink:
    """Events as JSON lines ``{"frame": …, "event": …, "args": […]}``."""

    def __init__(self, path: PathLike):
        self.path = Path(path)
        self.count = 0
        self._file = PartFile(self.path)

    def frame(self, result: FrameResult, warnings: list[Any]) -> None:
        for ev in result.events:
            self._file.handle.write(json_line(event_record(ev)))
        self.count += len(result.events)

    def skip(self, first: int, last: int) -> None:
        pass

    def finish(self) -> None:
        self._file.commit()

    def abort(self, interrupted: bool = False) -> None:
        self._file.discard()


class WarningsSink:
    """Warnings as a stream of episodes, JSON lines flushed as they are issued into
    ``<path>.part`` (``tail -f`` it; its name is in ``part``); kept in place when the run is
    interrupted, as the record of what was said.

    Each warning episode is two records (:mod:`sensemaking.records`): a start record when the
    situation starts to hold and an end record once it has stopped holding (or the input
    ended). A situation holding over consecutive frames is one episode.
    """

    def __init__(self, path: PathLike):
        self.path = Path(path)
        self.count = 0
        self.ended = 0
        self._file = PartFile(self.path, visible=True)
        self.part = self._file.part

    def frame(self, result: FrameResult, warnings: list[Any]) -> None:
        # a situation that cannot be checked (no objects) is a notice the monitor logs, not a
        # warning record
        warnings = [w for w in warnings if w.objects]
        if warnings:
            for w in warnings:
                self._file.handle.write(json_line(start_record(w)))
            self._file.handle.flush()
            self.count += len(warnings)

    def end_warnings(self, ends: list[Any]) -> None:
        """End records of warning episodes (:class:`~sensemaking.reasoning.online.WarningEnd`)."""
        if ends:
            for e in ends:
                self._file.handle.write(json_line(end_record(e)))
            self._file.handle.flush()
            self.ended += len(ends)

    def skip(self, first: int, last: int) -> None:
        pass

    def finish(self) -> None:
        self._file.commit()

    def abort(self, interrupted: bool = False) -> None:
        if interrupted:
            self._file.commit()
        else:
            self._file.discard()


class SceneSink:
    """The scene JSON of :class:`~sensemaking.scene.SceneRecorder` + ``Scene.save`` (the same
    bytes: both write with :func:`~sensemaking.scene.write_scene`), written with memory bounded
    by the live tracks, whatever their length: a track absent from a frame's output has ended
    and its rows go to an unnamed temporary file, and so do a live track's rows once
    :attr:`SPILL_ROWS` of them wait; events go to another file; at the end the file is
    assembled track by track in id order, each track's columns streamed a part at a time.

    Args:
        path: the scene file. fps: frames per second. image_size: ``(width, height)`` or None.
        metadata: free-form JSON-able information stored with the scene.
        problems: keep the abduction problems behind the events, as
            :class:`~sensemaking.scene.SceneRecorder` does (spilled to a temporary file).
    """

    #: the buffered columns, in order ("track" is the id, not stored with the rows)
    _ROWS = (
        "frames",
        "track",
        "class_id",
        "xyxy",
        "confidence",
        "state",
        "occluder",
        "visibility",
        "hidden_frames",
    )

    def __init__(
        self,
        path: PathLike,
        *,
        fps: float,
        image_size: tuple[int, int] | None = None,
        metadata: Mapping[str, Any] | None = None,
        problems: bool = True,
    ):
        self.path = Path(path)
        self.problems = problems
        self._solver: Any = None  # the solver of the problems recorded (constants, budget)
        self.fps = float(fps)
        self.image_size = None if image_size is None else (int(image_size[0]), int(image_size[1]))
        self.metadata = dict(metadata or {})
        self._runs: list[list[int]] = []  # recorded frames as [first, last] runs
        self._live: dict[
            int, list[list[np.ndarray]]
        ] = {}  # live track -> its row chunks (columns)
        self._batch: list[tuple[np.ndarray, ...]] = []
        self._batch_frames = 0
        self._index: dict[
            int, list[tuple[int, int]]
        ] = {}  # track id -> (offset, length) of its parts
        self._file = PartFile(self.path)
        # spill files beside the scene (its file system), in the temp folder for a device
        folder = None if self._file.through else self.path.absolute().parent

        def spill() -> Any:  # its write errors (a full disk) name the scene
            return NamedIO(tempfile.TemporaryFile(dir=folder), self.path)

        self._tracks: IO[bytes] = spill()
        self._events: IO[bytes] = spill()
        self._problems: IO[bytes] = spill()
        self.n_events = 0
        self._pending: list[_EventKey] = []  # a heap of events to write
        self._last_event: _EventKey | None = None
        self._sorted = True

    def _add_frames(self, first: int, last: int) -> None:
        if self._runs and self._runs[-1][1] + 1 == first:
            self._runs[-1][1] = last
        else:
            self._runs.append([first, last])

    #: frames buffered before their rows are grouped by track (numpy per batch, not per frame)
    BATCH_FRAMES = 256
    #: rows of a live track kept in memory before they go to the temporary file (at most this
    #: plus a batch's; ~100 B a row)
    SPILL_ROWS = 1024

    @property
    def _spill_parts(self) -> int:
        """Batches of a live track kept before its rows are spilled (a part per batch)."""
        return max(1, self.SPILL_ROWS // self.BATCH_FRAMES)

    @property
    def buffered_rows(self) -> int:
        """Rows held in memory (buffered frames and live tracks' parts), not yet spilled."""
        return sum(len(b[0]) for b in self._batch) + sum(
            len(p[0]) for parts in self._live.values() for p in parts
        )

    def frame(self, result: FrameResult, warnings: list[Any]) -> None:
        f = int(result.frame)
        if self._runs and f <= self._runs[-1][1]:
            raise ValueError(f"frames must increase: got frame {f} after {self._runs[-1][1]}")
        self._add_frames(f, f)
        tr = result.tracks
        n = len(tr)
        if n:
            assert tr.tracker_id is not None and tr.class_id is not None  # set by __post_init__
            assert tr.confidence is not None
            d = tr.data
            self._batch.append(
                (
                    np.full(n, f, dtype=np.int64),
                    tr.tracker_id,
                    tr.class_id,
                    tr.xyxy,
                    tr.confidence,
                    d["state"] if "state" in d else np.zeros(n, np.int64),
                    d["occluder"] if "occluder" in d else np.full(n, -1, np.int64),
                    d["visibility"] if "visibility" in d else np.zeros(n, np.int64),
                    d["hidden_frames"] if "hidden_frames" in d else np.zeros(n, np.int64),
                )
            )
        self._batch_frames += 1
        if self._batch_frames >= self.BATCH_FRAMES:
            self._group()
        for e in result.events:
            heapq.heappush(self._pending, (e.sort_key(), e))
        self.n_events += len(result.events)
        self._flush_events(f - self.EVENT_LAG)
        ab = result.abduction
        if self.problems and ab is not None and (result.events or ab.new_tracks):
            from sensemaking.abduction.record import named_here, problems_of_frame

            for p in problems_of_frame(f, ab, result.events):
                started = [d for d in p.dets if d >= 0]
                line = [named_here(p, result.events), started, p.to_json()]
                self._problems.write((json.dumps(line, separators=(",", ":")) + "\n").encode())
            self._solver = ab.solver

    def _group(self) -> None:
        """Move the buffered frames' rows to their tracks; tracks not in the last frame have
        ended: spill them."""
        last = self._runs[-1][1] if self._runs else None
        batch, self._batch, self._batch_frames = self._batch, [], 0
        if batch:
            cols = [np.concatenate(c) for c in zip(*batch, strict=True)]
            frame, tid = cols[0], cols[1]
            order = np.lexsort((frame, tid))
            cuts = np.flatnonzero(np.diff(tid[order])) + 1
            for chunk in np.split(order, cuts):
                t = int(tid[chunk[0]])
                parts = self._live.setdefault(t, [])
                parts.append([c[chunk] for c in cols])
        for t in [t for t, parts in self._live.items() if int(parts[-1][0][-1]) != last]:
            self._spill(t)
        # a track live for the whole run would otherwise keep every row it had (issue 23)
        for t in [t for t, parts in self._live.items() if len(parts) >= self._spill_parts]:
            self._spill(t)

    #: events may be reported some frames after the frame they name (a track's start once it is
    #: confirmed): they wait this many frames to be written in order (if one comes later still,
    #: the events are sorted at the end)
    EVENT_LAG = 1000

    def _flush_events(self, before: float) -> None:
        pending = self._pending
        lines = []
        while pending and pending[0][1].frame < before:
            key = heapq.heappop(pending)
            if self._last_event is not None and key[0] < self._last_event[0]:
                self._sorted = False
            self._last_event = key
            lines.append(json.dumps(event_record(key[1]), separators=(",", ":")) + "\n")
        if lines:
            self._events.write("".join(lines).encode())

    def skip(self, first: int, last: int) -> None:
        self._group()
        for t in list(self._live):
            self._spill(t)
        if records_gap(self._runs[0][0] if self._runs else first, last):
            self._add_frames(first, last)

    #: the spilled columns and their dtypes (those of :class:`~sensemaking.scene.Track`);
    #: a part is the columns' bytes one after the other
    _SPILLED: tuple[tuple[str, Any, int], ...] = (
        ("frames", np.int64, 1),
        ("class_id", np.int64, 1),
        ("xyxy", np.float64, 4),
        ("confidence", np.float64, 1),
        ("state", np.int8, 1),
        ("occluder", np.int64, 1),
        ("visibility", np.int8, 1),
        ("hidden_frames", np.int64, 1),
    )

    def _spill(self, track_id: int) -> None:
        parts = self._live.pop(track_id)
        cols = {k: np.concatenate([p[i] for p in parts]) for i, k in enumerate(self._ROWS)}
        n = len(cols["frames"])
        data = b"".join(
            np.ascontiguousarray(cols[k], dtype=dt).reshape(n * w).tobytes()
            for k, dt, w in self._SPILLED
        )
        self._tracks.seek(0, os.SEEK_END)
        self._index.setdefault(track_id, []).append((self._tracks.tell(), n))
        self._tracks.write(data)

    def _column(self, track_id: int, name: str) -> Iterator[np.ndarray]:
        """One column of a spilled track, a part at a time (``xyxy`` as (n, 4))."""
        for offset, n in self._index[track_id]:
            skip = 0
            for k, dt, w in self._SPILLED:
                size = n * w * np.dtype(dt).itemsize
                if k == name:
                    self._tracks.seek(offset + skip)
                    a = np.frombuffer(self._tracks.read(size), dtype=dt)
                    yield a.reshape(n, 4) if w == 4 else a
                    break
                skip += size

    def _track_entry(self, track_id: int) -> dict[str, Any]:
        """:func:`~sensemaking.scene.track_json` of a spilled track, its columns streamed."""
        counts: dict[int, int] = {}
        for part in self._column(track_id, "class_id"):
            classes, n = np.unique(part, return_counts=True)
            for c, k in zip(classes.tolist(), n.tolist(), strict=True):
                counts[c] = counts.get(c, 0) + k
        # the most frequent class, the lowest id on a tie (np.argmax over sorted classes)
        top = max(counts.values())
        class_id = min(c for c, k in counts.items() if k == top)

        def column(name: str, convert: Callable[[np.ndarray], list[Any]]) -> JsonArray:
            return JsonArray(v for a in self._column(track_id, name) for v in convert(a))

        columns = {key: column(attr, convert) for key, attr, convert in TRACK_COLUMNS}
        return track_json_parts(track_id, class_id, columns)

    def finish(self) -> None:
        self._group()
        for t in list(self._live):
            self._spill(t)
        self._flush_events(math.inf)
        self._events.seek(0)
        lines: Iterable[bytes] = self._events
        if not self._sorted:  # rare: an event later than EVENT_LAG frames; sort them all
            lines = sorted(
                self._events,
                key=lambda b: event_from_record(json.loads(b)).sort_key(),
            )
        parts = scene_parts(
            fps=self.fps,
            image_size=self.image_size,
            runs=[(a, b) for a, b in self._runs],
            metadata=self.metadata,
            tracks=JsonArray(self._track_entry(t) for t in sorted(self._index)),
            events=JsonArray(RawJson(line.decode().rstrip("\n")) for line in lines),
            abduction=None if self._solver is None else self._abduction(),
        )
        write_scene(self._file.handle, parts)
        self._close_temporary()
        self._file.commit()

    def abort(self, interrupted: bool = False) -> None:
        self._close_temporary()
        self._file.discard()

    def _abduction(self) -> dict[str, Any]:
        """The scene's ``"abduction"`` entry: the problems an event or a kept track needs
        (:func:`~sensemaking.abduction.record.keep_named`), in frame order, streamed from the
        temporary file."""
        from sensemaking.abduction.record import AbductionRecord, recorded_constants

        head = AbductionRecord(*recorded_constants(self._solver)).to_json()
        del head["problems"]  # the last key: streamed, one problem at a time

        def kept() -> Iterator[Any]:
            self._problems.seek(0)
            for raw in self._problems:
                named, started, problem = json.loads(raw)
                if named or any(t in self._index for t in started):
                    yield problem

        return {**head, "problems": JsonArray(kept())}

    def _close_temporary(self) -> None:
        self._tracks.close()
        self._events.close()
        self._problems.close()


def close_all(sinks: Iterable[Sink], *, ok: bool, interrupted: bool = False) -> None:
    """``finish`` every sink (``ok``) or ``abort`` every one; each is tried even if another
    fails."""
    error: BaseException | None = None
    for sink in sinks:
        try:
            if ok:
                sink.finish()
            else:
                sink.abort(interrupted)
        except BaseException as exc:  # noqa: BLE001 - the others still need closing
            error = error or exc
            ok = False  # the rest are aborted: outputs appear together or not at all
    if error is not None:
        raise error
