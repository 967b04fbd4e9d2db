"""The scene model: what happened in a sequence, built online from the tracker's frame results.

``SceneRecorder.add(result)`` once per frame (cheap: it only keeps the frame's arrays);
``recorder.scene()`` gives a :class:`Scene`: every track's boxes and states per frame, the event
log, and the fluents ``in_fov``, ``hidden_by`` and ``visibility`` as intervals. A scene is
saved as JSON (``Scene.save`` / ``Scene.load``, written by :func:`write_scene`, which the
pipeline's scene sink shares) and turned into ASP facts for question answering by the reasoning
layer (:func:`sensemaking.reasoning.facts.scene_facts`; the predicates are documented in
``reasoning/encodings/scene.lp``).

Scene JSON (``"format": "sensemaking.scene"``, ``"version": 1``)::

    {"format": "sensemaking.scene", "version": 1,
     "fps": 10.0, "image_size": [1242, 375],          # image_size may be null
     "frames": [0, 153],                              # first and last frame recorded
     "frame_numbers": [...],                          # when not contiguous or > 100,000
     "metadata": {...},                               # free-form (source file, tracker config)
     "tracks": [{"id": 3, "class": "car", "class_id": 3,
                 "frames": [0, 1, ...],               # frames the track was live, increasing
                 "boxes": [[x1, y1, x2, y2], ...],    # pixels; predictions while not visible
                 "confidence": [...],
                 "state": ["visible" | "hidden" | "missing", ...],
                 "occluder": [-1 | track id, ...],
                 "visibility": ["fully_visible" | "partially_occluded" | "fully_occluded", ...],
                 "hidden_frames": [...]}],            # frames since last matched
     "events": [{"frame": 12, "event": "hides_behind", "args": [7, 3]}, ...],
     "abduction": {...}}                              # optional: the problems behind the events

``"abduction"`` (format in :mod:`sensemaking.abduction.record`) keeps the facts of the part of
each frame an event was abduced from, so that ``sensemaking ask SCENE why TRACK FRAME`` can
solve it again and name the next-best explanations with their costs.

The frames recorded are those the pipeline stepped and the empty frames of the gaps it skipped
(nothing live) while the scene spans at most :data:`SCENE_SPAN_FRAMES` frames; a gap past that
is left out (:func:`records_gap`), so a scene's size follows its content.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from itertools import chain
from os import PathLike
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import numpy as np

from sensemaking.classes import class_name
from sensemaking.detections import Detections
from sensemaking.errors import TOO_DEEP, InputError
from sensemaking.io.atomic import atomic_write
from sensemaking.io.text import load_json, read_input_text
from sensemaking.records import event_from_record, event_record
from sensemaking.results import STATE_NAMES, VISIBILITY_VALUES, Event, FrameResult, TrackState

if TYPE_CHECKING:  # pragma: no cover
    from sensemaking.abduction.record import AbductionRecord, ProblemRecord
    from sensemaking.abduction.solver import AbductionSolver

__all__ = [
    "Track",
    "FluentInterval",
    "Scene",
    "SceneRecorder",
    "SCENE_FORMAT",
    "SCENE_VERSION",
    "SCENE_SPAN_FRAMES",
    "records_gap",
]

SCENE_FORMAT = "sensemaking.scene"
SCENE_VERSION = 1
#: a scene of at most this many frames (first to last) loads whatever it holds; the empty frames
#: of a gap the pipeline skipped are recorded as frames only within it (:func:`records_gap`)
SCENE_SPAN_FRAMES = 100_000
_STATES = STATE_NAMES  # index = TrackState value
_VISIBILITY = VISIBILITY_VALUES


@dataclass(frozen=True, eq=False)
class Track:
    """One track over the scene: arrays of length K, one entry per frame it was live.

    Attributes:
        id: track id. class_id: :mod:`sensemaking.classes` id.
        frames: (K,) int64 increasing frame numbers.
        xyxy: (K, 4) float64 boxes in pixels (Kalman prediction while hidden or missing).
        confidence: (K,) float64. state: (K,) int8 :class:`TrackState`.
        occluder: (K,) int64 occluding track id or -1. visibility: (K,) int8 :class:`Visibility`.
        hidden_frames: (K,) int64 frames since the track was last matched.
    """

    id: int
    class_id: int
    frames: np.ndarray
    xyxy: np.ndarray
    confidence: np.ndarray
    state: np.ndarray
    occluder: np.ndarray
    visibility: np.ndarray
    hidden_frames: np.ndarray

    @property
    def first(self) -> int:
        return int(self.frames[0])

    @property
    def last(self) -> int:
        return int(self.frames[-1])

    @property
    def class_name(self) -> str:
        return class_name(self.class_id)

    def index(self, frame: int) -> int | None:
        """Position of ``frame`` in the arrays, or None when the track was not live then."""
        i = int(np.searchsorted(self.frames, frame))
        return i if i < self.frames.shape[0] and self.frames[i] == frame else None

    def visible_mask(self) -> np.ndarray:
        """(K,) bool: frames where the track was matched to a detection."""
        return self.state == TrackState.VISIBLE

    def __len__(self) -> int:
        return int(self.frames.shape[0])


@dataclass(frozen=True, order=True)
class FluentInterval:
    """A fluent holding a value over frames ``start..end`` (inclusive).

    ``fluent`` is ``in_fov`` (args ``(T,)``, value ``true``), ``hidden_by`` (args ``(T, O)``,
    value ``true``) or ``visibility`` (args ``(T,)``, value a :class:`Visibility` name).
    Outside its ``in_fov`` intervals a track's ``in_fov`` is false; ``hidden_by`` is false
    outside the listed intervals.
    """

    start: int
    end: int
    fluent: str
    args: tuple[int, ...]
    value: str

    def asp(self) -> str:
        """The fact ``holds_during(Fluent(Args), Value, Start, End).``"""
        args = ",".join(map(str, self.args))
        return f"holds_during({self.fluent}({args}),{self.value},{self.start},{self.end})."

    def to_json(self) -> dict[str, Any]:
        return {
            "fluent": self.fluent,
            "args": list(self.args),
            "value": self.value,
            "start": self.start,
            "end": self.end,
        }


def _runs(pos: np.ndarray, key: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) index ranges where ``pos`` (scene frame positions) is consecutive and
    ``key`` constant."""
    if pos.shape[0] == 0:
        return []
    brk = (np.diff(pos) != 1) | (np.diff(key) != 0)
    starts = np.concatenate([[0], np.flatnonzero(brk) + 1])
    ends = np.concatenate([starts[1:] - 1, [pos.shape[0] - 1]])
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


