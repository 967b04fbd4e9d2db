"""One view of a tracker run for drawing: frame results, events, warnings and sequence metadata.

The renderer and the report accept a :class:`Run`, a list of
:class:`~sensemaking.results.FrameResult`, a :class:`sensemaking.scene.Scene` or the path of a
scene JSON; :func:`as_run` turns each into a :class:`Run`.
"""

from __future__ import annotations

import os
from collections import Counter, defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from sensemaking import records
from sensemaking.results import Event, FrameResult, TrackState
from sensemaking.viz._style import _get

__all__ = ["Run", "Span", "as_run"]


@dataclass(frozen=True)
class Span:
    """Frames ``start..end`` (inclusive) in which a track kept one state (and occluder)."""

    start: int
    end: int
    state: int  #: TrackState value
    occluder: int = -1


@dataclass
class Run:
    """A tracker run: per-frame results plus warnings and sequence metadata.

    Attributes:
        results: one FrameResult per processed frame, sorted by frame number.
        warnings: warning objects or dicts with ``frame, situation, objects, message, details``.
        width, height: image size in pixels (None: inferred from the boxes).
        fps: frame rate (None: unknown; drawing uses 10).
        name: sequence name shown in captions and the report title.
        scene: the Scene this run came from, when there is one (used for stories).
    """

    results: list[FrameResult]
    warnings: list[Any] = field(default_factory=list)
    width: int | None = None
    height: int | None = None
    fps: float | None = None
    name: str = ""
    scene: Any = None

    def __post_init__(self) -> None:
        self.results = sorted(self.results, key=lambda r: r.frame)
        self.warnings = sorted(self.warnings, key=lambda w: int(_get(w, "frame", 0)))

    # frames ---------------------------------------------------------------------------------
    @cached_property
    def by_frame(self) -> dict[int, FrameResult]:
        return {int(r.frame): r for r in self.results}

    @property
    def first_frame(self) -> int:
        return int(self.results[0].frame) if self.results else 0

    @property
    def last_frame(self) -> int:
        return int(self.results[-1].frame) if self.results else -1

    @property
    def frames(self) -> range:
        """Every frame number from the first result to the last (gaps included)."""
        return range(self.first_frame, self.last_frame + 1)

    # tracks -----------------------------------------------------------------------------------
    @cached_property
    def classes(self) -> dict[int, int]:
        """Track id -> its most frequent class id."""
        counts: dict[int, Counter] = defaultdict(Counter)
        for r in self.results:
            # Detections fills every column on construction
            assert r.tracks.tracker_id is not None and r.tracks.class_id is not None
            for tid, cid in zip(
                r.tracks.tracker_id.tolist(), r.tracks.class_id.tolist(), strict=True
            ):
                counts[tid][cid] += 1
        return {tid: c.most_common(1)[0][0] for tid, c in counts.items()}

    @cached_property
    def track_ids(self) -> list[int]:
        """Track ids ordered by first appearance (then id)."""
        first: dict[int, int] = {}
        for r in self.results:
            assert r.tracks.tracker_id is not None
            for tid in r.tracks.tracker_id.tolist():
                first.setdefault(tid, int(r.frame))
        return sorted(first, key=lambda t: (first[t], t))

    @cached_property
    def spans(self) -> dict[int, list[Span]]:
        """Track id -> maximal runs of consecutive frames with one state and occluder."""
        out: dict[int, list[Span]] = defaultdict(list)
        open_: dict[int, list[int]] = {}  # tid -> [start, end, state, occluder]
        for r in self.results:
            f = int(r.frame)
            t = r.tracks
            states = _column(t, "state", TrackState.VISIBLE)
            occl = _column(t, "occluder", -1)
            assert t.tracker_id is not None
            for tid, st, oc in zip(
                t.tracker_id.tolist(), states.tolist(), occl.tolist(), strict=True
            ):
                cur = open_.get(tid)
                if cur is not None and cur[1] == f - 1 and cur[2] == st and cur[3] == oc:
                    cur[1] = f
                    continue
                if cur is not None:
                    out[tid].append(Span(*cur))
                open_[tid] = [f, f, int(st), int(oc)]
        for tid, cur in open_.items():
            out[tid].append(Span(*cur))
        return dict(out)

    @cached_property
    def events(self) -> list[Event]:
        """All events, sorted."""
        return sorted(e for r in self.results for e in r.events)

    def warnings_at(self, frame: int) -> list[Any]:
        return [w for w in self.warnings if int(_get(w, "frame", -1)) == frame]

    def size(self) -> tuple[int, int]:
        """``(width, height)`` in pixels: the known size, else the boxes' extent (at least 64)."""
        if self.width and self.height:
            return int(self.width), int(self.height)
        x2 = y2 = 64.0
        for r in self.results:
            if len(r.tracks):
                x2 = max(x2, float(np.max(r.tracks.xyxy[:, 2])))
                y2 = max(y2, float(np.max(r.tracks.xyxy[:, 3])))
        return int(self.width or np.ceil(x2)), int(self.height or np.ceil(y2))


