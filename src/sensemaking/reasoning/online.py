"""Online detection of safety-critical situations: ``SituationMonitor.update(result) -> warnings``.

Per frame the monitor condenses the tracker's :class:`~sensemaking.results.FrameResult` into the
numbers the rules need -- states and occluders, which boxes stand in the ego corridor and how
much of the image they take, the qualitative motion of visible boxes, the rectangle relations
of near pairs involving a vehicle, events, lanes and ground labels, the anticipated
reappearance of hidden tracks -- and keeps them for the last ``window`` frames. Each frame's
facts go once to a long-lived clingo Control
(:class:`~sensemaking.reasoning.situations.StreamSolver`: frames by number, tracks by id), which
grounds what is new and answers ``warn/2`` and ``info/4`` for the window; ``stream=False`` is
the reference, the whole window on a fresh Control every frame. Every situation, built in or
added in a user's encoding, is decided by situations.lp, never in Python.

Warnings are episodes. A warning is returned when its situation starts to hold (the start of
an episode); the situation holding on over the next frames is the same episode, not a new
warning, and so is a gap of at most ``rearm_s`` (a detection missed for a frame does not end a
warning and start another); :attr:`SituationMonitor.ended` lists the episodes that ended at the
current frame (:class:`WarningEnd`: the situation has not held for more than ``rearm_s``), and
:meth:`SituationMonitor.finish` ends those still open when the input ends.
:attr:`SituationMonitor.active` lists every situation holding at the current frame.

Each warning carries, in its details, its episode number, a **severity** on the scale of
:data:`SEVERITY_NAMES` and the **lane position** of its first object (:data:`LANE_POSITIONS`):

* severity 1 *advisory* (be aware: OVERTAKING, REDUCED_VISIBILITY), 2 *caution* (be ready to
  act: HIDDEN_ENTITY, BLOCKED_LANE, EXITING_VEHICLE, a user's situation), 3 *warning* (act now:
  SUDDEN_STOP). HIDDEN_ENTITY, BLOCKED_LANE and EXITING_VEHICLE are raised to 3 when their
  object is on the ego lane; with a camera model HIDDEN_ENTITY's severity comes from the world
  instead (situations.lp: the hidden track's path against the ego lane and the time to
  contact, from the facts ``hidden_motion/5``). The scale is stated in ``situations.lp``
  (``severity/2``, ``severity_on_ego_lane/2``, read once); a user's encoding may state it for
  its own situations, or set one warning's severity with ``info(S,Objs,severity,N)``, N in
  1..3.
* lane position: ``ego``, ``left`` or ``right`` of the ego lane, or ``unknown``. The point is
  where the object stands on the road: the bottom centre of its box now (HIDDEN_ENTITY: of the
  anticipated box where it reappears). With lanes, the ego lane is the lane under the bottom
  centre of the image (the camera looks along it; of several, the one reaching lowest); the
  point is ``ego`` inside it, ``left``/``right`` beside it at the point's row, ``unknown``
  above or below the lane. Without lanes (or no lane under the image's bottom centre) the
  image rule: the ego lane is the middle half of the ego corridor's width at the point's row
  (the default corridor spans the ego lane and half of each neighbour), left or right of it
  ``left``/``right``, above the corridor ``unknown``. Without an ego vehicle (profile
  ``fixed``) or without the image size: ``unknown``.

The **scene profile** (``profile``: ``driving``, a camera on an ego vehicle, or ``fixed``, a
standing or handheld camera) is given to the rules as the fact ``profile(P)``; situations.lp
states which situations apply to each (the ego-vehicle ones only when driving).
"""

from __future__ import annotations

import logging
import time
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from itertools import compress
from os import PathLike
from typing import Any

import clingo
import numpy as np

from sensemaking.classes import PEOPLE, VEHICLES, class_name
from sensemaking.errors import InputError
from sensemaking.io.egomotion import EgoMotion
from sensemaking.reasoning.anticipation import Anticipation, anticipate
from sensemaking.reasoning.context import SceneContext, asp_name
from sensemaking.reasoning.egomotion import (
    CameraModel,
    EgoMotionConfig,
    EgoState,
    TrackMotion,
    WorldMotion,
    world_facts,
)
from sensemaking.reasoning.facts import AspString, Fact, value
from sensemaking.reasoning.relations import (
    IA_RELATIONS,
    INVERSE,
    MOTION_KINDS,
    classify_motion,
    motion_features,
    pair_front,
    pair_relations,
)
from sensemaking.reasoning.situations import (
    Situation,
    SituationConfig,
    SituationMatch,
    SituationSolver,
    SituationWarning,
    StreamSolver,
)
from sensemaking.records import end_record
from sensemaking.results import Event, FrameResult, TrackState
from sensemaking.sandbox import Limits
from sensemaking.settings import SCENE_PROFILES

__all__ = [
    "SituationMonitor",
    "WarningEnd",
    "PROFILES",
    "SEVERITY_NAMES",
    "LANE_POSITIONS",
]

log = logging.getLogger(__name__)

_STATE_NAMES = tuple(s.name.lower() for s in TrackState)
_VISIBLE, _HIDDEN = int(TrackState.VISIBLE), int(TrackState.HIDDEN)
#: class ids of the near-pair relations: True for a vehicle, False for a person
_ROLE: dict[int, bool] = {**dict.fromkeys(PEOPLE, False), **dict.fromkeys(VEHICLES, True)}
_ORDER: dict[str, int] = {s.name: i for i, s in enumerate(Situation)}