class Scene:
    """A recorded scene: tracks, events and fluents; see the module docstring.

    Args:
        tracks: track id -> :class:`Track`.
        events: the event log (sorted on construction).
        frames: (F,) the frame numbers recorded, increasing (frames without tracks included).
        fps: frames per second. image_size: ``(width, height)`` pixels, or None if unknown.
        metadata: free-form JSON-able information (source, tracker parameters).
        abduction: the problems the events were abduced from
            (:class:`~sensemaking.abduction.record.AbductionRecord`), or None.
    """

    def __init__(
        self,
        tracks: Mapping[int, Track],
        events: Sequence[Event],
        frames: Sequence[int] | np.ndarray,
        fps: float = 10.0,
        image_size: tuple[int, int] | None = None,
        metadata: Mapping[str, Any] | None = None,
        abduction: AbductionRecord | None = None,
    ):
        if fps <= 0:
            raise ValueError(f"fps must be positive, got {fps}")
        #: the abduction problems behind the events (for ``ask why``), or None
        self.abduction = abduction
        self.tracks: dict[int, Track] = dict(sorted(tracks.items()))
        self.events: list[Event] = sorted(events)
        fr = np.unique(np.asarray(frames, dtype=np.int64))
        if fr.size == 0 and self.tracks:
            fr = np.unique(np.concatenate([t.frames for t in self.tracks.values()]))
        self.frame_numbers: np.ndarray = fr
        self.fps = float(fps)
        self.image_size = None if image_size is None else (int(image_size[0]), int(image_size[1]))
        self.metadata: dict[str, Any] = dict(metadata or {})

    # -- basic access ---------------------------------------------------------------------------
    @property
    def first_frame(self) -> int | None:
        return int(self.frame_numbers[0]) if self.frame_numbers.size else None

    @property
    def last_frame(self) -> int | None:
        return int(self.frame_numbers[-1]) if self.frame_numbers.size else None

    def __contains__(self, track_id: object) -> bool:
        return isinstance(track_id, (int, np.integer)) and int(track_id) in self.tracks

    def __len__(self) -> int:
        return int(self.frame_numbers.size)

    def __repr__(self) -> str:
        span = "empty" if not len(self) else f"frames {self.first_frame}-{self.last_frame}"
        return f"Scene({span}, {len(self.tracks)} tracks, {len(self.events)} events)"

    def describe(self, track_id: int) -> str:
        """``"track 7 (cyclist)"``, or ``"track 7"`` when it is not in the scene."""
        t = self.tracks.get(int(track_id))
        return f"track {track_id} ({t.class_name})" if t else f"track {track_id}"

    def events_of(self, track_id: int) -> list[Event]:
        """Events that involve ``track_id`` (as any argument), in order."""
        return [e for e in self.events if track_id in e.args]

    def only(self, track_ids: Iterable[int]) -> Scene:
        """The scene of just these tracks (those in it) and the events that name one of them:
        same frames, fps, image size and metadata, no abduction record. Facts about one track
        (``ask why-ended T``) built from it follow the track's length, not the scene's."""
        keep = {int(t) for t in track_ids} & self.tracks.keys()
        return Scene(
            {k: t for k, t in self.tracks.items() if k in keep},
            [e for e in self.events if any(a in keep for a in e.args)],
            self.frame_numbers,
            fps=self.fps,
            image_size=self.image_size,
            metadata=self.metadata,
        )

    def window(self, first: int, last: int) -> Scene:
        """The scene of frames ``first..last`` only: each track's rows then (views, not
        copies), the events then; same fps, image size and metadata, no abduction record.
        Facts about one frame (``ask in-front F``) built from it follow that frame's rows."""
        tracks: dict[int, Track] = {}
        for k, t in self.tracks.items():
            a, b = np.searchsorted(t.frames, [first, last + 1]).tolist()
            if a < b:
                rows = {attr: getattr(t, attr)[a:b] for _, attr, _ in TRACK_COLUMNS}
                tracks[k] = Track(id=t.id, class_id=t.class_id, **rows)
        fr = self.frame_numbers
        return Scene(
            tracks,
            [e for e in self.events if first <= e.frame <= last],
            fr[(fr >= first) & (fr <= last)],
            fps=self.fps,
            image_size=self.image_size,
            metadata=self.metadata,
        )

    def seconds(self, frames: float) -> float:
        """A frame count in seconds."""
        return float(frames) / self.fps

    # -- fluents --------------------------------------------------------------------------------
    @cached_property
    def fluents(self) -> list[FluentInterval]:
        """Every fluent interval, sorted by start frame (see :class:`FluentInterval`)."""
        out: list[FluentInterval] = []
        for t in self.tracks.values():
            pos = np.searchsorted(self.frame_numbers, t.frames)
            fr = t.frames
            for a, b in _runs(pos, np.zeros_like(pos)):
                out.append(FluentInterval(int(fr[a]), int(fr[b]), "in_fov", (t.id,), "true"))
            hid = np.flatnonzero(t.state == TrackState.HIDDEN)
            for a, b in _runs(pos[hid], t.occluder[hid]):
                occ = int(t.occluder[hid[a]])
                if occ >= 0:
                    out.append(
                        FluentInterval(
                            int(fr[hid[a]]), int(fr[hid[b]]), "hidden_by", (t.id, occ), "true"
                        )
                    )
            for a, b in _runs(pos, t.visibility.astype(np.int64)):
                out.append(
                    FluentInterval(
                        int(fr[a]),
                        int(fr[b]),
                        "visibility",
                        (t.id,),
                        _VISIBILITY[int(t.visibility[a])],
                    )
                )
        out.sort()
        return out

    def fluent_intervals(
        self, fluent: str | None = None, track_id: int | None = None
    ) -> list[FluentInterval]:
        """Fluent intervals of one kind and/or with ``track_id`` as first argument."""
        return [
            f
            for f in self.fluents
            if (fluent is None or f.fluent == fluent)
            and (track_id is None or f.args[0] == track_id)
        ]

    # -- replay ---------------------------------------------------------------------------------
    def frame_results(self) -> Iterator[FrameResult]:
        """The recorded frames again, as :class:`FrameResult` (e.g. to run a monitor offline)."""
        rows = self._rows()
        by_frame: dict[int, list[Event]] = {}
        for e in self.events:
            by_frame.setdefault(e.frame, []).append(e)
        order = np.argsort(rows["frame"], kind="stable")
        frames_sorted = rows["frame"][order]
        for f in self.frame_numbers.tolist():
            lo, hi = np.searchsorted(frames_sorted, [f, f + 1])
            idx = order[lo:hi]
            tracks = Detections(
                xyxy=rows["xyxy"][idx],
                confidence=rows["confidence"][idx],
                class_id=rows["class_id"][idx],
                tracker_id=rows["track"][idx],
                frame=rows["frame"][idx],
                data={
                    "state": rows["state"][idx].astype(np.int64),
                    "occluder": rows["occluder"][idx],
                    "visibility": rows["visibility"][idx].astype(np.int64),
                    "hidden_frames": rows["hidden_frames"][idx],
                },
            )
            yield FrameResult(frame=int(f), tracks=tracks, events=sorted(by_frame.get(f, [])))

    def _rows(self) -> dict[str, np.ndarray]:
        ts = list(self.tracks.values())
        if not ts:
            z = np.zeros(0, dtype=np.int64)
            return {
                "frame": z,
                "track": z,
                "class_id": z,
                "xyxy": np.zeros((0, 4)),
                "confidence": np.zeros(0),
                "state": z,
                "occluder": z,
                "visibility": z,
                "hidden_frames": z,
            }
        return {
            "frame": np.concatenate([t.frames for t in ts]),
            "track": np.concatenate([np.full(len(t), t.id, dtype=np.int64) for t in ts]),
            "class_id": np.concatenate([np.full(len(t), t.class_id, dtype=np.int64) for t in ts]),
            "xyxy": np.concatenate([t.xyxy for t in ts]),
            "confidence": np.concatenate([t.confidence for t in ts]),
            "state": np.concatenate([t.state for t in ts]),
            "occluder": np.concatenate([t.occluder for t in ts]),
            "visibility": np.concatenate([t.visibility for t in ts]),
            "hidden_frames": np.concatenate([t.hidden_frames for t in ts]),
        }

    # -- JSON -----------------------------------------------------------------------------------
    def _parts(self) -> Iterator[tuple[str, Any]]:
        return scene_parts(
            fps=self.fps,
            image_size=self.image_size,
            runs=frame_runs(self.frame_numbers),
            metadata=self.metadata,
            tracks=JsonArray(track_json(t) for t in self.tracks.values()),
            events=JsonArray(event_record(e) for e in self.events),
            abduction=None if self.abduction is None else self.abduction.to_json(),
        )

    def to_json(self) -> dict[str, Any]:
        """The scene as a JSON-able dict (format in the module docstring): what :meth:`save`
        writes."""
        return {k: _materialize(v) for k, v in self._parts()}

    @classmethod
    def from_json(cls, record: Any, path: str | PathLike[str] | None = None) -> Scene:
        """Build from :meth:`to_json` output. Raises InputError naming ``path`` on bad input.

        Checked before anything is built: the format and version, a finite fps in [0.01, 1000],
        the image size, every number finite and every id an integer, track frames increasing
        and inside the scene's frames, the ids that events and occluders name present in the
        scene, and the frame span: at most ``MAX_FRAME`` frames and at most
        ``max(100000, 100 x the rows and events in the file)`` (nothing is allocated in
        proportion to a number in the file before it is checked against the file's content).
        """
        where = None if path is None else str(path)
        if not isinstance(record, Mapping) or record.get("format") != SCENE_FORMAT:
            raise InputError(
                f'not a scene file (expected "format": "{SCENE_FORMAT}"; '
                "write one with `sensemaking track --scene PATH`)",
                where,
            )
        version = record.get("version", SCENE_VERSION)  # files before versioning: 1
        if _is_int(version) and version > SCENE_VERSION:
            raise InputError(
                f"scene format version {version} is newer than this sensemaking reads "
                f"({SCENE_VERSION})",
                where,
            )
        if not _is_int(version) or version < 1:
            raise InputError(
                f"scene format version {version!r}: this sensemaking reads version "
                f"{SCENE_VERSION}",
                where,
            )
        try:
            return cls._from_checked_json(record, where)
        except InputError:
            raise
        except (KeyError, TypeError, ValueError, IndexError, OverflowError, AttributeError) as exc:
            raise InputError(f"malformed scene: {type(exc).__name__}: {exc}", where) from None

    @classmethod
    def _from_checked_json(cls, record: Mapping[str, Any], where: str | None) -> Scene:
        from sensemaking.detections import MAX_FRAME

        def bad(problem: str) -> InputError:
            return InputError(f"malformed scene: {problem}", where)

        fps = record.get("fps", 10.0)
        if (
            isinstance(fps, bool)
            or not isinstance(fps, (int, float))
            or not (math.isfinite(fps) and 0.01 <= fps <= 1000)  # track's --fps range
        ):
            raise bad(f"fps must be a number in [0.01, 1000], got {fps!r}")
        size = record.get("image_size")
        if size is not None and not (
            isinstance(size, list)
            and len(size) == 2
            and all(_is_int(v) and 1 <= v <= 100_000 for v in size)
        ):
            raise bad(f"image_size must be null or [width, height] in pixels, got {size!r}")
        raw_tracks = record.get("tracks", [])
        raw_events = record.get("events", [])
        if not isinstance(raw_tracks, list) or not isinstance(raw_events, list):
            raise bad("'tracks' and 'events' must be lists")
        content = len(raw_events) + sum(
            len(r)
            if isinstance(r, Track)
            else len(r.get("frames", ()))
            if isinstance(r, Mapping)
            else 1
            for r in raw_tracks
        )
        span_limit = min(MAX_FRAME, max(SCENE_SPAN_FRAMES, 100 * content))
        frames_given = None
        if "frame_numbers" in record:
            fn = record["frame_numbers"]
            if not isinstance(fn, list) or not all(_is_int(v) and 0 <= v <= MAX_FRAME for v in fn):
                raise bad(f"'frame_numbers' must be a list of frame numbers in 0..{MAX_FRAME}")
            frames = np.asarray(fn, dtype=np.int64)
            if frames.size > 1 and (np.diff(frames) <= 0).any():
                raise bad("'frame_numbers' must increase")
            frames_given = frames
        elif record.get("frames"):
            span = record["frames"]
            if not (isinstance(span, list) and len(span) == 2 and all(_is_int(v) for v in span)):
                raise bad(f"'frames' must be [first, last], got {str(span)[:80]}")
            f0, f1 = span
            if not 0 <= f0 <= f1 <= MAX_FRAME:
                raise bad(f"'frames' [{f0}, {f1}] must satisfy 0 <= first <= last <= {MAX_FRAME}")
            if f1 - f0 + 1 > span_limit:
                raise bad(
                    f"'frames' [{f0}, {f1}] spans {f1 - f0 + 1} frames, "
                    "implausibly many for a file "
                    f"of {content} rows and events (at most {span_limit})"
                )
            frames = np.arange(f0, f1 + 1, dtype=np.int64)
        else:
            frames = np.zeros(0, dtype=np.int64)
        tracks: dict[int, Track] = {}
        for i, r in enumerate(raw_tracks):
            if isinstance(r, Track):  # built while the file was read (_read_scene)
                t = r
            elif not isinstance(r, Mapping):
                raise bad(f"tracks[{i}] must be an object")
            else:
                t = _track_from_json(r, i, where)
            if t.id in tracks:
                raise bad(f"tracks[{i}]: id {t.id} appears twice")
            if frames.size and (t.first < frames[0] or t.last > frames[-1]):
                raise bad(
                    f"tracks[{i}]: frames {t.first}..{t.last} outside the scene's frames "
                    f"{int(frames[0])}..{int(frames[-1])}"
                )
            if frames_given is not None and not np.isin(t.frames, frames_given).all():
                raise bad(f"tracks[{i}]: a frame not in 'frame_numbers'")
            tracks[t.id] = t
        for t in tracks.values():
            occ = t.occluder[t.occluder >= 0]
            unknown = set(occ.tolist()) - set(tracks)
            if unknown:
                raise bad(f"track {t.id}: occluder {min(unknown)} is not a track of the scene")
        events = []
        for i, e in enumerate(raw_events):
            if not isinstance(e, Mapping):
                raise bad(f"events[{i}] must be an object")
            ev = event_from_record(e)
            if not re.fullmatch(r"[a-z][a-z0-9_]*", ev.name):
                raise bad(f"events[{i}]: event name {ev.name!r} must be a lower-case identifier")
            if frames.size and not frames[0] <= ev.frame <= frames[-1]:
                raise bad(f"events[{i}]: frame {ev.frame} outside the scene's frames")
            # integers name tracks; constants (events of a user's rules) stand for themselves
            missing = [a for a in ev.args if not isinstance(a, str) and a not in tracks]
            if missing:
                raise bad(
                    f"events[{i}]: {ev.name} names track {missing[0]}, which is not in the scene"
                )
            events.append(ev)
        metadata = record.get("metadata") or {}
        if not isinstance(metadata, Mapping):
            raise bad("'metadata' must be an object")
        abduction = None
        if record.get("abduction") is not None:
            from sensemaking.abduction.record import AbductionRecord

            abduction = AbductionRecord.from_json(record["abduction"], where)
        return cls(
            tracks,
            events,
            frames,
            fps=float(fps),
            image_size=None if size is None else (int(size[0]), int(size[1])),
            metadata=metadata,
            abduction=abduction,
        )

    def save(self, path: str | PathLike[str]) -> None:
        """Write the scene JSON atomically (a failed write leaves no partial file)."""
        with atomic_write(path) as fh:
            write_scene(fh, self._parts())

    @classmethod
    def load(cls, path: str | PathLike[str]) -> Scene:
        """Read a scene JSON file. Raises InputError naming the file (and line, for bad JSON).

        A well-formed file is read a part at a time (:func:`_read_scene`): its memory follows
        the scene's arrays, not the file's text and one Python object per number in it."""
        p = Path(path)
        record: Any = None
        try:
            if p.is_file():  # a file that can be read again (not a pipe) on an error
                with p.open(encoding="utf-8") as fh:  # newlines as read_text reads them
                    record = _read_scene(fh, str(p))
        except InputError:
            raise
        except (OSError, UnicodeDecodeError, json.JSONDecodeError, ValueError, _Irregular):
            # read again as a whole below: the same error, with its message and line (a
            # ValueError: a number past Python's digit limit)
            pass
        except RecursionError:  # deeper than Python's JSON reader goes
            raise InputError(TOO_DEEP, p) from None
        if record is not None:
            return cls.from_json(record, p)
        try:
            text = read_input_text(p)
        except FileNotFoundError:
            raise InputError("scene file not found", p) from None
        except (IsADirectoryError, UnicodeDecodeError) as exc:
            raise InputError(f"cannot read scene file: {exc}", p) from None
        try:
            record = load_json(text)
        except json.JSONDecodeError as exc:
            raise InputError(f"not valid JSON: {exc.msg}", p, exc.lineno) from None
        except RecursionError:
            raise InputError(TOO_DEEP, p) from None
        return cls.from_json(record, p)


