"""One loop for a sequence: tracker, scene recorder, situation monitor and output sinks, frame by
frame. ``sensemaking track`` and the demo run through it; so can any other caller::

    with Pipeline(tracker, monitor=monitor, sinks=[TracksSink(path, "mot")]) as pipe:
        summary = pipe.run(frames, first_frame=1, last_frame=length)   # (frame, Detections) pairs

Several classes at once (one tracker, one id space; a track matches detections of its class only
and may hide behind any object): merge the class files' frames and write one file per class::

    streams = [iter_detection_frames(p, "kitti") for p in ("car/0001.txt", "cyclist/0001.txt")]
    paths = class_paths("runs/{class}/0001.txt", [CLASS_IDS["car"], CLASS_IDS["cyclist"]])
    with Pipeline(tracker, sinks=[ClassTracksSink(paths, "kitti")]) as pipe:
        pipe.run(merge_frames(streams, keep_data=()), first_frame=0, last_frame=length - 1)

``step(frame, detections)`` does one frame (validated first: a refused frame changes nothing).
``run`` also steps the frames between the given ones, with no detections, as the tracker ages
its tracks by frames; once nothing is live (no track, the monitor's window empty of anything
but empty frames) the rest of a gap is skipped in one step, so a gap costs work bounded by the
tracker's and monitor's memory, not by the frame numbers. Leaving the ``with`` block normally
finishes every sink (final files appear), on an exception aborts them (nothing half-written;
on KeyboardInterrupt, which the CLI also raises for SIGTERM, the warnings file is kept).
Memory is flat in the length of the input when the sinks are (they are: see
:mod:`sensemaking.sinks`); a :class:`~sensemaking.scene.SceneRecorder` passed as
``recorder`` keeps the whole scene in memory (and the skipped frame numbers a scene records:
:func:`~sensemaking.scene.records_gap`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

from sensemaking.adapters import as_detections
from sensemaking.detections import Detections, check_frame_number, validate_detections
from sensemaking.errors import InputError, ProgramError
from sensemaking.results import FrameResult
from sensemaking.scene import records_gap
from sensemaking.sinks import Sink, close_all

__all__ = [
    "Pipeline",
    "PipelineSummary",
    "FrameStep",
    "FrameTracker",
    "DelaysResults",
    "CountsTracks",
    "Configured",
    "Recorder",
    "Monitor",
    "TakesWarningEnds",
]

log = logging.getLogger(__name__)


# -- what the pipeline runs ------------------------------------------------------------------
class FrameTracker(Protocol):
    """A tracker: one frame's detections in, the frame's result out (frames increase)."""

    def update(self, detections: Detections, /, frame: int) -> FrameResult: ...


@runtime_checkable
class DelaysResults(Protocol):
    """A tracker that decides frame t at frame t + ``lag`` (the look-ahead,
    :class:`~sensemaking.lookahead.LookaheadTracker`): ``push`` takes a frame and returns the
    results that became final, ``flush`` decides the frames still waiting."""

    @property
    def lag(self) -> int: ...

    def push(self, detections: Detections, /, frame: int) -> list[FrameResult]: ...

    def flush(self) -> list[FrameResult]: ...


class TrackerSettings(Protocol):
    """The parameters the pipeline reads from a tracker's ``config``."""

    @property
    def image_size(self) -> tuple[int, int] | None: ...

    @property
    def min_hits(self) -> int: ...


@runtime_checkable
class Configured(Protocol):
    """A tracker with a ``config``: its image size checks the detections, its ``min_hits``
    tells when an empty frame still confirms tracks."""

    @property
    def config(self) -> TrackerSettings: ...


@runtime_checkable
class CountsTracks(Protocol):
    """A tracker that tells its live tracks and counts its frames (``stats["frames"]``): once
    nothing is live, the empty frames of a gap are skipped at once. Other trackers step every
    frame."""

    @property
    def n_tracks(self) -> int: ...

    @property
    def stats(self) -> Mapping[str, Any]: ...


class Recorder(Protocol):
    """Keeps every frame's result (e.g. :class:`~sensemaking.scene.SceneRecorder`)."""

    def add(self, result: FrameResult) -> None: ...


class WindowConfig(Protocol):
    def window_frames(self, fps: float) -> int: ...


class Monitor(Protocol):
    """Issues warnings from frame results (e.g.
    :class:`~sensemaking.reasoning.online.SituationMonitor`): ``update`` gives a frame's new
    warnings, ``ended`` the episodes that ended at it, ``finish`` ends the open ones; it keeps
    the last ``config.window_frames(fps)`` frames."""

    fps: float

    @property
    def config(self) -> WindowConfig: ...

    @property
    def ended(self) -> Sequence[Any]: ...

    def update(self, result: FrameResult) -> Iterable[Any]: ...

    def finish(self, reason: str = ...) -> Iterable[Any]: ...


@runtime_checkable
class TakesWarningEnds(Protocol):
    """A sink that records the ends of warning episodes (e.g. the warnings file)."""

    def end_warnings(self, ends: list[Any]) -> None: ...