#: scene profiles: a camera on an ego vehicle, or a standing / handheld camera without one
PROFILES: tuple[str, ...] = SCENE_PROFILES
#: the severity scale of warnings (see the module docstring)
SEVERITY_NAMES: dict[int, str] = {1: "advisory", 2: "caution", 3: "warning"}
#: where a warning's object stands relative to the ego lane
LANE_POSITIONS: tuple[str, ...] = ("ego", "left", "right", "unknown")
#: the severity of a situation whose encoding states none (situations.lp: severity/2)
_USER_SEVERITY = 2
#: the inputs of situations.lp given only with a camera model (egomotion.world_facts and the
#: hidden tracks' extrapolated motion)
WORLD_INPUTS: frozenset[tuple[str, int]] = frozenset(
    {
        ("ego_speed", 2),
        ("position", 4),
        ("position_sd", 3),
        ("closing", 4),
        ("world_speed", 4),
        ("world_long", 3),
        ("world_lat", 3),
        ("hidden_motion", 5),
    }
)
#: monitors reason on a long-lived Control (StreamSolver) unless told ``stream=False``
STREAM = True
#: answers a StreamSolver gives before it starts a new Control (clasp keeps every atom it was
#: given, and each solve costs more as they add up; a restart grounds the window once)
STREAM_RESTART_FRAMES = 40
#: answers before a restart at which the next Control starts to be fed the window, a share
#: each frame, so that no single frame hands a whole window to clingo
STREAM_STAGE_FRAMES = 4


@dataclass(frozen=True)
class WarningEnd:
    """The end of a warning episode.

    Attributes:
        frame: the frame at which the episode is known to be over (the situation has not held
            for more than ``rearm_s``; or the input ended).
        situation, objects: as in the warning that started it.
        episode: the episode number (``details["episode"]`` of that warning).
        start_frame, last_frame: the first and the last frame the situation held.
        reason: ``cleared`` (it stopped holding), ``end_of_input`` or ``interrupted``.
    """

    frame: int
    situation: str
    objects: tuple[int, ...]
    episode: int
    start_frame: int
    last_frame: int
    reason: str = "cleared"

    def to_json(self) -> dict[str, Any]:
        """The end record of the warnings stream (:func:`sensemaking.records.end_record`)."""
        return end_record(self)


class _Episode:
    __slots__ = ("number", "start", "last")

    def __init__(self, number: int, start: int) -> None:
        self.number, self.start, self.last = number, start, start


def _cm(v: float) -> int:
    """Metres (or m/s) as whole centimetres (cm/s)."""
    return int(round(v * 100.0))


def _kmh(info: dict[str, list[Any]], key: str) -> str:
    """`` (N km/h)`` from a speed detail in cm/s, or nothing."""
    v = info.get(key)
    return f" ({v[0] * 0.036:.0f} km/h)" if v and isinstance(v[0], int) else ""


def _confidence_facts(events: list[Event], local: Callable[[int], int], base: int) -> list[Fact]:
    """``confidence_at(E,F,C)``: event E (as in ``occurs_at``) at frame F (relative to
    ``base``) has confidence C, permille, for the events that carry one (the hidings)."""
    return [
        (
            "confidence_at",
            (e.name, *(local(a) if isinstance(a, int) else a for a in e.args)),
            e.frame - base,
            int(round(1000 * e.confidence)),
        )
        for e in events
        if e.confidence is not None
    ]


class _Frame:
    """One frame of the window: the numbers its facts are made of (track ids, absolute frames)."""

    __slots__ = (
        "frame",
        "events",
        "ids",
        "state",
        "hidden_by",
        "in_corr",
        "area",
        "motion",
        "ra",
        "front",
        "lanes",
        "on_lane",
        "surface",
        "ego",
        "world",
    )

    def __init__(self, frame: int, events: list[Event]) -> None:
        self.frame = frame
        self.events = events
        self.ids: list[int] = []
        self.state: dict[int, str] = {}
        self.hidden_by: dict[int, int] = {}  # hidden track -> occluder
        self.in_corr: list[int] = []
        self.area: dict[int, int] = {}  # in-corridor tracks: permille of the image
        self.motion: dict[int, tuple[str, ...]] = {}  # visible tracks: MOTION_KINDS that hold
        self.ra: list[tuple[int, int, str, str]] = []  # (a, b, x relation, y relation), a < b
        self.front: list[tuple[int, int]] = []  # (a, b): a in front of b (relations.pair_front)
        self.lanes: list[int | str] = []  # lane terms in force
        self.on_lane: dict[int, list[int | str]] = {}
        self.surface: dict[int, str] = {}
        self.ego: EgoState | None = None  # the ego's motion (with a camera model)
        self.world: dict[int, TrackMotion] = {}  # visible tracks in metres and m/s


class _Numbering:
    """Frames and tracks as one stream solver's facts name them: frames relative to ``base``,
    tracks by slot (the given tracks in the order of their ids, then new ones in turn), so that
    a long run makes a bounded set of clingo symbols."""

    __slots__ = ("base", "slot", "slots")

    def __init__(self, base: int, tracks: Iterable[int]) -> None:
        self.base = base
        self.slot: dict[int, int] = {}  # track id -> slot
        self.slots: list[int] = []  # slot -> track id
        for t in sorted(tracks):
            self(t)

    def __call__(self, t: int) -> int:
        """The slot of track ``t`` (a new one if it has none)."""
        k = self.slot.get(t)
        if k is None:
            k = self.slot[t] = len(self.slots)
            self.slots.append(t)
        return k


class _Standby:
    """The stream solver that takes over at the next restart, with its numbering and the
    frames of the window not yet given to it (oldest first)."""

    __slots__ = ("solver", "num", "queue")

    def __init__(self, solver: StreamSolver, num: _Numbering, frames: Iterable[_Frame]) -> None:
        self.solver, self.num, self.queue = solver, num, deque(frames)