def track_json(t: Track) -> dict[str, Any]:
    """One entry of the scene JSON's ``"tracks"`` list (boxes rounded to 0.01 px, scores to
    1e-4)."""
    columns = {key: convert(getattr(t, attr)) for key, attr, convert in TRACK_COLUMNS}
    return track_json_parts(t.id, t.class_id, columns)


def track_json_parts(track_id: int, class_id: int, columns: Mapping[str, Any]) -> dict[str, Any]:
    """:func:`track_json` from its columns converted by :data:`TRACK_COLUMNS` (lists, or
    :class:`JsonArray` of their elements to stream a long track), by JSON key."""
    return {
        "id": track_id,
        "class": class_name(class_id),
        "class_id": class_id,
        **{key: columns[key] for key, _, _ in TRACK_COLUMNS},
    }


def _names(names: Sequence[str]) -> Callable[[np.ndarray], list[str]]:
    return lambda values: [names[v] for v in values.tolist()]


#: the scene file's track columns: JSON key, :class:`Track` attribute, and how a (K,) array of
#: it (``xyxy``: (K, 4)) becomes JSON values; a long track can be converted a part at a time
TRACK_COLUMNS: tuple[tuple[str, str, Callable[[np.ndarray], list[Any]]], ...] = (
    ("frames", "frames", np.ndarray.tolist),
    ("boxes", "xyxy", lambda a: np.round(a, 2).tolist()),
    ("confidence", "confidence", lambda a: np.round(a, 4).tolist()),
    ("state", "state", _names(_STATES)),
    ("occluder", "occluder", np.ndarray.tolist),
    ("visibility", "visibility", _names(_VISIBILITY)),
    ("hidden_frames", "hidden_frames", np.ndarray.tolist),
)