@dataclass(frozen=True)
class FrameStep:
    """What one frame gave: the tracker's result and the warnings issued at it."""

    result: FrameResult
    warnings: list[Any] = field(default_factory=list)
    #: warning episodes ended at this frame (:class:`~sensemaking.reasoning.online.WarningEnd`)
    ended: list[Any] = field(default_factory=list)


@dataclass
class PipelineSummary:
    """Counts over a run: ``frames`` covered (stepped + skipped), ``stepped`` (tracker updates),
    ``skipped`` (empty frames skipped in gaps), ``events``, ``warnings``, ``first``/``last``
    frame covered (None before any)."""

    frames: int = 0
    stepped: int = 0
    skipped: int = 0
    events: int = 0
    warnings: int = 0
    first: int | None = None
    last: int | None = None


class Pipeline:
    """Runs ``tracker`` (:class:`FrameTracker`) and, per frame result, the ``recorder``
    (:class:`Recorder`), the ``monitor`` (:class:`Monitor`) and each of ``sinks``
    (:class:`~sensemaking.sinks.Sink`).

    A tracker that delays its results (:class:`DelaysResults`, the look-ahead) is stepped with
    :meth:`advance`: the recorder, monitor and sinks get each frame's result when it is final,
    at its own frame number, and the frames still waiting are decided at the end of the input
    (:meth:`run`, :meth:`finish`) and before a gap is skipped.

    Args:
        validate: check every frame's detections
            (:func:`~sensemaking.detections.validate_detections`, with the tracker's image size)
            before the tracker sees them.
        on_frames: called with the number of frames covered after each step or skip (progress).
    """

    def __init__(
        self,
        tracker: FrameTracker | DelaysResults,
        recorder: Recorder | None = None,
        monitor: Monitor | None = None,
        sinks: Sequence[Sink] = (),
        *,
        validate: bool = True,
        on_frames: Callable[[int], None] | None = None,
    ):
        self.tracker = tracker
        self.recorder = recorder
        self.monitor = monitor
        self.sinks = list(sinks)
        self.validate = validate
        self.on_frames = on_frames
        self.summary = PipelineSummary()
        self._quiet = 0  # consecutive stepped frames after which nothing was live
        self._closed = False
        # asked once, used every frame
        self._counter: CountsTracks | None = tracker if isinstance(tracker, CountsTracks) else None
        self._delayed: DelaysResults | None = (
            tracker if isinstance(tracker, DelaysResults) and tracker.lag > 0 else None
        )
        self._lag = 0 if self._delayed is None else int(self._delayed.lag)
        settings = tracker.config if isinstance(tracker, Configured) else None
        self._image_size = None if settings is None else settings.image_size
        self._min_hits = 1 if settings is None else int(settings.min_hits)
        # the monitor keeps its last `window` frame snapshots (a count, not frame numbers): a
        # gap is skipped only once that window holds nothing but empty frames
        self._horizon = 0
        if monitor is not None:
            self._horizon = int(monitor.config.window_frames(monitor.fps)) + 1

    # -- one frame -----------------------------------------------------------------------------
    def step(self, frame: int, detections: Any = None) -> FrameStep:
        """Track one frame (``detections``: :class:`Detections` or anything the tracker takes;
        None: no detections). Frames must increase. Raises InputError (a ValueError) for a frame
        number or detections outside the plausibility bounds, before anything changes. A
        tracker that delays its results is stepped with :meth:`advance` (TypeError here)."""
        if self._delayed is not None:
            raise TypeError("the tracker delays its results (look-ahead): use advance()")
        return self.advance(frame, detections)[0]

    def advance(self, frame: int, detections: Any = None) -> list[FrameStep]:
        """:meth:`step` for any tracker: the frames whose results became final (one for an
        online tracker; with a look-ahead of k frames, frame ``frame - k`` once k frames
        wait)."""
        frame = check_frame_number(frame)
        if self.summary.last is not None and frame <= self.summary.last:
            raise InputError(f"frames must increase: got frame {frame} after {self.summary.last}")
        if detections is None:
            detections = Detections.empty()
        elif not isinstance(detections, Detections):
            detections = as_detections(detections)
        if self.validate:
            validate_detections(detections, self._image_size)
        try:  # the user's programs (tracking rules, situations) on this frame's facts
            if self._delayed is None:
                results = [self.tracker.update(detections, frame=frame)]  # type: ignore[union-attr]
            else:
                results = self._delayed.push(detections, frame=frame)
            steps = [self._emit(r) for r in results]
        except ProgramError as exc:
            raise ProgramError(f"frame {frame}: {exc.problem}", exc.path, exc.line) from None
        s = self.summary  # counted once emitted: an interrupt in a sink leaves the frame undone
        s.frames += 1
        s.stepped += 1
        s.first = frame if s.first is None else s.first
        s.last = frame
        idle = self._tracker_idle() and all(
            len(st.result.tracks) == 0 and not st.result.events for st in steps
        )
        self._quiet = self._quiet + 1 if idle else 0
        if self.on_frames is not None:
            self.on_frames(1)
        return steps

    def _emit(self, result: FrameResult) -> FrameStep:
        """Give a final frame result to the recorder, the monitor and the sinks."""
        if self.recorder is not None:
            self.recorder.add(result)
        warnings = list(self.monitor.update(result)) if self.monitor is not None else []
        ended = list(self.monitor.ended) if self.monitor is not None else []
        for sink in self.sinks:
            sink.frame(result, warnings)
        self._end_warnings(ended)
        self.summary.events += len(result.events)
        self.summary.warnings += len(warnings)
        return FrameStep(result, warnings, ended)

    def drain(self) -> list[FrameStep]:
        """Decide and emit the frames a look-ahead tracker still holds (the end of the input);
        nothing for an online tracker."""
        if self._delayed is None:
            return []
        return [self._emit(r) for r in self._delayed.flush()]

    def _end_warnings(self, ends: list[Any]) -> None:
        """Give the ends of warning episodes to the sinks that take them (``end_warnings``)."""
        if ends:
            for sink in self.sinks:
                if isinstance(sink, TakesWarningEnds):
                    sink.end_warnings(ends)

    def _finish_warnings(self, reason: str) -> None:
        """End the monitor's open warning episodes (the input ended or was interrupted)."""
        if self.monitor is not None:
            self._end_warnings(list(self.monitor.finish(reason)))

    def _tracker_idle(self) -> bool:
        """True when an empty frame would change nothing in the tracker but its frame counters:
        no live track, and past the first ``min_hits`` frames (which confirm tracks at once)."""
        tracker = self._counter
        if tracker is None or "frames" not in tracker.stats:
            return False  # a tracker that does not tell: every frame is stepped
        return tracker.n_tracks == 0 and tracker.stats["frames"] > self._min_hits

    def _fill(self, first: int, last: int) -> None:
        """Frames ``first..last`` have no detections: step them while something is live, then
        skip the rest at once."""
        f = first
        while f <= last:
            if self._horizon >= 0 and self._quiet > self._horizon + self._lag:
                n = last - f + 1
                s = self.summary
                self.drain()  # the frames still waiting are final before the gap
                self._finish_warnings("cleared")  # nothing holds over the frames skipped
                # the recorder keeps the frame numbers of the gaps a scene records: add them empty
                if self.recorder is not None and records_gap(
                    s.first if s.first is not None else f, last
                ):
                    for g in range(f, last + 1):
                        self.recorder.add(
                            FrameResult(frame=g, tracks=Detections.empty(), events=[])
                        )
                for sink in self.sinks:
                    sink.skip(f, last)
                s.frames += n
                s.skipped += n
                s.first = f if s.first is None else s.first
                s.last = last
                if self.on_frames is not None:
                    self.on_frames(n)
                return
            self.advance(f)
            f += 1

    # -- a sequence ----------------------------------------------------------------------------
    def run(
        self,
        frames: Iterable[tuple[int, Any]],
        *,
        first_frame: int | None = None,
        last_frame: int | None = None,
    ) -> PipelineSummary:
        """Step every ``(frame, detections)`` pair (increasing frames), the frames between them
        with no detections, and with ``first_frame`` / ``last_frame`` the empty frames before
        the first pair / after the last one (a sequence's full length). Returns the summary."""
        if first_frame is not None:
            first_frame = check_frame_number(first_frame, "first frame")
        if last_frame is not None:
            last_frame = check_frame_number(last_frame, "last frame")
        for f, dets in frames:
            f = check_frame_number(f)
            if last_frame is not None and f > last_frame:
                raise InputError(f"frame {f} is after the sequence's last frame {last_frame}")
            previous = self.summary.last
            if previous is not None and f <= previous:
                raise InputError(f"frames must increase: got frame {f} after {previous}")
            start = previous + 1 if previous is not None else first_frame
            if start is not None and start < f:
                self._fill(start, f - 1)
            self.advance(f, dets)
        if last_frame is not None:
            start = self.summary.last + 1 if self.summary.last is not None else first_frame
            if start is None:
                start = last_frame
            if start <= last_frame:
                self._fill(start, last_frame)
        self.drain()
        return self.summary

    # -- the end ---------------------------------------------------------------------------------
    def finish(self) -> None:
        """Make every sink's file (renamed into place together at the end)."""
        if not self._closed:
            self._closed = True
            try:
                self.drain()
                self._finish_warnings("end_of_input")
            except BaseException:
                close_all(self.sinks, ok=False)
                raise
            close_all(self.sinks, ok=True)

    def abort(self, interrupted: bool = False) -> None:
        """Delete what the sinks wrote (but the warnings, when ``interrupted``)."""
        if not self._closed:
            self._closed = True
            if interrupted:  # the warnings file is kept: its open episodes end here
                try:
                    self._finish_warnings("interrupted")
                except Exception:  # noqa: BLE001 - the sinks still need closing
                    log.warning("could not end the open warning episodes", exc_info=True)
            close_all(self.sinks, ok=False, interrupted=interrupted)

    def __enter__(self) -> Pipeline:
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        if exc_type is None:
            self.finish()
        else:
            self.abort(interrupted=issubclass(exc_type, KeyboardInterrupt))