class SituationMonitor:
    """Detects the situations of situations.lp online, one frame result at a time.

    Args:
        config: :class:`~sensemaking.reasoning.situations.SituationConfig` (default: all six).
        context: :class:`~sensemaking.reasoning.context.SceneContext` (corridor, lanes,
            segmentation); default: the default corridor, no lanes, no segmentation.
        fps: frames per second of the sequence.
        image_size: ``(width, height)`` of the images, pixels; None when unknown: then the
            situations that need the ego corridor (HIDDEN_ENTITY, REDUCED_VISIBILITY,
            SUDDEN_STOP) are skipped, with a note.
        extra_encodings: paths of ASP files that extend situations.lp (their rules go to
            ``base``): a new situation is a rule ``warn(name,(T,...))``, warned as ``NAME``;
            its details are ``info(name,(T,...),key,value)``. The input predicates are those
            documented in situations.lp. Raises InputError for a file clingo cannot read.
        profile: the scene profile, ``driving`` (a camera on an ego vehicle) or ``fixed`` (no
            ego vehicle: situations.lp issues none of the ego-vehicle situations).
        camera: the :class:`~sensemaking.reasoning.egomotion.CameraModel` of the images (e.g.
            ``CameraModel.kitti()``): with it, motion is judged in the world (metres, m/s, the
            ego's own speed estimated from the scene); None: in the image (a fixed camera).
        ego_motion: the ego vehicle's speed per frame
            (:func:`sensemaking.io.egomotion.read_ego_motion`), used where it has the frame
            (needs ``camera``).
        ego_config: :class:`~sensemaking.reasoning.egomotion.EgoMotionConfig`.
        limits: time, memory and atom limits of ``extra_encodings`` (the user's code), checked
            once before any frame (:mod:`sensemaking.sandbox`); default: ``ask``'s.
        stream: reason on a long-lived clingo Control that takes each frame's facts once
            (:class:`~sensemaking.reasoning.situations.StreamSolver`); False: the reference,
            a fresh Control grounding the whole window every frame (same warnings, slower);
            None: :data:`STREAM`.

    ``update(result)`` once per frame in order, ``reset()`` before another sequence.
    ``stats`` counts frames, clingo calls, answers from the cache of clingo's answers and the
    time spent in ``update`` (milliseconds).
    """

    def __init__(
        self,
        config: SituationConfig | None = None,
        context: SceneContext | None = None,
        fps: float = 10.0,
        image_size: tuple[int, int] | None = (1242, 375),
        extra_encodings: Sequence[str | PathLike[str]] = (),
        profile: str = "driving",
        camera: CameraModel | None = None,
        ego_motion: EgoMotion | None = None,
        ego_config: EgoMotionConfig | None = None,
        limits: Limits | None = None,
        stream: bool | None = None,
    ):
        if profile not in PROFILES:
            raise ValueError(f"unknown scene profile {profile!r} (one of {', '.join(PROFILES)})")
        self.profile = profile
        if fps <= 0:
            raise ValueError(f"fps must be positive, got {fps}")
        if image_size is not None and (image_size[0] <= 0 or image_size[1] <= 0):
            raise ValueError(f"image_size must be (width, height) > 0, got {image_size}")
        self.config = config or SituationConfig()
        self.context = context or SceneContext()
        self.fps = float(fps)
        self.image_size = None if image_size is None else (int(image_size[0]), int(image_size[1]))
        self._window = self.config.window_frames(self.fps)
        self._lag = self.config.motion.lag_frames(self.fps)
        self._frame_ms = max(1, int(round(1000.0 / self.fps)))
        self._rearm = max(1, int(round(self.config.rearm_s * self.fps)))
        enabled = [s for s in Situation if s.name in self.config.situations]
        self._skipped: dict[Situation, str] = {}
        if Situation.BLOCKED_LANE in enabled and not self.context.lanes:
            self._skipped[Situation.BLOCKED_LANE] = "needs lanes (no lanes file given)"
        if self.image_size is None:
            for s in (
                Situation.HIDDEN_ENTITY,
                Situation.REDUCED_VISIBILITY,
                Situation.SUDDEN_STOP,
            ):
                if s in enabled:
                    self._skipped[s] = "needs the image size (for the ego corridor)"
        checked = [s.value for s in enabled if s not in self._skipped]
        self._checked = checked
        self._extra = tuple(extra_encodings)
        self._solver = SituationSolver(
            checked, self.config.constants, extra_encodings, limits=limits
        )
        self._severity, self._severity_ego = self._solver.severities()
        self.stream = STREAM if stream is None else bool(stream)
        # box area (px²) -> permille of the image
        self._permille = (
            0.0 if self.image_size is None else 1000.0 / (self.image_size[0] * self.image_size[1])
        )
        # visible boxes kept per track: anticipation fits the last velocity_points of them, and
        # motion needs the box 2 lag frames before
        self._hist_len = max(2 * self._lag, self.config.anticipation.velocity_points) + 1
        if ego_motion is not None and camera is None:
            raise ValueError("ego_motion needs a camera model (camera=CameraModel(...))")
        self._world = (
            None
            if camera is None
            else WorldMotion(camera, self.fps, self.image_size, ego_motion, ego_config)
        )
        self._stream: StreamSolver | None = None
        self.reset()

    # -- state ----------------------------------------------------------------------------------
    def reset(self) -> None:
        """Forget all history; the next update starts a new sequence."""
        self._frames: deque[_Frame] = deque(maxlen=self._window)
        # visible frames of each track: [frame, box, centre speed px/s, vx px/s, growth 1/s]
        # (speed NaN without a box lag to 2 lag frames before)
        self._hist: dict[int, deque[list[Any]]] = {}
        self._class: dict[int, int] = {}
        self._last_live: dict[int, int] = {}
        self._open: dict[tuple[str, tuple[int, ...]], _Episode] = {}
        self._episodes = 0
        self._ended: list[WarningEnd] = []
        self._boxes: dict[int, list[float]] = {}  # track -> box at the current frame
        self._seq_start: int | None = None
        self._last_frame: int | None = None
        self._anticip: dict[int, Anticipation] = {}
        # hidden track -> (Z, X cm now, VZ, VX cm/s): its last world fit, extrapolated
        self._hidden_motion: dict[int, tuple[int, int, int, int]] = {}
        self._found: list[SituationMatch] = []  # what holds at the current frame
        # its warnings, made when read (None: not yet)
        self._active: list[SituationWarning] | None = []
        self.stats: dict[str, float] = {"frames": 0, "solver_calls": 0, "cache_hits": 0, "ms": 0.0}
        if self._world is not None:
            self._world.reset()
        self._calls0, self._hits0 = self._solver.calls, self._solver.hits
        self._num: _Numbering | None = None  # the stream solver's numbering; None: not started
        self._next: _Standby | None = None  # the Control fed ahead of the next restart
        if self.stream:
            static: list[Fact] = [("frame_ms", self._frame_ms), ("profile", self.profile)]
            if self._world is not None:
                static.append(("camera",))
            self._stream = StreamSolver(
                self._checked,
                self.config.constants,
                self._extra,
                static_facts=static,
                restart_frames=STREAM_RESTART_FRAMES,
                window=self._window,
                absent=self._absent(),
            )
            self._calls0 = 0

    def __getstate__(self) -> dict[str, Any]:
        # a standby Control is not worth pickling: after a copy the next restart is a plain one
        state = dict(self.__dict__)
        state["_next"] = None
        return state

    def _absent(self) -> set[tuple[str, int]]:
        """The input predicates of situations.lp this monitor never gives (see _observe)."""
        out: set[tuple[str, int]] = set()
        if self._world is None:
            out |= WORLD_INPUTS
        if not self.context.lanes:
            out |= {("lane", 1), ("on_lane", 3)}
        if self.context.segmentation is None:
            out.add(("surface", 3))
        return out

    @property
    def skipped(self) -> dict[str, str]:
        """Situations that cannot be checked with this context, and why."""
        return {s.name: why for s, why in self._skipped.items()}

    @property
    def anticipations(self) -> list[Anticipation]:
        """Anticipated reappearances of the tracks hidden at the current frame."""
        return list(self._anticip.values())

    # -- the loop -------------------------------------------------------------------------------
    def update(self, result: FrameResult) -> list[SituationWarning]:
        """Process one frame; return the warnings whose situation starts to hold at this frame
        (and, on the first frame, a note for each situation that cannot be checked)."""
        t0 = time.perf_counter()
        f = int(result.frame)
        if self._last_frame is not None and f <= self._last_frame:
            raise ValueError(f"frames must increase: got frame {f} after {self._last_frame}")
        new: list[SituationWarning] = []
        if self._seq_start is None:
            self._seq_start = f
            if self.profile != "driving":
                log.info("scene profile %s: no ego vehicle, no ego-vehicle warnings", self.profile)
            for s, why in self._skipped.items():
                log.info("%s not checked: it %s", s.name, why)
                note = f"{s.name} not checked: it {why}"
                new.append(SituationWarning(f, s.name, (), note, {"skipped": why}))
        self._last_frame = f
        self._observe(result)
        if self._stream is not None:
            found = self._stream_answer()
        else:
            facts, tracks = self._facts()
            found = self._read(self._solver.answer(facts), tracks, f)
        self._found, self._active = found, None
        self._ended = [
            self._end(key, min(f, ep.last + self._rearm + 1), "cleared")
            for key, ep in list(self._open.items())
            if f - ep.last > self._rearm
        ]
        for d in found:
            key = (d.situation, d.objects)
            ep = self._open.get(key)
            if ep is None:
                self._episodes += 1
                ep = self._open[key] = _Episode(self._episodes, f)
                new.append(self._warning(f, d, ep.number))
            ep.last = f
        self._forget(f)
        self.stats["frames"] += 1
        if self._stream is not None:
            self.stats["solver_calls"] = self._stream.calls
        else:
            self.stats["solver_calls"] = self._solver.calls - self._calls0
            self.stats["cache_hits"] = self._solver.hits - self._hits0
        self.stats["ms"] += (time.perf_counter() - t0) * 1000.0
        return new

    def _end(self, key: tuple[str, tuple[int, ...]], frame: int, reason: str) -> WarningEnd:
        ep = self._open.pop(key)
        return WarningEnd(frame, key[0], key[1], ep.number, ep.start, ep.last, reason)

    @property
    def ended(self) -> list[WarningEnd]:
        """The warning episodes that ended at the current frame."""
        return list(self._ended)

    def finish(self, reason: str = "end_of_input") -> list[WarningEnd]:
        """End every open episode (the input ended, or was interrupted: ``reason``); at the last
        frame seen, or the frame the episode would have ended at if sooner."""
        if self._last_frame is None:
            return []
        f = self._last_frame
        return [
            self._end(key, min(f, ep.last + self._rearm + 1), reason)
            for key, ep in sorted(self._open.items(), key=lambda kv: kv[1].number)
        ]

    @property
    def active(self) -> list[SituationWarning]:
        """Every situation holding at the current frame, as warnings of this frame."""
        if self._active is None:
            f = self._last_frame
            assert f is not None  # _found is filled by update
            self._active = [
                self._warning(f, d, self._open[(d.situation, d.objects)].number)
                for d in self._found
            ]
        return list(self._active)

    def run(self, results: Iterable[FrameResult]) -> list[SituationWarning]:
        """Every warning over a sequence of frame results (after :meth:`reset`)."""
        self.reset()
        out: list[SituationWarning] = []
        for r in results:
            out.extend(self.update(r))
        return out

    # -- per-frame numbers ------------------------------------------------------------------------
    def _observe(self, result: FrameResult) -> None:
        f = int(result.frame)
        fr = _Frame(f, list(result.events))
        self._frames.append(fr)
        self._anticip = {}
        self._hidden_motion = {}
        tr = result.tracks
        if tr.tracker_id is None or tr.class_id is None:
            raise ValueError(
                f"frame {f}: the tracks of a frame result need tracker_id and class_id"
            )
        ids = tr.tracker_id.tolist()
        n = len(ids)
        self._boxes = {}
        if n == 0:
            return
        cls = tr.class_id.tolist()
        data = tr.data
        states = np.asarray(data["state"], dtype=np.int64).tolist() if "state" in data else [0] * n
        occl = (
            np.asarray(data["occluder"], dtype=np.int64).tolist()
            if "occluder" in data
            else [-1] * n
        )
        xyxy = tr.xyxy
        boxes = xyxy.tolist()
        fr.ids = ids
        self._boxes = dict(zip(ids, boxes, strict=True))
        fr.state = {t: _STATE_NAMES[s] for t, s in zip(ids, states, strict=True)}
        self._class.update(zip(ids, cls, strict=True))
        self._last_live.update(dict.fromkeys(ids, f))
        moving = []  # (track, its entry now, the entry lag frames before)
        for i, (t, s) in enumerate(zip(ids, states, strict=True)):
            if s == _VISIBLE:
                h = self._hist.get(t)
                if h is None:
                    h = self._hist[t] = deque(maxlen=self._hist_len)
                h.append([f, boxes[i], np.nan, 0.0, 0.0])
                j = self._prev_entry(h)
                if j is not None:
                    moving.append((t, h[-1], h[j]))
            elif s == _HIDDEN and occl[i] >= 0:
                fr.hidden_by[t] = occl[i]
        if moving:
            self._motion(fr, moving)
        if self._world is not None:
            vis = [i for i, s in enumerate(states) if s == _VISIBLE]
            loc = data.get("location")
            if loc is None and self._world.config.detection_location:
                loc = data.get("detection_location")  # the matched detection's, a 3D detector's
            fr.ego, fr.world = self._world.update(
                f,
                [ids[i] for i in vis],
                xyxy[vis],
                None if loc is None else np.asarray(loc, dtype=np.float64)[vis],
                [cls[i] for i in vis],
            )

        if self.image_size is not None:
            k = self._permille
            for i in np.flatnonzero(
                self.context.corridor.contains_boxes(xyxy, self.image_size)
            ).tolist():
                x1, y1, x2, y2 = boxes[i]
                fr.in_corr.append(ids[i])
                fr.area[ids[i]] = round((x2 - x1) * (y2 - y1) * k)

        if fr.hidden_by and self._world is not None:
            self._extrapolate_hidden(fr)
        if fr.hidden_by:
            by_id = dict(zip(ids, boxes, strict=True))
            for t, o in fr.hidden_by.items():
                a = self._anticipate(t, o, f, by_id)
                if a is not None:
                    self._anticip[t] = a

        # rectangle relations of near pairs with a vehicle (vehicle/vehicle, person/vehicle)
        rel = [i for i, c in enumerate(cls) if c in _ROLE]
        veh = [_ROLE[cls[i]] for i in rel]
        if len(rel) >= 2 and True in veh:
            pairs, codes = pair_relations(xyxy[rel], self.config.relations)
            front = pair_front(
                xyxy[rel], pairs, tr.depth[rel], self.image_size, config=self.config.relations
            ).tolist()
            for (i, j), (cx, cy), fa in zip(pairs.tolist(), codes.tolist(), front, strict=True):
                if veh[i] or veh[j]:
                    a, b, rx, ry = ids[rel[i]], ids[rel[j]], IA_RELATIONS[cx], IA_RELATIONS[cy]
                    fr.ra.append((a, b, rx, ry) if a < b else (b, a, INVERSE[rx], INVERSE[ry]))
                    if fa:
                        fr.front.append((a, b) if fa > 0 else (b, a))

        lanes = self.context.lanes.lanes_at(f) if self.context.lanes else ()
        if lanes:
            bottom = np.stack([(xyxy[:, 0] + xyxy[:, 2]) / 2, xyxy[:, 3]], axis=1)
            for lane in lanes:
                term = lane.id if isinstance(lane.id, int) else AspString(lane.id)
                fr.lanes.append(term)
                for i in np.flatnonzero(lane.contains_points(bottom)).tolist():
                    fr.on_lane.setdefault(ids[i], []).append(term)
        if self.context.segmentation is not None:
            for i, s in enumerate(
                self.context.segmentation.surface_under(f, xyxy, self.image_size)
            ):
                if s is not None:
                    fr.surface[ids[i]] = asp_name(s)

    def _extrapolate_hidden(self, fr: _Frame) -> None:
        """Each hidden track's last fitted world position in the window, moved on to now at its
        relative velocity then (cm, cm/s): the facts ``hidden_motion/5``."""
        for t in fr.hidden_by:
            for past in reversed(self._frames):
                m = past.world.get(t)
                if m is not None and np.isfinite(m.vz) and np.isfinite(m.vx):
                    dt = (fr.frame - past.frame) / self.fps
                    z, x = m.z + m.vz * dt, m.x + m.vx * dt
                    self._hidden_motion[t] = (_cm(z), _cm(x), _cm(m.vz), _cm(m.vx))
                    break

    def _prev_entry(self, h: deque[list[Any]]) -> int | None:
        """Index of the box ``lag`` frames before the latest entry of a history, else of the
        latest earlier one if at most ``2 lag`` frames before, else None."""
        k, lag = len(h) - 1, self._lag
        f = h[k][0]
        j = k - lag
        if j >= 0 and h[j][0] == f - lag:  # seen every frame: the box lag frames before
            return j
        for j in range(k - 1, -1, -1):
            if h[j][0] <= f - lag:
                return j if f - h[j][0] <= 2 * lag else None
        return None

    def _motion(self, fr: _Frame, moving: list[tuple[int, list[Any], list[Any]]]) -> None:
        """Qualitative motion of the visible tracks with a box lag to 2 lag frames before; keeps
        speed, vx and growth in their entries (the speed is ``stopping``'s speed before)."""
        prev = np.array([p[1] for _, _, p in moving], dtype=np.float64)
        cur = np.array([e[1] for _, e, _ in moving], dtype=np.float64)
        dt = np.array([(e[0] - p[0]) / self.fps for _, e, p in moving], dtype=np.float64)
        feats = motion_features(prev, cur, dt)
        kinds = classify_motion(
            feats, np.array([p[2] for _, _, p in moving], dtype=np.float64), self.config.motion
        )
        for (t, e, _), row, sp, vx, g in zip(
            moving,
            kinds.tolist(),
            feats.speed.tolist(),
            feats.vx.tolist(),
            feats.growth.tolist(),
            strict=True,
        ):
            e[2], e[3], e[4] = sp, vx, g
            fr.motion[t] = tuple(compress(MOTION_KINDS, row))

    def _features(self, t: int) -> tuple[float, float, float]:
        """Centre speed (px/s), horizontal speed (px/s) and growth (1/s) of ``t`` now (zeros
        when unknown)."""
        h = self._hist.get(t)
        if not h or h[-1][0] != self._frames[-1].frame or h[-1][2] != h[-1][2]:  # NaN: no motion
            return 0.0, 0.0, 0.0
        return h[-1][2], h[-1][3], h[-1][4]

    def _anticipate(
        self, t: int, o: int, f: int, boxes: dict[int, list[float]]
    ) -> Anticipation | None:
        h = self._hist.get(t)
        if not h:
            return None
        ap = self.config.anticipation
        points = ap.velocity_points
        oh = [(e[0], e[1]) for e in list(self._hist.get(o, ()))[-points:]]
        if o in boxes and (not oh or oh[-1][0] != f):
            oh.append((f, boxes[o]))  # the occluder's box now (a prediction if not visible)
        if not oh:
            return None
        th = list(h)[-points:]
        return anticipate(
            np.array([e[0] for e in th]),
            np.array([e[1] for e in th]),
            np.array([e[0] for e in oh]),
            np.array([e[1] for e in oh]),
            f,
            fps=self.fps,
            track=t,
            occluder=o,
            image_size=self.image_size,
            corridor=self.context.corridor,
            config=ap,
        )

    # -- facts and answers ----------------------------------------------------------------------
    def _facts(self) -> tuple[tuple[Fact, ...], list[int]]:
        """The facts of the window (predicates of situations.lp; frames relative to now, tracks
        by their index in the sorted ids of the window) and those ids."""
        frames = self._frames
        n = frames[-1].frame
        seen = {t for fr in frames for t in fr.ids}
        mentioned = seen.union(
            *(fr.hidden_by.values() for fr in frames),
            *((a for a in e.args if isinstance(a, int)) for fr in frames for e in fr.events),
        )
        tracks = sorted(mentioned)
        local = {t: i for i, t in enumerate(tracks)}
        out: list[Fact] = [("now", 0), ("frame_ms", self._frame_ms), ("profile", self.profile)]
        if self._seq_start is not None and self._seq_start >= frames[0].frame:
            out.append(("seq_start", self._seq_start - n))
        for t in tracks:
            if t in seen:
                c = self._class.get(t, 0)
                out.append(("track", local[t], asp_name(class_name(c))))
                if c in VEHICLES:
                    out.append(("vehicle", local[t]))
                elif c in PEOPLE:
                    out.append(("person", local[t]))
        for fr in frames:
            g = fr.frame - n
            out += [("state", local[t], g, s) for t, s in fr.state.items()]
            out += [("hidden_by", local[t], local[o], g) for t, o in fr.hidden_by.items()]
            out += [("in_corridor", local[t], g) for t in fr.in_corr]
            out += [("motion", local[t], g, k) for t, kinds in fr.motion.items() for k in kinds]
            out += [("ra", local[a], local[b], g, rx, ry) for a, b, rx, ry in fr.ra]
            out += [("front", local[a], local[b], g) for a, b in fr.front]
            out += [
                # constants in the events of a user's encoding stay as they are
                (
                    "occurs_at",
                    (e.name, *(local.get(a, a) if isinstance(a, int) else a for a in e.args)),
                    e.frame - n,
                )
                for e in fr.events
            ]
            out += _confidence_facts(fr.events, lambda a: local.get(a, a), n)
            out += [
                ("on_lane", local[t], term, g) for t, terms in fr.on_lane.items() for term in terms
            ]
            out += [("surface", local[t], g, s) for t, s in fr.surface.items()]
            if self._world is not None:
                out += world_facts(fr.ego, fr.world, local, g)
        now = frames[-1]
        out += [("area", local[t], 0, a) for t, a in now.area.items()]
        out += [("lane", term) for term in now.lanes]
        for a in self._anticip.values():
            t, o, r = local[a.track], local[a.occluder], a.reappear_frame - n
            out.append(
                ("anticipated", t, o, r, int(round(a.position[0])), int(round(a.position[1])))
            )
            if a.in_corridor:
                out.append(("anticipated_in_corridor", t, o, r))
        out += [("hidden_motion", local[t], *v) for t, v in self._hidden_motion.items()]
        return tuple(out), tracks

    def _stream_answer(self) -> list[SituationMatch]:
        """The matches of the current frame from the stream solver: the new frame's facts go
        in, the frame that left the window goes out. Frames and tracks are numbered as of the
        solver's last restart (:class:`_Numbering`). The Control that takes over at a restart
        is fed the window a share at a time over the frames before (:class:`_Standby`)."""
        solver = self._stream
        assert solver is not None
        frames = self._frames
        fr = frames[-1]
        n = fr.frame
        first = frames[0].frame
        if self._next is not None:
            self._feed(self._next, first, fr, solver.restart_frames - solver.age)
        num = self._num
        if num is None or solver.due:
            if self._next is not None:
                nxt, self._next = self._next, None
                self._feed(nxt, first, None, 1)
                solver.adopt(nxt.solver)
                num = nxt.num
            else:
                if num is not None:
                    solver.restart(keep=False)
                num = _Numbering(n, self._mentioned())
                for x in frames:
                    solver.add_frame(x.frame - n, self._frame_facts(x, num))
            self._num = num
        else:
            for g in solver.frames:
                if g + num.base < first:
                    solver.drop_frame(g)
            solver.add_frame(n - num.base, self._frame_facts(fr, num))
        base = num.base
        seen = set().union(*(x.ids for x in frames))
        window: list[Fact] = []
        if self._seq_start is not None and self._seq_start >= first:
            window.append(("seq_start", self._seq_start - base))
        for t in seen:
            c = self._class.get(t, 0)
            k = num(t)
            window.append(("track", k, asp_name(class_name(c))))
            if c in VEHICLES:
                window.append(("vehicle", k))
            elif c in PEOPLE:
                window.append(("person", k))
        window += [("lane", term) for term in fr.lanes]
        for a in self._anticip.values():
            t, o, r = num(a.track), num(a.occluder), a.reappear_frame - base
            px, py = int(round(a.position[0])), int(round(a.position[1]))
            window.append(("anticipated", t, o, r, px, py))
            if a.in_corridor:
                window.append(("anticipated_in_corridor", t, o, r))
        window += [("hidden_motion", num(t), *v) for t, v in self._hidden_motion.items()]
        solver.set_window(window)
        g = n - base
        current: list[Fact] = [("now", g)]
        current += [("area", num(t), g, a) for t, a in fr.area.items()]
        found = self._read(solver.answer(g, current), num.slots, base)
        if self._next is None and solver.age > solver.restart_frames - STREAM_STAGE_FRAMES:
            self._next = _Standby(solver.standby(), _Numbering(n, self._mentioned()), frames)
        return found

    def _feed(self, nxt: _Standby, first: int, fr: _Frame | None, left: int) -> None:
        """Give the standby solver the new frame ``fr`` (queued) and its share of the queue:
        all of it over the ``left`` frames before it takes over; frames that left the window
        are dropped."""
        solver, num, queue = nxt.solver, nxt.num, nxt.queue
        if fr is not None:
            queue.append(fr)
        while queue and queue[0].frame < first:
            queue.popleft()
        for g in solver.frames:
            if g + num.base < first:
                solver.drop_frame(g)
        for _ in range(-(-len(queue) // max(1, left))):
            x = queue.popleft()
            solver.add_frame(x.frame - num.base, self._frame_facts(x, num))
        solver.prepare()

    def _mentioned(self) -> set[int]:
        """The tracks the window's facts name: seen, occluders, events' arguments."""
        out: set[int] = set()
        for fr in self._frames:
            out.update(fr.ids)
            out.update(fr.hidden_by.values())
            for e in fr.events:
                out.update(a for a in e.args if isinstance(a, int))
        return out

    def _frame_facts(self, fr: _Frame, num: _Numbering) -> list[Fact]:
        """The facts of one frame of the window (frame relative to the solver's base, tracks
        by slot)."""
        g, local = fr.frame - num.base, num
        for t in fr.ids:  # new tracks get their slots in the order of the ids, as ever
            local(t)
        slot = num.slot  # the frame's own tracks: a lookup, not a call
        out: list[Fact] = [("state", slot[t], g, s) for t, s in fr.state.items()]
        out += [("hidden_by", slot[t], local(o), g) for t, o in fr.hidden_by.items()]
        out += [("in_corridor", slot[t], g) for t in fr.in_corr]
        out += [("motion", slot[t], g, k) for t, kinds in fr.motion.items() for k in kinds]
        out += [("ra", slot[a], slot[b], g, rx, ry) for a, b, rx, ry in fr.ra]
        out += [("front", slot[a], slot[b], g) for a, b in fr.front]
        out += [
            # constants in the events of a user's encoding stay as they are
            (
                "occurs_at",
                (e.name, *(local(a) if isinstance(a, int) else a for a in e.args)),
                e.frame - num.base,
            )
            for e in fr.events
        ]
        out += _confidence_facts(fr.events, local, num.base)
        out += [("on_lane", slot[t], term, g) for t, terms in fr.on_lane.items() for term in terms]
        out += [("surface", slot[t], g, s) for t, s in fr.surface.items()]
        if self._world is not None:
            out += [x for x in world_facts(fr.ego, fr.world, slot, g) if x[0] != "camera"]
        return out

    @staticmethod
    def _read(
        atoms: Iterable[clingo.Symbol], tracks: list[int] | None, now: int
    ) -> list[SituationMatch]:
        """``warn/2`` and ``info/4`` atoms as matches: track indices back to ids (``tracks``;
        None: the atoms name ids), ``frame(F)`` back to frame numbers (``now`` is frame 0);
        sorted by situation (the built-in ones first) and objects."""

        def track(sym: clingo.Symbol) -> int:
            if sym.type != clingo.SymbolType.Number or (
                tracks is not None and not 0 <= sym.number < len(tracks)
            ):
                raise InputError(f"situation encodings: {sym} is not a track of the window")
            return sym.number if tracks is None else tracks[sym.number]

        def objects(sym: clingo.Symbol) -> tuple[int, ...]:
            return (
                tuple(track(a) for a in sym.arguments)
                if sym.type == clingo.SymbolType.Function and not sym.name
                else (track(sym),)
            )

        def detail(sym: clingo.Symbol) -> Any:
            if sym.type == clingo.SymbolType.Function and len(sym.arguments) == 1:
                if sym.name == "frame" and sym.arguments[0].type == clingo.SymbolType.Number:
                    return sym.arguments[0].number + now
                if sym.name == "track":
                    return track(sym.arguments[0])
            return value(sym)

        warns: dict[tuple[str, tuple[int, ...]], dict[str, list[Any]]] = {}
        infos = []
        for sym in atoms:
            key = (str(value(sym.arguments[0])).upper(), objects(sym.arguments[1]))
            if sym.name == "warn":
                warns[key] = {}
            else:
                infos.append((key, str(value(sym.arguments[2])), detail(sym.arguments[3])))
        for key, k, v in infos:
            if key in warns:
                warns[key].setdefault(k, []).append(v)
        out = [
            SituationMatch(s, objs, {k: sorted(v, key=str) for k, v in info.items()})
            for (s, objs), info in warns.items()
        ]
        out.sort(key=lambda d: (_ORDER.get(d.situation, len(_ORDER)), d.situation, d.objects))
        return out

    def _forget(self, f: int) -> None:
        if f % self._window:
            return
        for t in [t for t, last in self._last_live.items() if f - last > self._window]:
            for d in (self._hist, self._class, self._last_live):
                d.pop(t, None)
        if self._world is not None:
            self._world.forget(set(self._last_live))

    # -- warnings -------------------------------------------------------------------------------
    def _describe(self, t: int) -> str:
        c = self._class.get(t)
        return f"track {t} ({class_name(c)})" if c is not None else f"track {t}"

    def _lane_position(self, point: tuple[float, float] | None) -> str:
        """``ego``, ``left``, ``right`` or ``unknown``: where ``(x, y)`` (pixels) stands relative
        to the ego lane (the rule of the module docstring)."""
        if point is None or self.profile != "driving" or self.image_size is None:
            return "unknown"
        x, y = point
        w, h = self.image_size
        ego = None
        lanes = self.context.lanes.lanes_at(self._last_frame or 0) if self.context.lanes else ()
        lowest = -np.inf
        for lane in lanes:  # the lane under the image's bottom centre, reaching lowest
            row = min(lane.left[-1, 1], lane.right[-1, 1])
            if lane.contains_points(np.array([[w / 2.0, row]]))[0] and row > lowest:
                ego, lowest = lane, row
        if ego is not None:
            xl, xr = (float(v[0]) for v in ego.span_at(np.array([y])))
        else:
            cl, cr = (float(v[0]) for v in self.context.corridor.span_at(np.array([y]), (w, h)))
            xl, xr = cl + (cr - cl) / 4, cr - (cr - cl) / 4
        if xl != xl or xr != xr:  # NaN: the row is outside the lane or the corridor
            return "unknown"
        return "left" if x < xl else "right" if x > xr else "ego"

    def _warning(self, f: int, d: SituationMatch, episode: int | None = None) -> SituationWarning:
        s, objs, info = d.situation, d.objects, d.info
        desc = self._describe
        details: dict[str, Any] = {"classes": [class_name(self._class.get(t, 0)) for t in objs]}
        for k, v in info.items():
            details[k] = v[0] if len(v) == 1 else v
        level = details.pop("confidence_permille", None)
        if isinstance(level, int):  # the encoding's permille, reported 0..1
            details["confidence"] = level / 1000
        if episode is not None:
            details["episode"] = episode
        point: tuple[float, float] | None = None
        if s == "HIDDEN_ENTITY" and objs and objs[0] in self._anticip:
            point = self._anticip[objs[0]].position
        elif objs and objs[0] in self._boxes:
            box = self._boxes[objs[0]]
            point = ((box[0] + box[2]) / 2.0, box[3])
        lane_position = self._lane_position(point)
        details["lane_position"] = lane_position
        severity = self._severity.get(s, _USER_SEVERITY)  # the encoding's severity/2
        if lane_position == "ego":
            severity = self._severity_ego.get(s, severity)
        given = details.get("severity")
        if isinstance(given, int) and given in SEVERITY_NAMES:  # a user's encoding says it
            severity = given
        details["severity"] = severity
        if s == "OVERTAKING":
            a, b = objs
            kmh = [_kmh(info, k) for k in ("speed_cms", "overtaken_speed_cms")]
            msg = f"{desc(a)}{kmh[0]} is overtaking {desc(b)}{kmh[1]}"
        elif s == "HIDDEN_ENTITY" and objs[0] in self._anticip:
            t, o = objs
            ant = self._anticip[t]
            details["anticipation"] = ant.to_json()
            details["lead_frames"], details["lead_s"] = ant.lead_frames, round(ant.lead_s, 3)
            msg = (
                f"{desc(t)} is hidden behind {desc(o)} and may reappear in front of the ego "
                f"vehicle at frame {ant.reappear_frame} (in {ant.lead_frames} frames, "
                f"{ant.lead_s:.1f} s) at "
                f"x={ant.position[0]:.0f}, y={ant.position[1]:.0f} px"
            )
        elif s == "REDUCED_VISIBILITY":
            (o,) = objs
            parts = []
            if "area_permille" in details:
                parts.append(f"it takes {details['area_permille'] / 10:.0f}% of the image")
            hides = info.get("hides", [])
            if hides:
                parts.append("it hides " + ", ".join(desc(h) for h in hides))
            msg = f"{desc(o)} in front of the ego vehicle reduces visibility" + (
                f" ({'; '.join(parts)})" if parts else ""
            )
        elif s == "SUDDEN_STOP" and "distance_cm" in info:  # judged over the road
            (veh,) = objs
            z, c = info["distance_cm"][0] / 100.0, info.get("closing_cms", [0])[0] / 100.0
            details["ttc_s"] = round(z / c, 2) if c > 0 else None
            how = "stops" if "stopping" in info.get("cause", []) else "brakes hard"
            msg = (
                f"{desc(veh)} {z:.0f} m ahead in the ego lane {how}{_kmh(info, 'speed_cms')}: "
                f"the gap closes at {c * 3.6:.0f} km/h"
                + (f", time to contact {z / c:.1f} s" if c > 0 else "")
            )
        elif s == "SUDDEN_STOP":
            (veh,) = objs
            sp, vx, g = self._features(veh)
            details.update(
                {"speed_px_s": round(sp, 1), "vx_px_s": round(vx, 1), "growth_per_s": round(g, 3)}
            )
            if "stopping" in info.get("cause", []):
                msg = f"{desc(veh)} in front of the ego vehicle stops suddenly"
            else:
                details["ttc_s"] = round(1.0 / g, 2) if g > 0 else None
                ttc = f" (time to contact about {1.0 / g:.1f} s)" if g > 0 else ""
                msg = (
                    f"{desc(veh)} in front of the ego vehicle brakes: "
                    f"the ego vehicle closes in fast{ttc}"
                )
        elif s == "BLOCKED_LANE":
            (t,) = objs
            lanes = info.get("lane", [])
            lane_names = ", ".join(str(x) for x in lanes) or "?"
            msg = f"lane {lane_names} is blocked by {desc(t)}, standing still"
        elif s == "EXITING_VEHICLE":
            p, veh = objs
            msg = (
                f"{desc(p)} appeared next to {desc(veh)}, which stands still: "
                "a person may be getting out"
            )
        else:  # a situation of a user's encoding
            msg = f"{s.lower().replace('_', ' ')}: " + ", ".join(desc(t) for t in objs)
        return SituationWarning(f, s, tuple(int(o) for o in objs), msg, details)