class RawJson(str):
    """JSON text, written into a scene file as it is (e.g. a record kept in a temporary file)."""

    __slots__ = ()


class JsonArray:
    """A JSON array whose elements are made (and written) one at a time."""

    __slots__ = ("items",)

    def __init__(self, items: Iterable[Any]):
        self.items = items


def frame_runs(frames: np.ndarray | Sequence[int]) -> list[tuple[int, int]]:
    """``(first, last)`` of each run of consecutive frame numbers, in order."""
    fr = np.asarray(frames, dtype=np.int64)
    if fr.size == 0:
        return []
    cut = np.flatnonzero(np.diff(fr) != 1) + 1
    first = np.concatenate([fr[:1], fr[cut]])
    last = np.concatenate([fr[cut - 1], fr[-1:]])
    return list(zip(first.tolist(), last.tolist(), strict=True))


def scene_parts(
    *,
    fps: float,
    image_size: tuple[int, int] | None,
    runs: Sequence[tuple[int, int]],
    metadata: Mapping[str, Any],
    tracks: JsonArray,
    events: JsonArray,
    abduction: Mapping[str, Any] | None,
) -> Iterator[tuple[str, Any]]:
    """The entries of a scene file, in order (format in the module docstring): the one
    definition :meth:`Scene.save`, :meth:`Scene.to_json` and the pipeline's scene sink share.

    Args:
        runs: the recorded frames as ``(first, last)`` runs (:func:`frame_runs`).
        tracks: :func:`track_json` entries. events: event records
            (:func:`sensemaking.records.event_record`, or :class:`RawJson` of them).
        abduction: :meth:`~sensemaking.abduction.record.AbductionRecord.to_json`, its
            ``"problems"`` last (a :class:`JsonArray` to stream them), or None.
    """
    yield "format", SCENE_FORMAT
    yield "version", SCENE_VERSION
    yield "fps", fps
    yield "image_size", None if image_size is None else list(image_size)
    yield "frames", [runs[0][0], runs[-1][1]] if runs else []
    # past SCENE_SPAN_FRAMES a span alone is refused as implausible: list the frames instead
    if len(runs) > 1 or (runs and runs[-1][1] - runs[0][0] >= SCENE_SPAN_FRAMES):
        yield "frame_numbers", JsonArray(chain.from_iterable(range(a, b + 1) for a, b in runs))
    yield "metadata", metadata
    yield "tracks", tracks
    yield "events", events
    if abduction is not None:
        yield "abduction", abduction


