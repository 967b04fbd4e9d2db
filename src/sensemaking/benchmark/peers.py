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
from collections.abc import Callable, Sequence
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
    "BoxmotAdapter",
    "BOXMOT_PEERS",
    "BOXMOT_LEFT_OUT",
    "TRACKERS_PEERS",
    "OursAdapter",
    "make_peer",
    "peer_defaults",
]

#: peers from the ``trackers`` package: our key -> class name in ``trackers``
TRACKERS_PEERS: dict[str, str] = {
    "sort": "SORTTracker",
    "bytetrack": "ByteTrackTracker",
    "ocsort": "OCSORTTracker",
}
#: motion-only peers from ``boxmot``: our key -> (boxmot tracker name, the constructor arguments
#: that switch off the parts reading pixels: appearance embeddings and camera-motion
#: compensation; every other value is boxmot's default). Left out: StrongSORT (needs appearance
#: embeddings), OccluBoost (its ECC camera-motion compensation on the image cannot be switched
#: off), SAM2MOT (segments the image).
BOXMOT_PEERS: dict[str, tuple[str, dict[str, Any]]] = {
    "boxmot-bytetrack": ("bytetrack", {}),
    "boxmot-ocsort": ("ocsort", {}),
    "boxmot-botsort": ("botsort", {"use_embeddings": False, "use_cmc": False}),
    "boxmot-deepocsort": ("deepocsort", {"use_embeddings": False, "cmc_off": True}),
    "boxmot-hybridsort": ("hybridsort", {"use_embeddings": False, "cmc_method": None}),
    "boxmot-boosttrack": ("boosttrack", {"use_embeddings": False, "use_cmc": False}),
    "boxmot-sfsort": ("sfsort", {}),
}
#: boxmot trackers not run, and why
BOXMOT_LEFT_OUT: dict[str, str] = {
    "strongsort": "needs appearance embeddings (a ReID model)",
    "occluboost": "its camera-motion compensation (ECC on the image) cannot be switched off",
    "sam2mot": "segments the image (masks)",
}
#: every peer: our key -> its class name (``trackers``) or boxmot tracker name
PEERS: dict[str, str] = {**TRACKERS_PEERS, **{k: v[0] for k, v in BOXMOT_PEERS.items()}}
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
    "boxmot-bytetrack": "ByteTrack (boxmot)",
    "boxmot-ocsort": "OC-SORT (boxmot)",
    "boxmot-botsort": "BoT-SORT (boxmot, no ReID)",
    "boxmot-deepocsort": "Deep OC-SORT (boxmot, no ReID)",
    "boxmot-hybridsort": "Hybrid-SORT (boxmot, no ReID)",
    "boxmot-boosttrack": "BoostTrack (boxmot)",
    "boxmot-sfsort": "SFSORT (boxmot)",
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


def _boxmot_class(key: str) -> Any:
    require("boxmot", "boxmot")
    from boxmot.trackers.registry import _load_tracker_class, get_tracker_definition

    return _load_tracker_class(get_tracker_definition(BOXMOT_PEERS[key][0]))


def peer_defaults(key: str) -> dict[str, Any]:
    """The constructor defaults of a peer as installed (for the report); for boxmot peers with
    the values that switch off its pixel-reading parts."""
    import inspect

    if key in BOXMOT_PEERS:
        cls = _boxmot_class(key)
        out: dict[str, Any] = {}
        for name, param in inspect.signature(cls.__init__).parameters.items():
            if name in ("self", "kwargs") or param.kind != param.POSITIONAL_OR_KEYWORD:
                continue
            if param.default is not inspect.Parameter.empty and isinstance(
                param.default, (int, float, str, bool)
            ):
                out[name] = param.default
        out.update(BOXMOT_PEERS[key][1])
        return out
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
        if self.name not in TRACKERS_PEERS:
            raise ValueError(f"unknown peer {self.name!r}; known: {', '.join(PEERS)}")
        self._sv = require("supervision", "benchmark")
        cls = getattr(_trackers_module(), PEERS[self.name])
        self._tracker = cls(frame_rate=float(self.frame_rate), **(self.kwargs or {}))

    def reset(self) -> None:
        self._tracker.reset()

    def _to_sv(self, dets: Detections) -> Any:
        n = len(dets)
        assert dets.class_id is not None  # set by __post_init__
        return self._sv.Detections(
            xyxy=dets.xyxy if n else np.empty((0, 4), dtype=np.float64),
            confidence=dets.confidence,
            class_id=dets.class_id.astype(int),
            data={"_row": np.arange(n, dtype=np.int64)},
        )

    def update(self, detections: Detections, frame: int) -> tuple[Detections, float]:
        if self.min_score is not None and len(detections):
            assert detections.confidence is not None  # set by __post_init__
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


