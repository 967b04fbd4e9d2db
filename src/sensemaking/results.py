"""What the tracker returns each frame: tracks with their states, and the abduced events."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum
from typing import TYPE_CHECKING

import numpy as np

from sensemaking.detections import Detections
from sensemaking.vocabulary import EVENT_NAMES

if TYPE_CHECKING:  # pragma: no cover
    from sensemaking.abduction.problem import FrameProblem
    from sensemaking.abduction.solver import AbductionSolver

__all__ = [
    "TrackState",
    "Visibility",
    "VISIBILITY_VALUES",
    "STATE_NAMES",
    "Event",
    "FrameResult",
    "FrameAbduction",
    "EVENT_NAMES",
]


class TrackState(IntEnum):
    """Per-frame state of a live track (``FrameResult.tracks.data["state"]``)."""

    VISIBLE = 0  #: matched to a detection this frame
    HIDDEN = 1  #: abduced to be hidden behind another track (``data["occluder"]`` names it)
    MISSING = 2  #: not detected, explained as missing detections (or otherwise unobserved)


class Visibility(IntEnum):
    """Values of the ``visibility(T)`` fluent (``FrameResult.tracks.data["visibility"]``)."""

    FULLY_VISIBLE = 0
    PARTIALLY_OCCLUDED = 1
    FULLY_OCCLUDED = 2

    @property
    def asp(self) -> str:
        return self.name.lower()


#: the values of the ``visibility(T)`` fluent in ASP, indexed by :class:`Visibility`
VISIBILITY_VALUES: tuple[str, ...] = tuple(v.asp for v in Visibility)
#: the names of the track states (scene files, ``state/3`` facts), indexed by :class:`TrackState`
STATE_NAMES: tuple[str, ...] = tuple(s.name.lower() for s in TrackState)


@dataclass(frozen=True, order=True)
class Event:
    """One abduced event: ``name(args...)`` occurring at ``frame``; args are track ids (or
    constants, in events of a user's encoding). Its JSON record: :mod:`sensemaking.records`."""

    frame: int
    name: str
    args: tuple[int | str, ...]
    #: how sure the encoding is of the event, 0..1 (the hiding events: see tracking.lp's
    #: ``hide_confidence``); None where it states none. Not part of the event's identity.
    confidence: float | None = field(default=None, compare=False)

    def sort_key(self) -> tuple[int, str, tuple[tuple[int, int, str], ...]]:
        """Order of events: by frame, name, then arguments, track ids before constants (the
        dataclass order compares an id with a constant, which raises)."""
        return (
            self.frame,
            self.name,
            tuple((1, 0, a) if isinstance(a, str) else (0, int(a), "") for a in self.args),
        )

    def __str__(self) -> str:
        return f"{self.name}({', '.join(map(str, self.args))})@{self.frame}"


@dataclass(frozen=True, eq=False)
class FrameAbduction:
    """What the tracker abduced a frame's answer from, to ask it again (``ask why``).

    Attributes:
        problem: the frame's :class:`~sensemaking.abduction.problem.FrameProblem` (detections
            by row of the frame's input).
        new_tracks: detection row -> id of the track it started this frame (tentative ones too),
            or of the ended track it revived (``revive_s``).
        solver: the solver (program, constants, work budget) that answered it.
    """

    problem: FrameProblem
    new_tracks: dict[int, int]
    solver: AbductionSolver


@dataclass(frozen=True, eq=False)
class FrameResult:
    """The tracker's answer for one frame.

    Attributes:
        frame: the frame number of the input detections.
        tracks: every live track (visible, hidden and missing), ``tracker_id`` set. For a
            visible track ``xyxy``/``confidence``/``source_row`` are those of its detection;
            for a hidden or missing one ``xyxy`` is the Kalman prediction and ``source_row`` -1.
            ``data`` columns: ``state`` (:class:`TrackState`), ``occluder`` (track id or -1),
            ``visibility`` (:class:`Visibility`), ``hidden_frames`` (frames since last seen).
        events: the events of this frame, sorted. A tentative track's start event
            (``starts``/``enters_fov``) is reported, and dated, at the frame the track is
            confirmed: the first frame it is output.
        solve_ms: wall time of the abduction step (grounding + solving), milliseconds.
        timed_out: True when the solve budget ran out and the best answer so far was used.
        abduction: the frame's problem as the encoding saw it (:class:`FrameAbduction`), or
            None (no abduction this frame, or a fallback to Hungarian matching).
    """

    frame: int
    tracks: Detections
    events: list[Event] = field(default_factory=list)
    solve_ms: float = 0.0
    timed_out: bool = False
    abduction: FrameAbduction | None = None

    @property
    def visible(self) -> Detections:
        """Only the tracks matched to a detection this frame."""
        return self.tracks[self.tracks.data["state"] == TrackState.VISIBLE]

    @property
    def hidden(self) -> Detections:
        """Only the tracks abduced to be hidden behind another track."""
        return self.tracks[self.tracks.data["state"] == TrackState.HIDDEN]

    def state_of(self, track_id: int) -> TrackState | None:
        """The state of one track this frame, or None when it is not live."""
        idx = np.flatnonzero(self.tracks.tracker_id == track_id)
        return TrackState(int(self.tracks.data["state"][idx[0]])) if idx.size else None