def records_gap(scene_first: int, last: int) -> bool:
    """Whether the empty frames of a gap the pipeline skipped, up to frame ``last``, are
    recorded as frames of a scene whose first frame is ``scene_first``: only while the scene
    spans at most :data:`SCENE_SPAN_FRAMES` frames, so that what ``track --scene`` writes
    always loads and a scene's size follows the frames stepped (its content), not the frame
    numbers."""
    return last - scene_first < SCENE_SPAN_FRAMES


def _dumps(value: Any) -> str:
    if isinstance(value, RawJson):
        return value
    return json.dumps(value, separators=(",", ":"))


def _streamed(value: Any) -> bool:
    return isinstance(value, JsonArray) or (
        isinstance(value, Mapping) and any(isinstance(v, JsonArray) for v in value.values())
    )


#: elements or characters of a streamed array held before they are written
_BLOCK_ITEMS, _BLOCK_CHARS = 4096, 1 << 20


def _write_value(out: IO[str], value: Any) -> None:
    if isinstance(value, JsonArray):
        out.write("[")
        chunk: list[str] = []
        size = 0
        sep = ""
        for item in value.items:
            if _streamed(item):  # an element with streamed parts (a long track): as it comes
                if chunk:
                    out.write(sep + ",".join(chunk))
                    chunk, size, sep = [], 0, ","
                out.write(sep)
                _write_value(out, item)
                sep = ","
                continue
            chunk.append(_dumps(item))
            size += len(chunk[-1])
            # in blocks: a long array (or one of long elements) is not one huge string
            if len(chunk) >= _BLOCK_ITEMS or size >= _BLOCK_CHARS:
                out.write(sep + ",".join(chunk))
                chunk, size, sep = [], 0, ","
        if chunk:
            out.write(sep + ",".join(chunk))
        out.write("]")
    elif _streamed(value):
        _write_entries(out, value.items())
    else:
        out.write(_dumps(value))