def _column(tracks: Any, key: str, default: int) -> np.ndarray:
    value = tracks.data.get(key)
    if value is None:
        return np.full(len(tracks), int(default), dtype=np.int64)
    return np.asarray(value).astype(np.int64)


def as_run(
    source: Any,
    *,
    warnings: Iterable[Any] | str | None = "auto",
    width: int | None = None,
    height: int | None = None,
    fps: float | None = None,
    name: str | None = None,
) -> Run:
    """A :class:`Run` from a Run, FrameResults, a Scene or a scene JSON path; keywords override.

    ``warnings``: ``"auto"`` keeps a Run's warnings and otherwise replays the frames through
    :class:`sensemaking.reasoning.online.SituationMonitor` (when it exists); None means none; an
    iterable gives them (objects or dicts with ``frame, situation, objects, message, details``).
    """
    path_name = None
    if isinstance(source, (str, os.PathLike)):
        path_name = Path(source).stem
        source = _load_scene(Path(source))
    if isinstance(source, Run):
        run = Run(
            list(source.results),
            list(source.warnings),
            source.width,
            source.height,
            source.fps,
            source.name,
            source.scene,
        )
        if warnings == "auto":
            warnings = run.warnings
    elif isinstance(source, Sequence) and all(isinstance(r, FrameResult) for r in source):
        run = Run(list(source))
    else:
        run = _from_scene(source)
    run.width = width if width is not None else run.width
    run.height = height if height is not None else run.height
    run.fps = fps if fps is not None else run.fps
    run.name = name if name is not None else (run.name or path_name or "")
    if isinstance(warnings, str):
        if warnings != "auto":
            raise ValueError(f"warnings must be 'auto', None or an iterable, got {warnings!r}")
        warnings = monitor_warnings(run)
    run.warnings = sorted(warnings or [], key=lambda w: int(_get(w, "frame", 0)))
    return run


def monitor_warnings(run: Run) -> list[Any]:
    """Warnings of the online situation monitor replayed over the run ([] when it is not built)."""
    try:
        from sensemaking.reasoning.online import SituationMonitor
    except ImportError:
        return []
    monitor = SituationMonitor(fps=float(run.fps or 10.0), image_size=run.size())
    out: list[Any] = []
    for r in run.results:
        out.extend(monitor.update(r) or ())
    return out


def scene_of(run: Run) -> Any:
    """The run's Scene: the one it came from, else one recorded from its results (None when
    :mod:`sensemaking.scene` is not available)."""
    if run.scene is not None:
        return run.scene
    try:
        from sensemaking.scene import SceneRecorder
    except ImportError:
        return None
    size = (int(run.width), int(run.height)) if run.width and run.height else None
    rec = SceneRecorder(
        fps=float(run.fps or 10.0), image_size=size, metadata={"name": run.name}, problems=False
    )
    for r in run.results:
        rec.add(r)
    run.scene = rec.scene()
    return run.scene


def _load_scene(path: Path) -> Any:
    from sensemaking.errors import InputError

    if not path.is_file():
        raise InputError("no such scene file", path)
    try:
        from sensemaking.scene import Scene
    except ImportError as exc:  # pragma: no cover - scene model not built in this version
        raise InputError(f"cannot read scenes: {exc}", path) from exc
    return Scene.load(path)


def _scene_name(scene: Any) -> str:
    meta = getattr(scene, "metadata", None) or {}
    for key in ("name", "sequence", "seq"):
        if meta.get(key):
            return str(meta[key])
    for key in ("source", "detections", "input"):
        if meta.get(key):
            return Path(str(meta[key])).stem
    return ""


def _from_scene(scene: Any) -> Run:
    """A Run from a :class:`sensemaking.scene.Scene` (or anything with ``frame_results()``)."""
    results = getattr(scene, "frame_results", None)
    if results is None:
        raise TypeError(
            f"cannot draw a {type(scene).__name__}: "
            "give a Scene, a scene JSON path or a list of FrameResult"
        )
    size = getattr(scene, "image_size", None)
    fps = getattr(scene, "fps", None)
    return Run(
        list(results() if callable(results) else results),
        [],
        width=None if size is None else int(size[0]),
        height=None if size is None else int(size[1]),
        fps=None if fps is None else float(fps),
        name=_scene_name(scene),
        scene=scene,
    )


def read_warnings(path: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """Warnings from a JSON-lines file (``sensemaking track --warnings``), read by
    :func:`sensemaking.records.read_warnings`; the end records of warning episodes are left
    out: a warning is drawn where it starts."""
    return [dict(r) for r in records.warning_starts(records.read_warnings(path))]