@dataclass
class BoxmotAdapter:
    """A motion-only boxmot tracker behind :class:`FrameTracker`, through its documented
    ``update(dets, img)``: ``dets`` (N, 6) ``x1, y1, x2, y2, score, class``; ``img`` a blank
    image of the sequence's size (only its shape is read: the pixel-reading parts are off, see
    :data:`BOXMOT_PEERS`). Its output rows carry the index of the detection they matched; the
    track is reported at that detection (its box, class, frame and source row).

    Args:
        name: a key of :data:`BOXMOT_PEERS`.
        frame_rate: the sequence's frame rate (for trackers with a ``frame_rate`` parameter).
        image_size: (width, height) of the sequence in pixels.
        min_score: drop detections below this score first (None: the tracker's own thresholds).
    """

    name: str
    frame_rate: float = 30.0
    image_size: tuple[int, int] = (1920, 1080)
    min_score: float | None = None

    def __post_init__(self) -> None:
        import inspect
        import logging

        if self.name not in BOXMOT_PEERS:
            raise ValueError(
                f"unknown boxmot peer {self.name!r}; known: {', '.join(BOXMOT_PEERS)}"
            )
        self._cls = _boxmot_class(self.name)
        params = inspect.signature(self._cls.__init__).parameters
        self._kwargs = dict(BOXMOT_PEERS[self.name][1])
        if "frame_rate" in params:
            self._kwargs["frame_rate"] = int(round(self.frame_rate))
        logging.getLogger("boxmot").setLevel(logging.WARNING)
        w, h = self.image_size
        self._img = np.zeros((int(h), int(w), 3), dtype=np.uint8)
        self.reset()

    def reset(self) -> None:
        self._tracker = self._cls(**self._kwargs)

    def update(self, detections: Detections, frame: int) -> tuple[Detections, float]:
        if self.min_score is not None and len(detections):
            assert detections.confidence is not None  # set by __post_init__
            detections = detections[detections.confidence >= self.min_score]
        n = len(detections)
        dets = np.zeros((n, 6), dtype=np.float64)
        if n:
            dets[:, :4] = detections.xyxy
            dets[:, 4] = detections.confidence
            dets[:, 5] = detections.class_id
        start = time.perf_counter()
        out = self._tracker.update(dets, self._img)
        elapsed = time.perf_counter() - start
        out = (
            np.asarray(out, dtype=np.float64).reshape(-1, 8)
            if out is not None and len(out)
            else np.zeros((0, 8))
        )
        rows = out[:, 7].astype(np.int64)
        keep = (rows >= 0) & (rows < n)
        if not np.any(keep):
            return Detections.empty(), elapsed
        ids = out[keep, 4].astype(np.int64)
        # boxmot numbers tracks from 0 or 1 by tracker; MOTChallenge ids are 1-based
        return detections[rows[keep]].with_(tracker_id=ids + 1), elapsed


def make_peer(
    name: str,
    frame_rate: float,
    min_score: float | None = None,
    image_size: tuple[int, int] = (1920, 1080),
) -> PeerAdapter | BoxmotAdapter:
    """A peer adapter with the peer's defaults and the sequence's frame rate (and, for boxmot
    peers, its image size for the blank image)."""
    if name in BOXMOT_PEERS:
        return BoxmotAdapter(
            name=name, frame_rate=frame_rate, image_size=image_size, min_score=min_score
        )
    return PeerAdapter(name=name, frame_rate=frame_rate, min_score=min_score)


@dataclass
class OursAdapter:
    """Our :class:`~sensemaking.tracker.Tracker` behind :class:`FrameTracker`.

    Args:
        name: ``ours`` or ``ours-noabd`` (for the report; the config decides the behaviour).
        config: the tracker configuration (``abduction`` on or off).
        states: which track states to report each frame (0 visible, 1 hidden, 2 missing);
            hidden and missing tracks carry the tracker's predicted box.
        observer: called with every frame's full result after the timed update (the benchmark's
            explanation pass reads the events there), or None.
    """

    name: str
    config: TrackerConfig
    states: Sequence[int] = (0,)
    observer: Callable[[Any], None] | None = None

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
        if self.observer is not None:
            self.observer(result)
        tracks = result.tracks
        if len(tracks) == 0:
            return Detections.empty(), elapsed
        assert tracks.tracker_id is not None  # set by __post_init__
        keep = tracks.tracker_id >= 0
        state = tracks.data.get("state")
        if state is not None:
            keep &= np.isin(np.asarray(state, dtype=np.int64), self._states)
        tracks = tracks[keep]
        if len(tracks):
            if not np.all(tracks.frame == frame):
                tracks = tracks.with_(frame=np.full(len(tracks), frame, dtype=np.int64))
        return tracks, elapsed