def _write_entries(out: IO[str], entries: Iterable[tuple[str, Any]]) -> None:
    out.write("{")
    for k, (key, v) in enumerate(entries):
        out.write(("," if k else "") + json.dumps(key) + ":")
        _write_value(out, v)
    out.write("}")


def write_scene(out: IO[str], parts: Iterable[tuple[str, Any]]) -> None:
    """Write a scene file's entries (:func:`scene_parts`) as compact JSON and a newline,
    streaming every :class:`JsonArray`; the bytes are those of ``json.dump`` of the dict."""
    _write_entries(out, parts)
    out.write("\n")


def _materialize(value: Any) -> Any:
    if isinstance(value, JsonArray):
        return [_materialize(v) for v in value.items]
    if isinstance(value, RawJson):
        return json.loads(value)
    if isinstance(value, Mapping) and _streamed(value):
        return {k: _materialize(v) for k, v in value.items()}
    return value


_WS = re.compile(r"[ \t\n\r]*")
_raw_decode = json.JSONDecoder().raw_decode
#: what follows a JSON value (outside a string), other than whitespace
_AFTER_VALUE = frozenset(",]}:")
#: characters read at a time into the :class:`_Window`
_WINDOW_CHARS = 1 << 20
#: builds one entry of a list as it is parsed: (position in the list, parsed value) -> entry
_Build = Callable[[int, Any], Any]


class _Irregular(Exception):
    """Text the streaming reader leaves to ``json.loads`` (which then says what is wrong)."""


class _Window:
    """A window on a text file that :func:`_read_scene` walks: refilled as it runs dry, the
    part already read dropped, so that it holds about one entry of a list (a track) at a time.

    Attributes:
        text: the text held. pos: the reader's position in it. eof: the file is all read.
    """

    def __init__(self, fh: IO[str], chunk: int | None = None):
        self.fh, self.chunk = fh, chunk or _WINDOW_CHARS
        self.text, self.pos, self.eof = "", 0, False

    def more(self) -> bool:
        """Read on, at least as much as is held (a value longer than the window doubles it);
        False at the end of the file."""
        if self.eof:
            return False
        self.text, self.pos = self.text[self.pos :], 0
        piece = self.fh.read(max(self.chunk, len(self.text)))
        self.eof = not piece
        self.text += piece
        return not self.eof

    def peek(self) -> str:
        """The next character that is not JSON whitespace ('' at the end of the file)."""
        while True:
            self.pos = _WS.match(self.text, self.pos).end()  # type: ignore[union-attr]
            if self.pos < len(self.text) or not self.more():
                return self.text[self.pos : self.pos + 1]

    def take(self) -> str:
        """:meth:`peek`, and past it."""
        c = self.peek()
        self.pos += len(c)
        return c

    def value(self) -> Any:
        """The JSON value at the position; raises JSONDecodeError once the whole file is read
        (a value cut off by the window's end is read again in a wider one)."""
        self.peek()
        while True:
            try:
                value, end = _raw_decode(self.text, self.pos)
                # complete when what follows is seen ("10." may be 10.5 in a wider window)
                after = _WS.match(self.text, end).end()  # type: ignore[union-attr]
                if self.eof or self.text[after : after + 1] in _AFTER_VALUE:
                    self.pos = end
                    return value
            except json.JSONDecodeError:
                if self.eof:
                    raise
            self.more()


