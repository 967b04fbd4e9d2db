"""The online tracker: ``Tracker.update(detections) -> FrameResult`` (Algorithm 1 of the paper).

Per frame: Kalman prediction of every track, IoU of predictions and detections as the matching
likelihood, gating in numpy, then clingo abduces the assignment together with the events that
explain it (``abduction=True``), or plain Hungarian IoU matching does the assignment
(``abduction=False``: the paper's "without abduction", for ablations).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any

import numpy as np

from sensemaking import asp
from sensemaking.abduction.components import ComponentSolver, SolverCache
from sensemaking.abduction.confidence import CONFIDENCE_CONSTANTS, HideConfidence
from sensemaking.abduction.hungarian import match_hungarian
from sensemaking.abduction.observe import frame_problem, likelihood, likelihood_grid, quantize
from sensemaking.abduction.problem import GONE_EVENTS, VISIBILITY_VALUES, FrameProblem
from sensemaking.abduction.solver import (
    AbductionSolver,
    Answer,
    Det,
    Ref,
    load_encoding,
    read_encoding,
)
from sensemaking.adapters import as_detections
from sensemaking.config import AbductionCosts, KalmanConfig, TrackerConfig
from sensemaking.detections import (
    Detections,
    check_frame_number,
    check_frame_size,
    check_live_tracks,
    validate_detections,
)
from sensemaking.results import Event, FrameAbduction, FrameResult, TrackState
from sensemaking.sandbox import Limits, check_user_encoding
from sensemaking.track_table import EndedTracks, TrackTable
from sensemaking.vocabulary import REVIVE_EVENTS, START_EVENTS

# the configuration lives in sensemaking.config; re-exported here, where users import it from
__all__ = [
    "TrackerConfig",
    "AbductionCosts",
    "KalmanConfig",
    "Tracker",
    "FrameResult",
    "Event",
    "TrackState",
]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class TrackerState:
    """What :meth:`Tracker.snapshot` keeps: the track table (with its Kalman filters), the
    tracks that ended a moment ago (``revive_s``), the start events of tentative tracks, the
    next id and the frame counters."""

    tracks: TrackTable
    ended: EndedTracks
    pending: dict[int, Event]
    next_id: int
    frames_seen: int
    last_frame: int | None


#: ``scene_shift`` needs at least this many matched established tracks: a median of three
#: outvotes one object that manoeuvres on its own
SCENE_SHIFT_MIN_TRACKS = 3


class Tracker:
    """Online multi-object tracker with abductive explanations.

    ``update(detections)`` once per frame, in order; ``reset()`` before a new sequence.
    """

    def __init__(
        self,
        config: TrackerConfig | None = None,
        *,
        encoding: str | Path | None = None,
        rules: str | Path | Sequence[str | Path] = (),
        solver_cache: SolverCache | None = None,
        limits: Limits | None = None,
        confidence: str | Path | None = None,
        **overrides: Any,
    ):
        """Args:
        config: the parameters (default :class:`TrackerConfig`); ``overrides`` change some.
        encoding: an encoding (a ``.lp`` path or its text) that replaces the packaged
            ``tracking.lp``; it reads the same facts and shows the same atoms.
        rules: more rules (``.lp`` paths or text) added to the encoding, e.g. your own
            events: ``occurs(stops(T)) :- track(T), speed(T,S), S < 5.`` is reported as an
            event ``stops`` on every frame where it holds (see ``tracking.lp``'s facts).
        solver_cache: where clingo's answers and ground Controls are remembered (default: the
            process's :data:`~sensemaking.abduction.components.SHARED`, shared by every tracker
            of the process not given its own). Where optimal answers tie, which one a frame
            gets may depend on what the cache's trackers solved before: give a tracker a
            ``SolverCache()`` of its own for an output that depends on its input only.
        limits: time, memory and atom limits of a user's encoding or rules: checked once
            before any frame (grounded and solved without facts in a limited child process,
            :mod:`sensemaking.sandbox`); the atom limit holds for every frame too. Default:
            ``ask``'s limits.
        confidence: rules (a ``.lp`` path or its text) that replace the packaged
            ``confidence.lp``: how sure each hiding is (the events' ``confidence``). They read
            the facts documented there and show ``confidence(E,C)``, 0..1000.
        """
        self.config = (
            replace(config or TrackerConfig(), **overrides)
            if overrides
            else (config or TrackerConfig())
        )
        c = self.config
        extra = [rules] if isinstance(rules, (str, Path)) else list(rules)
        constants = {
            # thresholds on the likelihood grid, rounded down so that every pair the numpy
            # gate admits also passes the encoding's constraint
            "iou_assign": quantize(c, np.array([c.iou_assign]), np.floor)[0],
            "iou_resume": quantize(c, np.array([c.iou_resume]), np.floor)[0],
            # confidence gates are applied in numpy in the detector's own units: detections
            # too weak to start a track get confidence 0 in the facts, all others >= 1
            "conf_assign": 0,
            "conf_start": 1,
            "class_aware": int(c.class_aware),
            # evidence for a hiding, per mille of the hidden track's box (1001: never)
            "hide_min_cover": int(np.floor(c.hide_sure_cover * 1000)),
            "hide_late_cover": int(np.floor(c.late_hide_cover * 1000)) if c.late_hides else 1001,
            "late_confidence": int(round(c.late_confidence * 1000)),
            "late_maybe": int(c.late_maybe),
            "depth_clear": int(np.floor(c.depth_clear * 1000)),
            "depth_confidence": int(round(c.depth_confidence * 1000)),
            # every event cost is tracking.lp's #const cost_<name>
            **{f"cost_{name}": value for name, value in _costs(c).items()},
            # only when on: the constants (recorded in scene files) stay as they were
            **({"direction_weight": c.direction_weight} if c.direction_weight else {}),
            **({"size_weight": c.size_weight} if c.size_weight else {}),
            **(
                {
                    "swap_weight": c.swap_weight,
                    "swap_margin": round(c.swap_margin * 1000),
                    "swap_behind": int(c.swap_behind),
                }
                if c.swap_weight
                else {}
            ),
        }
        base = None if encoding is None else read_encoding(encoding)
        rule_texts = [read_encoding(r) for r in extra]
        names = asp.mentioned("\n".join((base or load_encoding(), *rule_texts)))
        solver = AbductionSolver(
            # the confidence's constants are confidence.lp's (unless the program reads them): a
            # change of them is no new frame program, no new answer cache
            constants={
                k: v for k, v in constants.items() if k not in CONFIDENCE_CONSTANTS or k in names
            },
            encoding=base,
            rules=rule_texts,
            max_conflicts=c.max_conflicts,
            unread=_unread(encoding is None, constants, rule_texts),
        )
        packaged = encoding is None and not extra
        if not packaged:  # the user's code, under ask's limits (issue 24)
            _check_user_program(solver, [encoding, *extra], limits or Limits())
        self._confidence = HideConfidence(
            {k: constants[k] for k in CONFIDENCE_CONSTANTS},
            None if confidence is None else read_encoding(confidence),
        )
        if confidence is not None:
            _check_user_program(self._confidence, [confidence], limits or Limits())
        decompose = packaged if c.decompose is None else c.decompose
        self._solver = ComponentSolver(
            solver, decompose=decompose, numbers=likelihood_grid(c), cache=solver_cache
        )
        self.reset()

    # -- state ------------------------------------------------------------------------------
    def reset(self) -> None:
        """Forget every track; the next update is a first frame. Ids start again at 1."""
        self._tracks = TrackTable(self.config.kalman_config)
        #: tracks ended a moment ago that a detection may revive (``revive_s``)
        self._ended = EndedTracks(self.config.kalman_config)
        self._revive = self.config.revive_frames if self.config.abduction else 0
        self._pending: dict[int, Event] = {}  # start events of tentative tracks
        self._next_id = 1
        self._frames_seen = 0
        self._last_frame: int | None = None
        self.stats = {"frames": 0, "timed_out": 0, "fallback": 0, "solve_ms": 0.0}

    @property
    def n_tracks(self) -> int:
        """Live tracks (visible, hidden and missing, confirmed or not)."""
        return int(self._tracks.id.shape[0])

    @property
    def tracks(self) -> TrackTable:
        """The live tracks (one row each, confirmed or not, with their Kalman filters): for
        reading; the tracker changes them in :meth:`update`."""
        return self._tracks

    @property
    def solver(self) -> ComponentSolver:
        """The solver that answers each frame's problem (component by component)."""
        return self._solver

    # -- the loop: Algorithm 1 ----------------------------------------------------------------
    def update(self, detections: Any, frame: int | None = None) -> FrameResult:
        """Process one frame of detections; return every live confirmed track and the events.

        Args:
            detections: :class:`Detections` of one frame (or anything ``adapters.as_detections``
                takes: supervision Detections, ultralytics results, (N, 4|5|6) arrays).
            frame: the frame number; default: the detections' frame column, else last + 1.
        """
        return self.decide(detections, frame)[0]

    def decide(
        self,
        detections: Any,
        frame: int | None = None,
        answer: Answer | None = None,
        *,
        keep_problem: bool = False,
    ) -> tuple[FrameResult, Answer, FrameProblem | None]:
        """:meth:`update`, the frame's answer that was applied and, with ``keep_problem``, a
        copy of the problem as it was solved (the result's problem shares arrays with the
        track table, which the answer then changes). With ``answer`` given (a hypothesis of
        the look-ahead, :mod:`sensemaking.lookahead`) that answer is applied instead of the
        frame's own optimum (the problem is still built, for the result)."""
        dets, frame = self._admit(detections, frame)
        pred = self._predict()  # Kalman prediction of every track
        t0 = time.perf_counter()
        # likelihood and gating (observe.frame_problem), then abduction (or matching without it)
        if answer is None:
            problem, answer, timed_out = self._explain(pred, dets)
        else:
            problem, timed_out = self.problem(dets, pred), False
        solve_ms = (time.perf_counter() - t0) * 1000.0
        self.stats["solve_ms"] += solve_ms
        solved = frozen_problem(problem) if keep_problem and problem is not None else None
        # how sure each hiding is: read off the problem before the answer changes its tracks
        sure = {} if problem is None else self._confidence.levels(problem, answer)
        events, observed = self._apply(answer, dets, frame, sure)  # update the tracks
        abduction = None
        if problem is not None:
            started = set(answer.start)
            revived = set(problem.gone_id.tolist())  # the candidates; those in observed revived
            new_tracks = {
                row: tid for tid, row in observed.items() if row in started or tid in revived
            }
            abduction = FrameAbduction(problem, new_tracks, self._solver.solver)
        result = FrameResult(
            frame=frame,
            tracks=self._output(dets, observed, frame),
            events=events,
            solve_ms=solve_ms,
            timed_out=timed_out,
            abduction=abduction,
        )
        return result, answer, solved

    def snapshot(self) -> TrackerState:
        """A copy of the tracker's state (tracks, Kalman filters, waiting events, ids, frame
        counters; not the solver or its caches): :meth:`restore` returns to it."""
        return TrackerState(
            self._tracks.copy(),
            self._ended.copy(),
            dict(self._pending),
            self._next_id,
            self._frames_seen,
            self._last_frame,
        )

    def restore(self, state: TrackerState) -> None:
        """Return to a :meth:`snapshot` (copied again: the snapshot can be restored twice)."""
        self._tracks = state.tracks.copy()
        self._ended = state.ended.copy()
        self._pending = dict(state.pending)
        self._next_id = state.next_id
        self._frames_seen = state.frames_seen
        self._last_frame = state.last_frame

    def _admit(self, detections: Any, frame: int | None) -> tuple[Detections, int]:
        """The frame's checked detections and its number; checked before any state changes,
        so a refused frame leaves the tracker as it was."""
        dets = validate_detections(_coerce(detections), self.config.image_size)
        check_frame_size(len(dets), frame)  # per-frame work is (tracks x detections)
        if frame is not None:
            frame = check_frame_number(frame)
        if frame is None:
            if len(dets):
                frame = int(dets.frame[0])
            else:
                frame = 0 if self._last_frame is None else self._last_frame + 1
        if len(dets) and (dets.frame != frame).any():
            dets = dets.with_(frame=np.full(len(dets), frame))
        if self._last_frame is not None and frame <= self._last_frame:
            raise ValueError(f"frames must increase: got frame {frame} after {self._last_frame}")
        check_live_tracks(len(self._tracks), frame)  # and bounded in tracks too
        self._last_frame = frame
        self._frames_seen += 1
        self.stats["frames"] += 1
        return dets, frame

    def _predict(self) -> np.ndarray:
        """(T, 4) every track's box predicted for this frame (the Kalman bank moves on)."""
        if self.config.unseen_damping < 1.0:  # an unseen track's image velocity fades (issue 27)
            unseen = self._tracks.unseen > 0
            if unseen.any():
                self._tracks.kf.damp(unseen, self.config.unseen_damping)
        if len(self._ended):
            self._age_ended()
        return self._tracks.kf.predict(1) if len(self._tracks) else np.zeros((0, 4))

    def _age_ended(self) -> None:
        """One more frame for the ended tracks: unseen, older, forgotten past ``revive_s``;
        without ``revive_hold`` their predictions move on."""
        ended = self._ended
        ended.age += 1
        ended.table.unseen += 1
        if (ended.age > self._revive).any():
            ended.keep(ended.age <= self._revive)
        if len(ended) and not self.config.revive_hold:
            ended.table.kf.predict(1)

    def _explain(
        self, pred: np.ndarray, dets: Detections
    ) -> tuple[FrameProblem | None, Answer, bool]:
        """(the abduced problem or None, the frame's answer, whether a budget cut it): the
        abduction, or Hungarian matching without it (``abduction=False``)."""
        if not self.config.abduction:
            return None, match_hungarian(self._tracks, pred, dets, self.config), False
        return self._abduce(pred, dets)

    # -- association --------------------------------------------------------------------------
    def problem(self, dets: Detections, pred: np.ndarray | None = None) -> FrameProblem:
        """The abduction problem of ``dets`` against the live tracks, without changing them;
        ``pred`` (T, 4): the predicted boxes (default: the next frame's prediction)."""
        if pred is None:
            pred = self._tracks.kf.peek(1) if len(self._tracks) else np.zeros((0, 4))
        return frame_problem(
            self._tracks,
            pred,
            dets,
            self.config,
            first_frame=self._frames_seen == 1,
            speed="speed" in self._solver.solver.uses,
            gone=self._ended if len(self._ended) else None,
        )

    def likelihood(self, pred: np.ndarray, dets: Detections) -> np.ndarray:
        """(T, D) gated likelihood of predictions ``pred`` (T, 4) and ``dets``
        (:func:`~sensemaking.abduction.observe.likelihood`)."""
        return likelihood(self._tracks, pred, dets, self.config)

    def _abduce(
        self, pred: np.ndarray, dets: Detections
    ) -> tuple[FrameProblem | None, Answer, bool]:
        """Abduce the frame through the encoding (component by component, see
        :mod:`sensemaking.abduction.components`); Hungarian matching if no model in budget."""
        problem = self.problem(dets, pred)
        answer = self._solver.solve(problem, budget_ms=self.config.max_solve_ms)
        if answer is None:
            self.stats["timed_out"] += 1
            self.stats["fallback"] += 1
            return None, match_hungarian(self._tracks, pred, dets, self.config), True
        cut = answer.timed_out or answer.budget_hit
        if cut:
            self.stats["timed_out"] += 1
        return problem, answer, cut

    # -- applying the answer ----------------------------------------------------------------------
    def _apply(
        self,
        ans: Answer,
        dets: Detections,
        frame: int,
        sure: dict[tuple[str, tuple[Ref, ...]], int] | None = None,
    ) -> tuple[list[Event], dict[int, int]]:
        """Update the tracks by the answer; return this frame's events and
        ``track id -> detection row`` of every track observed this frame (matched or new).
        ``sure``: the confidence (0..1000) of some of the answer's events, by name and args."""
        if len(self._tracks) == 0 and not (ans.start or ans.events or ans.fluents):
            return [], {}  # no track before or after: nothing to update, confirm or report
        if len(self._ended) and ans.resume:
            self._revive_tracks(ans)
        index = self._tracks.row_of()
        matched = {**ans.assign, **ans.resume}
        camera = self._correct_matched(matched, index, dets)
        # new tracks first, so that fluents and events can name them
        new_ids = self._start_new(ans, dets)
        observed = {**matched, **{t: d.row for d, t in new_ids.items()}}
        if self.config.direction_weight and observed:
            self._record_trail(observed, dets, frame)
        self._carry_fluents(ans, index, new_ids)
        self._mark_unobserved(ans.halt + ans.ignore_trk, index, camera)
        events = self._confirm(frame)
        events += self._report_events(ans, new_ids, frame, sure or {})
        if self._revive and ans.end:
            self._keep_ended(ans)
        self._drop_ended(set(ans.end))
        events.sort(key=Event.sort_key)
        return events, observed

    def _revive_tracks(self, ans: Answer) -> None:
        """Move the ended tracks the answer revives (shown as resumed) back to the live ones,
        unseen since they were last seen: they are corrected as any resumed track. A revived
        track is confirmed again as a new one is, its history counting as one detection (with
        ``min_hits`` 3 it is reported from its second detection on): a detection that flickers
        once where a track ended does not bring it back."""
        gone = set(self._ended.table.id.tolist())
        revived = [t for t in ans.resume if t in gone]
        if revived:
            rows = self._ended.pop(revived)
            rows.state[:] = TrackState.MISSING
            rows.occluder[:] = -1
            rows.confirmed[:] = False
            rows.hits[:] = 1  # the correction adds this frame's detection
            self._tracks.extend(rows)

    def _keep_ended(self, ans: Answer) -> None:
        """Keep the confirmed tracks the answer ends by leaves_fov or ends, to revive."""
        how = {
            args[0]: GONE_EVENTS.index(name)
            for name, args in ans.events
            if name in GONE_EVENTS and args and isinstance(args[0], int)
        }
        t = self._tracks
        rows = np.array(
            [i for i, tid in enumerate(t.id.tolist()) if tid in how and t.confirmed[i]],
            dtype=np.int64,
        )
        if len(rows):
            self._ended.add(t.take(rows), np.array([how[int(t.id[i])] for i in rows]))

    def _correct_matched(
        self, matched: dict[int, int], index: dict[int, int], dets: Detections
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """Correct the matched tracks (``track id -> detection row``) by their detections;
        return the scene's image motion that the predictions missed, ``(centre shift (2,)
        pixels, velocity change (2,) pixels/frame)``, with ``scene_shift`` (else None)."""
        if not matched:
            return None
        c = self.config
        kf = self._tracks.kf
        camera: tuple[np.ndarray, np.ndarray] | None = None
        rows = np.array([index[t] for t in matched], dtype=np.int64)
        cols = np.array(list(matched.values()), dtype=np.int64)
        settled = rows[self._settled(rows)] if c.scene_shift else rows[:0]
        if len(settled) >= SCENE_SHIFT_MIN_TRACKS:
            before = kf.motion(settled)
        gaps = self._tracks.unseen[rows]
        back = gaps > 0
        # distinct rows in range, gated boxes: the bank's unchecked update
        if c.resume_reupdate and back.any():
            if not back.all():
                kf.update_trusted(rows[~back], dets.xyxy[cols[~back]])
            kf.reupdate(rows[back], dets.xyxy[cols[back]], gaps[back])
        else:
            kf.update_trusted(rows, dets.xyxy[cols])
        if len(settled) >= SCENE_SHIFT_MIN_TRACKS:
            # the median correction of the established tracks' centres and velocities: the
            # image motion of the scene that their predictions missed this frame
            change = np.median(kf.motion(settled) - before, axis=0)
            camera = (change[0], change[1])
        self._tracks.unseen[rows] = 0
        self._tracks.state[rows] = TrackState.VISIBLE
        self._tracks.hits[rows] += 1
        self._tracks.conf[rows] = dets.confidence[cols]
        self._tracks.depth[rows] = dets.depth[cols]
        return camera

    def _record_trail(self, observed: dict[int, int], dets: Detections, frame: int) -> None:
        """Add this frame's observations (``track id -> detection row``) to the tracks'
        trails, from which their directions of motion are read (``direction_weight``)."""
        index = self._tracks.row_of()
        rows = np.array([index[t] for t in observed], dtype=np.int64)
        cols = np.array(list(observed.values()), dtype=np.int64)
        self._tracks.record(rows, frame, dets.xyxy[cols])

    def _start_new(self, ans: Answer, dets: Detections) -> dict[Det, int]:
        """Start a track for each detection the answer starts; ``detection -> new track id``
        (ids in detection order). Confirmation follows the general rule (:meth:`_confirm`)."""
        if not ans.start:
            return {}
        new_vis = {
            a[0].row: v for n, a, v in ans.fluents if n == "visibility" and isinstance(a[0], Det)
        }
        cols = np.array(sorted(ans.start), dtype=np.int64)
        ids = np.arange(self._next_id, self._next_id + len(cols), dtype=np.int64)
        self._next_id += len(cols)
        vis = [VISIBILITY_VALUES.index(new_vis.get(j, "fully_visible")) for j in cols.tolist()]
        self._tracks.add(
            ids,
            dets.xyxy[cols],
            dets.class_id[cols],
            dets.confidence[cols],
            np.array(vis),
            velocity=self.scene_velocity(dets.class_id[cols]),
            depth=dets.depth[cols],
        )
        return {Det(k): int(t) for k, t in zip(cols.tolist(), ids.tolist(), strict=True)}

    def _carry_fluents(self, ans: Answer, index: dict[int, int], new_ids: dict[Det, int]) -> None:
        """Set the fluents the answer changed; the others carry on (inertia)."""
        for fname, fargs, value in ans.fluents:
            if fname not in ("hidden_by", "visibility"):
                continue  # the tracker carries these two (and in_fov, true while live)
            # None for ended tracks and new ones (a Det, set by _start_new)
            i = index.get(fargs[0]) if isinstance(fargs[0], int) else None
            if i is None:
                continue
            if fname == "hidden_by":
                occluder = new_ids[fargs[1]] if isinstance(fargs[1], Det) else fargs[1]
                if value == "true":
                    self._tracks.occluder[i] = occluder
                elif self._tracks.occluder[i] == occluder:
                    self._tracks.occluder[i] = -1
            elif fname == "visibility":
                self._tracks.vis[i] = VISIBILITY_VALUES.index(value)

    def _mark_unobserved(
        self,
        unobserved: list[int],
        index: dict[int, int],
        camera: tuple[np.ndarray, np.ndarray] | None,
    ) -> None:
        """Tracks without a detection this frame: hidden behind their occluder, or missing;
        with ``scene_shift`` they move with the scene's image motion (``camera``)."""
        for t in unobserved:
            i = index[t]
            self._tracks.unseen[i] += 1
            self._tracks.state[i] = (
                TrackState.HIDDEN if self._tracks.occluder[i] >= 0 else TrackState.MISSING
            )
        if camera is not None and unobserved:
            rows = np.array([index[t] for t in unobserved], dtype=np.int64)
            self._tracks.kf.shift(rows, *camera)

    def _confirm(self, frame: int) -> list[Event]:
        """Confirm the tentative tracks with enough evidence; return their start events, which
        waited until now and are dated now: the first frame the track is output (the event log
        agrees with the tracks)."""
        c = self.config
        events: list[Event] = []
        tentative = ~self._tracks.confirmed
        if not tentative.any():
            return events  # every track is confirmed already
        confirm = (self._tracks.hits >= c.min_hits) | (self._frames_seen <= c.min_hits)
        if c.confirm_confidence is not None:
            confirm |= (self._tracks.unseen == 0) & (self._tracks.conf >= c.confirm_confidence)
        newly_confirmed = tentative & confirm
        self._tracks.confirmed |= newly_confirmed
        for i in np.flatnonzero(newly_confirmed).tolist():
            pending = self._pending.pop(int(self._tracks.id[i]), None)
            if pending is not None:
                events.append(replace(pending, frame=frame))
        return events

    def _report_events(
        self,
        ans: Answer,
        new_ids: dict[Det, int],
        frame: int,
        levels: dict[tuple[str, tuple[Ref, ...]], int],
    ) -> list[Event]:
        """The answer's events, with detections renamed to their new track ids; a tentative
        track's events other than its start are not reported, its start waits
        (:meth:`_confirm`). ``levels``: confidences of events (the program's own
        ``confidence/2``, if it shows any, comes first)."""
        events: list[Event] = []
        confirmed = set(self._tracks.id[self._tracks.confirmed].tolist()) if ans.events else set()
        sure = {**levels, **{(n, a): c for n, a, c in ans.confidence}}
        for name, args in ans.events:
            if any(isinstance(a, Det) and a not in new_ids for a in args):
                log.debug("event %s names a detection that starts no track: not reported", name)
                continue
            ids_ = tuple(new_ids[a] if isinstance(a, Det) else a for a in args)
            level = sure.get((name, args))
            ev = Event(frame, name, ids_, None if level is None else level / 1000)
            if not ids_ or ids_[0] in confirmed or not isinstance(ids_[0], int):
                events.append(ev)
            elif name in START_EVENTS or name in REVIVE_EVENTS:
                self._pending[ids_[0]] = ev
        return events

    def _drop_ended(self, ended: set[int]) -> None:
        """Remove the tracks the answer ends (and their waiting start events)."""
        if not ended:
            return
        self._tracks.drop(np.array([t not in ended for t in self._tracks.id.tolist()], dtype=bool))
        for t in ended:
            self._pending.pop(t, None)

    def _settled(self, rows: np.ndarray | slice = slice(None)) -> np.ndarray:
        """(K,) bool of ``rows`` (default every track): established tracks, visible last frame
        and seen ``min_hits`` + 2 times or more (their velocity is known)."""
        t = self._tracks
        return (t.unseen[rows] == 0) & (t.hits[rows] >= self.config.min_hits + 2)

    def scene_velocity(self, classes: np.ndarray | None = None) -> np.ndarray:
        """(K, 4) prior velocity of K new tracks of ``classes`` (pixels per frame): the median
        ``cx, cy`` velocity of the established visible tracks of the same class, 0 without
        ``inherit_motion`` or without any of them ((4,) over every class when ``classes`` is
        None). One established track is enough: a lone car leading a convoy into view is the
        only motion known, and the fit at rest still counts for the new tracks (see
        ``observe.uncertain_boxes``). Per class because cars and pedestrians move apart: a
        joint run of several classes starts each class's tracks as its own run would."""
        pooled = classes is None
        kinds = np.zeros(1, dtype=np.int64) if classes is None else np.asarray(classes)
        prior = np.zeros((len(kinds), 4))
        if self.config.inherit_motion and len(self._tracks):
            settled = self._settled()
            velocity = self._tracks.kf.velocity()[:, :2]
            for cls in np.unique(kinds).tolist():
                same = settled if pooled else settled & (self._tracks.cls == cls)
                if same.any():
                    prior[kinds == cls, :2] = np.median(velocity[same], axis=0)
        return prior[0] if pooled else prior

    def _output(self, dets: Detections, observed: dict[int, int], frame: int) -> Detections:
        """Every live confirmed track: its detection's box if observed, else the prediction."""
        n = len(self._tracks)
        if n == 0:
            return _no_tracks()  # most frames of sparse sequences
        boxes = self._tracks.kf.xyxy()
        rows = np.full(n, -1, dtype=np.int64)
        det_loc = dets.data.get("location")
        loc = None if det_loc is None else np.full((n, 3), np.nan)
        if observed:
            pos = {int(t): i for i, t in enumerate(self._tracks.id.tolist())}
            idx = np.array([pos[t] for t in observed], dtype=np.int64)
            cols = np.array(list(observed.values()), dtype=np.int64)
            boxes[idx] = dets.xyxy[cols]
            rows[idx] = dets.source_row[cols]
            if loc is not None:
                loc[idx] = np.asarray(det_loc, dtype=np.float64)[cols]
        keep = self._tracks.confirmed
        # boolean indexing copies: the columns never alias the tracker's state
        return _track_output(
            boxes[keep],
            self._tracks.conf[keep],
            self._tracks.cls[keep],
            self._tracks.id[keep],
            np.full(int(keep.sum()), frame, dtype=np.int64),
            rows[keep],
            self._tracks.state[keep],
            self._tracks.occluder[keep],
            self._tracks.vis[keep],
            self._tracks.unseen[keep],
            # a 3D detector's position, for the world motion of --warnings
            None if loc is None else loc[keep],
        )


def _costs(config: TrackerConfig) -> dict[str, int]:
    """The event costs the solver is given: ``costs.returns`` only with ``revive_s`` (no ended
    track is revived without it; left out, the scene files of runs without it stay as they
    were, their recorded constants included), ``costs.resumes_seen`` only with
    ``resume_last_seen``."""
    costs = asdict(config.costs)
    if not config.revive_frames:
        costs.pop("returns")
    if not (config.resume_last_seen and config.abduction):  # scene constants stay as they were
        costs.pop("resumes_seen")
    return costs


def frozen_problem(problem: FrameProblem) -> FrameProblem:
    """``problem`` with its arrays copied (some are the track table's columns)."""
    copies: dict[str, Any] = {
        f.name: value.copy()
        for f in fields(problem)
        if isinstance(value := getattr(problem, f.name), np.ndarray)
    }
    return replace(problem, **copies)


def _unread(packaged: bool, constants: dict[str, int], rules: Sequence[str]) -> tuple[str, ...]:
    """The optional facts ``tracking.lp`` mentions that cannot change an answer with these
    constants: ``cover_share/3`` where hide_min_cover and hide_late_cover admit every share
    (without the facts each counts as full, 1000), unless the user's rules read it."""
    if not packaged or "cover_share" in asp.mentioned("\n".join(rules)):
        return ()
    lows = (constants["hide_min_cover"], constants["hide_late_cover"])
    return ("cover_share",) if all(v <= 0 or v > 1000 for v in lows) else ()


def _check_user_program(
    solver: AbductionSolver | HideConfidence, sources: Sequence[str | Path | None], limits: Limits
) -> None:
    """Ground and solve the user's program once without facts under ``limits`` and keep the
    atom limit for every frame. ``sources``: the encoding (None: packaged), then the rules.
    Raises InputError naming the user's file."""

    def name(src: str | Path | None, i: int) -> str:
        if src is None:
            return "tracking.lp"
        if isinstance(src, Path) or str(src).endswith(".lp"):
            return str(src)
        return "rules" if i else "encoding"

    parts = [
        (name(src, i), text)
        for i, (src, text) in enumerate(zip(sources, solver.texts, strict=True))
    ]
    check_user_encoding(solver.program, solver.options, parts, limits)
    solver.max_atoms = limits.max_atoms


def _track_output(
    xyxy: np.ndarray,
    confidence: np.ndarray,
    class_id: np.ndarray,
    tracker_id: np.ndarray,
    frame: np.ndarray,
    source_row: np.ndarray,
    state: np.ndarray,
    occluder: np.ndarray,
    visibility: np.ndarray,
    hidden_frames: np.ndarray,
    detection_location: np.ndarray | None = None,
) -> Detections:
    """The columns of :meth:`Tracker._output` (N rows; ``xyxy`` (N, 4) float pixels, the rest
    (N,); ``detection_location`` (N, 3) metres, NaN where not seen, only with a 3D detector),
    which have the validated dtypes and shapes already: no validation every frame."""
    return Detections.trusted(
        xyxy=xyxy,
        confidence=confidence,
        class_id=class_id,
        tracker_id=tracker_id,
        frame=frame,
        source_row=source_row,
        data={
            "state": state,
            "occluder": occluder,
            "visibility": visibility,
            "hidden_frames": hidden_frames,
            **({} if detection_location is None else {"detection_location": detection_location}),
        },
    )


def _no_tracks() -> Detections:
    """:meth:`Tracker._output` without tracks: empty columns of its dtypes (fresh arrays)."""

    def ints() -> np.ndarray:
        return np.empty(0, dtype=np.int64)

    return _track_output(
        np.empty((0, 4)),
        np.empty(0),
        ints(),
        ints(),
        ints(),
        ints(),
        ints(),
        ints(),
        ints(),
        ints(),
    )


def _coerce(obj: Any) -> Detections:
    if isinstance(obj, Detections):
        return obj
    return as_detections(obj)  # duck-typed adapters (supervision, ultralytics, arrays)
