"""One per-frame interface over our tracker and the peers SORT, ByteTrack and OC-SORT.

Every adapter takes our :class:`~sensemaking.detections.Detections` for one frame and returns the
tracks it reports for that frame (a ``Detections`` with ``tracker_id`` >= 0, class, frame and
``source_row`` carried through), together with the seconds spent in the tracker's own ``update``
call (association only: no file I/O, no format conversion).

The peers come from roboflow's ``trackers`` package (the ``benchmark`` extra), imported lazily.
They run with their own defaults, except ``frame_rate`` which is set from the sequence (it scales
their lost-track buffer). The ``prefilter`` variant additionally drops detections scoring below
the score threshold our tracker uses before the peer sees them.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from sensemaking.detections import Detections
from sensemaking.errors import require

if TYPE_CHECKING:  # pragma: no cover
    from sensemaking.tracker import TrackerConfig

__all__ = [
    "PEERS",
    "OURS",
    "TRACKER_NAMES",
    "DISPLAY_NAMES",
    "FrameTracker",
    "PeerAdapter",
    "OursAdapter",
    "make_peer",
    "peer_defaults",
]

#: peers from the ``trackers`` package: our key -> class name in ``trackers``
PEERS: dict[str, str] = {"sort": "SORTTracker", "bytetrack": "ByteTrackTracker", "ocsort": "OCSORTTracker"}
#: our tracker, with and without abduction
OURS: tuple[str, ...] = ("ours", "ours-noabd")
#: every tracker key, in report order
TRACKER_NAMES: tuple[str, ...] = OURS + tuple(PEERS)
#: how the report names each tracker
DISPLAY_NAMES: dict[str, str] = {
    "ours": "ours, with abduction",
    "ours-noabd": "ours, without abduction",
    "sort": "SORT",
    "bytetrack": "ByteTrack",
    "ocsort": "OC-SORT",
}


class FrameTracker(Protocol):
    """What the runner drives: one sequence at a time, one frame per call."""

    name: str

    def reset(self) -> None:
        """Forget every track (call before each sequence)."""

    def update(self, detections: Detections, frame: int) -> tuple[Detections, float]:
        """Tracks reported for ``frame``, and the seconds the tracker's update took."""


def _trackers_module() -> Any:
    return require("trackers", "benchmark")


def peer_defaults(key: str) -> dict[str, Any]:
    """The constructor defaults of a peer as installed (for the report)."""
    import inspect

    cls = getattr(_trackers_module(), PEERS[key])
    out = {}
    for name, param in inspect.signature(cls.__init__).parameters.items():
        if name == "self" or param.default is inspect.Parameter.empty:
            continue
        default = param.default
        if isinstance(default, type):
            default = default.__name__
        elif default is not None and not isinstance(default, (int, float, str, bool)):
            default = repr(default)
        out[name] = default
    return out


@dataclass
class PeerAdapter:
    """A peer from ``trackers`` behind :class:`FrameTracker`.

    Args:
        name: ``sort``, ``bytetrack`` or ``ocsort``.
        frame_rate: the sequence's frame rate, passed to the peer's ``frame_rate`` parameter.
        min_score: drop detections with a lower confidence before the peer sees them
            (None: give the peer every detection, its own thresholds apply).
        kwargs: further constructor arguments (default: none, the peer's defaults).
    """

    name: str
    frame_rate: float = 30.0
    min_score: float | None = None
    kwargs: dict[str, Any] | None = None

    def __post_init__(self) -> None:
        if self.name not in PEERS:
            raise ValueError(f"unknown peer {self.name!r}; known: {', '.join(PEERS)}")
        self._sv = require("supervision", "benchmark")
        cls = getattr(_trackers_module(), PEERS[self.name])
        self._tracker = cls(frame_rate=float(self.frame_rate), **(self.kwargs or {}))

    def reset(self) -> None:
        self._tracker.reset()

    def _to_sv(self, dets: Detections) -> Any:
        n = len(dets)
        return self._sv.Detections(
            xyxy=dets.xyxy if n else np.empty((0, 4), dtype=np.float64),
            confidence=dets.confidence,
            class_id=dets.class_id.astype(int),
            data={"_row": np.arange(n, dtype=np.int64)},
        )

    def update(self, detections: Detections, frame: int) -> tuple[Detections, float]:
        if self.min_score is not None and len(detections):
            detections = detections[detections.confidence >= self.min_score]
        sv_dets = self._to_sv(detections)
        start = time.perf_counter()
        out = self._tracker.update(sv_dets)
        elapsed = time.perf_counter() - start
        if len(out) == 0 or out.tracker_id is None:
            return Detections.empty(), elapsed
        ids = np.asarray(out.tracker_id, dtype=np.int64)
        keep = ids >= 0
        if not np.any(keep):
            return Detections.empty(), elapsed
        rows = np.asarray(out.data["_row"], dtype=np.int64)[keep]
        # the peers report the matched detection's own box: take it (and class, frame, source
        # row, data) from our input rather than from the float round trip
        # the peers number tracks from 0; MOTChallenge ids are 1-based, so shift by one
        tracks = detections[rows].with_(tracker_id=ids[keep] + 1)
        return tracks, elapsed


def make_peer(name: str, frame_rate: float, min_score: float | None = None) -> PeerAdapter:
    """A peer adapter with the peer's defaults and the sequence's frame rate."""
    return PeerAdapter(name=name, frame_rate=frame_rate, min_score=min_score)


@dataclass
class OursAdapter:
    """Our :class:`~sensemaking.tracker.Tracker` behind :class:`FrameTracker`.

    Args:
        name: ``ours`` or ``ours-noabd`` (for the report; the config decides the behaviour).
        config: the tracker configuration (``abduction`` on or off).
        states: which track states to report each frame (0 visible, 1 hidden, 2 missing);
            hidden and missing tracks carry the tracker's predicted box.
    """

    name: str
    config: TrackerConfig
    states: Sequence[int] = (0,)

    def __post_init__(self) -> None:
        from sensemaking.tracker import Tracker

        self._tracker = Tracker(self.config)
        self._states = np.asarray(sorted(set(int(s) for s in self.states)), dtype=np.int64)

    def reset(self) -> None:
        self._tracker.reset()

    def update(self, detections: Detections, frame: int) -> tuple[Detections, float]:
        start = time.perf_counter()
        result = self._tracker.update(detections, frame=frame)
        elapsed = time.perf_counter() - start
        tracks = result.tracks
        if len(tracks) == 0:
            return Detections.empty(), elapsed
        keep = tracks.tracker_id >= 0
        state = tracks.data.get("state")
        if state is not None:
            keep &= np.isin(np.asarray(state, dtype=np.int64), self._states)
        tracks = tracks[keep]
        if len(tracks):
            if not np.all(tracks.frame == frame):
                tracks = tracks.with_(frame=np.full(len(tracks), frame, dtype=np.int64))
        return tracks, elapsed