def _read_scene(fh: IO[str], where: str | None) -> Any:
    """``json.load(fh)`` of a scene file, except that each entry of the ``"tracks"`` list
    that :func:`_track_from_json` accepts is a :class:`Track` as soon as it is parsed, and each
    of ``"abduction"``'s ``"problems"`` a checked
    :class:`~sensemaking.abduction.record.ProblemRecord`: the text and Python objects of one
    entry live at a time, not the whole file's. An entry refused stays as parsed, so that
    :meth:`Scene.from_json` raises the same error in the same order.

    Raises:
        _Irregular, json.JSONDecodeError: text this reader does not take apart (invalid JSON,
            a top level that is no object): read it with ``json.loads`` for its error.
    """

    def track(i: int, item: Any) -> Any:
        return _track_from_json(item, i, where)

    def problem(i: int, item: Any) -> Any:
        from sensemaking.abduction.record import problem_from_json

        return problem_from_json(item, i, where)

    def abduction(w: _Window) -> Any:
        if w.peek() != "{":
            return w.value()
        return _read_object(w, {"problems": lambda w: _read_array(w, problem)})

    w = _Window(fh)
    record = _read_object(w, {"tracks": lambda w: _read_array(w, track), "abduction": abduction})
    if w.peek():
        raise _Irregular
    return record


def _read_object(w: _Window, fields: Mapping[str, Callable[[_Window], Any]]) -> dict[str, Any]:
    """The JSON object at the window's position, the values of ``fields`` read by their reader
    (the others as JSON)."""
    if w.take() != "{":
        raise _Irregular
    out: dict[str, Any] = {}
    if w.peek() == "}":
        w.pos += 1
        return out
    while True:
        if w.peek() != '"':
            raise _Irregular
        key = w.value()
        if w.take() != ":":
            raise _Irregular
        out[key] = fields.get(key, _Window.value)(w)  # a repeated key: the last, as json.loads
        mark = w.take()
        if mark == "}":
            return out
        if mark != ",":
            raise _Irregular


def _read_array(w: _Window, build: _Build) -> Any:
    """The JSON array at the window's position (else the value there), each object in it
    passed to ``build`` as soon as it is parsed (kept as parsed when ``build`` refuses it)."""
    if w.peek() != "[":
        return w.value()
    w.pos += 1
    out: list[Any] = []
    if w.peek() == "]":
        w.pos += 1
        return out
    while True:
        item = w.value()
        if isinstance(item, dict):
            try:
                item = build(len(out), item)
            except Exception:  # noqa: BLE001 -- kept as parsed: from_json raises it in order
                pass
        out.append(item)
        mark = w.take()
        if mark == "]":
            return out
        if mark != ",":
            raise _Irregular


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _track_from_json(r: Mapping[str, Any], i: int, where: str | None) -> Track:
    from sensemaking.detections import MAX_FRAME

    if not _is_int(r.get("id")) or r["id"] < 0:
        raise InputError(
            f"malformed scene: tracks[{i}]: 'id' must be a non-negative integer", where
        )
    raw = r["frames"]
    if not isinstance(raw, list) or not all(_is_int(v) and 0 <= v <= MAX_FRAME for v in raw):
        raise InputError(
            f"tracks[{i}]: 'frames' must be a list of frame numbers in 0..{MAX_FRAME}", where
        )
    frames = np.asarray(raw, dtype=np.int64)
    k = frames.shape[0]
    if k == 0 or np.any(np.diff(frames) <= 0):
        raise InputError(f"tracks[{i}]: 'frames' must be non-empty and increasing", where)
    boxes = r["boxes"]
    if not isinstance(boxes, list) or not all(isinstance(b, list) and len(b) == 4 for b in boxes):
        raise InputError(f"tracks[{i}]: 'boxes' must be a list of [x1, y1, x2, y2]", where)
    xyxy = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    if not np.isfinite(xyxy).all() or (np.abs(xyxy) > 1e7).any():
        raise InputError(
            f"tracks[{i}]: 'boxes' must hold finite pixel coordinates (|x| <= 1e7)", where
        )

    def col(name: str, default: Any, conv: Any = None, integer: bool = False) -> np.ndarray:
        v = r.get(name)
        if v is None:
            return np.full(k, default)
        if not isinstance(v, list):
            raise InputError(f"tracks[{i}]: '{name}' must be a list", where)
        arr = np.asarray([conv(x) for x in v] if conv else v)
        if (
            arr.ndim != 1
            or arr.dtype.kind not in "iufb"
            or not np.isfinite(arr.astype(np.float64)).all()
        ):
            raise InputError(
                f"tracks[{i}]: '{name}' must be a list of finite numbers or names", where
            )
        if integer and (arr.dtype.kind not in "iu" or (arr.size and np.abs(arr).max() > 2**53)):
            raise InputError(f"tracks[{i}]: '{name}' must be a list of integers", where)
        if arr.shape[0] != k:
            raise InputError(
                f"tracks[{i}]: '{name}' has {arr.shape[0]} entries for {k} frames", where
            )
        return arr

    if xyxy.shape[0] != k:
        raise InputError(f"tracks[{i}]: 'boxes' has {xyxy.shape[0]} entries for {k} frames", where)

    def enum(names: tuple[str, ...], what: str):
        def conv(x: Any) -> int:
            if isinstance(x, str):
                if x not in names:
                    raise InputError(
                        f"tracks[{i}]: unknown {what} {x!r} (one of {', '.join(names)})", where
                    )
                return names.index(x)
            if not _is_int(x) or not 0 <= x < len(names):
                raise InputError(
                    f"tracks[{i}]: {what} {x!r} is not one of {', '.join(names)}", where
                )
            return int(x)

        return conv

    if "class_id" in r and (not _is_int(r["class_id"]) or r["class_id"] < 0):
        raise InputError(f"tracks[{i}]: 'class_id' must be a non-negative integer", where)
    cid = int(r.get("class_id", 0)) if "class_id" in r else _class_from_name(r.get("class"))
    return Track(
        id=int(r["id"]),
        class_id=cid,
        frames=frames,
        xyxy=xyxy,
        confidence=col("confidence", 1.0).astype(np.float64),
        state=col("state", 0, enum(_STATES, "state")).astype(np.int8),
        occluder=col("occluder", -1, integer=True).astype(np.int64),
        visibility=col("visibility", 0, enum(_VISIBILITY, "visibility")).astype(np.int8),
        hidden_frames=col("hidden_frames", 0, integer=True).astype(np.int64),
    )


def _class_from_name(name: Any) -> int:
    from sensemaking.classes import class_id

    try:
        return class_id(str(name)) if name is not None else 0
    except KeyError:
        return 0


class SceneRecorder:
    """Collects frame results online into a :class:`Scene`.

    ``add(result)`` copies the frame's rows into column buffers that grow by doubling (no
    allocation per frame: retaining a few fresh arrays every frame measurably slowed the tracker
    running beside it); the scene is assembled on demand.

    Args:
        fps: frames per second of the sequence. image_size: ``(width, height)`` pixels or None.
        metadata: free-form JSON-able information stored with the scene.
        problems: keep the abduction problem behind every event (the components of the frame
            that hold its subject, as facts; see :mod:`sensemaking.abduction.record`), so that
            ``ask why`` can solve them again. Memory: in proportion to the events.
    """

    #: buffered columns: name -> (dtype, shape of one row, value when the result lacks the column)
    _COLUMNS: dict[str, tuple[type, tuple[int, ...], int]] = {
        "tracker_id": (np.int64, (), 0),
        "class_id": (np.int64, (), 0),
        "xyxy": (np.float64, (4,), 0),
        "confidence": (np.float64, (), 0),
        "state": (np.int8, (), 0),
        "occluder": (np.int64, (), -1),
        "visibility": (np.int8, (), 0),
        "hidden_frames": (np.int64, (), 0),
    }

    def __init__(
        self,
        fps: float = 10.0,
        image_size: tuple[int, int] | None = None,
        metadata: Mapping[str, Any] | None = None,
        problems: bool = True,
    ):
        if fps <= 0:
            raise ValueError(f"fps must be positive, got {fps}")
        self.fps = float(fps)
        self.image_size = image_size
        self.metadata = dict(metadata or {})
        self.problems = problems
        self.reset()

    def reset(self) -> None:
        """Forget everything recorded."""
        self._frames: list[int] = []
        self._row_frames: list[int] = []  # the frames with rows ...
        self._row_counts: list[int] = []  # ... and how many
        self._rows = 0
        self._cols: dict[str, np.ndarray] = {
            k: np.empty((0,) + shape, dtype) for k, (dtype, shape, _) in self._COLUMNS.items()
        }
        self._events: list[Event] = []
        self._problems: list[ProblemRecord] = []
        self._solver: AbductionSolver | None = None

    def __len__(self) -> int:
        return len(self._frames)

    def add(self, result: FrameResult) -> None:
        """Record one frame (frames must increase)."""
        f = int(result.frame)
        if self._frames and f <= self._frames[-1]:
            raise ValueError(f"frames must increase: got frame {f} after {self._frames[-1]}")
        self._frames.append(f)
        tr = result.tracks
        n = len(tr)
        if n:
            start, end = self._rows, self._rows + n
            cols = self._cols
            if end > len(cols["tracker_id"]):
                cap = max(256, 2 * end)
                for k, c in cols.items():
                    grown = np.empty((cap,) + c.shape[1:], c.dtype)
                    grown[:start] = c[:start]
                    cols[k] = grown
            d = tr.data
            cols["tracker_id"][start:end] = tr.tracker_id
            cols["class_id"][start:end] = tr.class_id
            cols["xyxy"][start:end] = tr.xyxy
            cols["confidence"][start:end] = tr.confidence
            for k in ("state", "occluder", "visibility", "hidden_frames"):
                cols[k][start:end] = d[k] if k in d else self._COLUMNS[k][2]
            self._rows = end
            self._row_frames.append(f)
            self._row_counts.append(n)
        self._events.extend(result.events)
        ab = result.abduction
        if self.problems and ab is not None and (result.events or ab.new_tracks):
            from sensemaking.abduction.record import problems_of_frame

            self._problems += problems_of_frame(f, ab, result.events)
            self._solver = ab.solver

    def scene(self) -> Scene:
        """The scene recorded so far."""
        tracks: dict[int, Track] = {}
        if self._rows:
            frame = np.repeat(np.asarray(self._row_frames, dtype=np.int64), self._row_counts)
            col = {k: c[: self._rows] for k, c in self._cols.items()}
            tid = col["tracker_id"]
            order = np.lexsort((frame, tid))
            tids = tid[order]
            cuts = np.flatnonzero(np.diff(tids)) + 1
            for chunk in np.split(order, cuts):
                t = int(tid[chunk[0]])
                classes, counts = np.unique(col["class_id"][chunk], return_counts=True)
                tracks[t] = Track(
                    id=t,
                    class_id=int(classes[np.argmax(counts)]),
                    frames=frame[chunk],
                    xyxy=col["xyxy"][chunk],
                    confidence=col["confidence"][chunk],
                    state=col["state"][chunk],
                    occluder=col["occluder"][chunk],
                    visibility=col["visibility"][chunk],
                    hidden_frames=col["hidden_frames"][chunk],
                )
        abduction = None
        if self._solver is not None:
            from sensemaking.abduction.record import (
                AbductionRecord,
                keep_named,
                recorded_constants,
            )

            constants, budget = recorded_constants(self._solver)
            kept = keep_named(self._problems, self._events, tracks)
            abduction = AbductionRecord(constants, budget, kept)
        return Scene(
            tracks,
            self._events,
            self._frames,
            fps=self.fps,
            image_size=self.image_size,
            metadata=self.metadata,
            abduction=abduction,
        )
