"""Online detection of safety-critical situations: ``SituationMonitor.update(result) -> warnings``.

Per frame the monitor condenses the tracker's :class:`~sensemaking.results.FrameResult` into a
small snapshot, computed once (in plain Python over the few rows: numpy's per-call cost would
dominate; same float operations) and kept for the last ``window`` frames: states and
occluders, which boxes stand in the ego corridor, qualitative motion of visible boxes,
rectangle relations of near pairs involving a vehicle, events, lanes and ground labels, and the
anticipated reappearance of hidden tracks. From the snapshots it finds the *candidates* of each
situation -- the objects for which the trigger facts of its rules are present, a necessary
condition of the rule bodies -- and, only when there are new ones, grounds ``situations.lp`` on a
fresh clingo Control with the facts of those objects
(:func:`~sensemaking.reasoning.situations.solve_window` leaves out the rules that cannot fire with
those facts). History is never re-grounded. For OVERTAKING, HIDDEN_ENTITY, REDUCED_VISIBILITY and
SUDDEN_STOP the candidates are exactly the objects the rules hold for (every condition of the
rule body is checked), so a candidate held at the previous frame is still held without asking the
solver: on most frames nothing is grounded at all. With ``SituationConfig(prefilter=False)``
every situation is grounded every frame with every fact of the window; the warnings are the same.

A warning is returned when its situation starts to hold; :attr:`SituationMonitor.active`
lists every situation holding at the current frame (reading it asks the solver about the frame
if :meth:`SituationMonitor.update` did not).
"""

from __future__ import annotations

import logging
import time
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass, field
from itertools import compress
from typing import Any

import numpy as np

from sensemaking.classes import PEOPLE, VEHICLES, class_name
from sensemaking.reasoning.anticipation import Anticipation, anticipate_fits, fit_motion_rows
from sensemaking.reasoning.context import SceneContext, asp_name
from sensemaking.reasoning.relations import IA_RELATIONS, MOTION_KINDS, inverse_codes, motion_row, near_pair_codes
from sensemaking.reasoning.situations import (
    SituationMatch, Situation, SituationConfig, Warning, situation_constants, solve_window,
)
from sensemaking.results import Event, FrameResult, TrackState

__all__ = ["SituationMonitor", "BOTTOM_LOWER"]

log = logging.getLogger(__name__)

_STATE_NAMES = tuple(s.name.lower() for s in TrackState)
#: y relations that put A's bottom lower than B's (``bottom_lower/1`` of relations.lp)
BOTTOM_LOWER: frozenset[str] = frozenset({"after", "met_by", "overlapped_by", "contains", "started_by"})
#: by relation code: the code is in BOTTOM_LOWER
_BL: list[bool] = [r in BOTTOM_LOWER for r in IA_RELATIONS]
#: by relation code: the code of the converse relation
_INV: list[int] = inverse_codes(np.arange(len(IA_RELATIONS))).tolist()
#: x relations of boxes side by side (``lateral/1`` of relations.lp; closed under the converse)
_LATERAL_CODES = frozenset(IA_RELATIONS.index(r) for r in
                           ("before", "after", "meets", "met_by", "overlaps", "overlapped_by"))
_VISIBLE, _HIDDEN = int(TrackState.VISIBLE), int(TrackState.HIDDEN)


#: situations whose candidates (SituationMonitor._candidates) are exactly the objects their rules
#: hold for: every condition of the rule body is checked there. BLOCKED_LANE (how long on the lane,
#: off the road) and EXITING_VEHICLE (touching) are only prefiltered.
_EXACT: frozenset[str] = frozenset({"OVERTAKING", "HIDDEN_ENTITY", "REDUCED_VISIBILITY", "SUDDEN_STOP"})


def _lane_term(lane_id: int | str) -> str:
    if isinstance(lane_id, int):
        return str(lane_id)
    return '"' + str(lane_id).replace("\\", "\\\\").replace('"', '\\"') + '"'


@dataclass(slots=True)
class _Frame:
    """One frame of the window: everything the situation rules may use, before rendering."""

    frame: int
    ids: list[int] = field(default_factory=list)
    state: dict[int, int] = field(default_factory=dict)
    hidden_by: dict[int, int] = field(default_factory=dict)  # hidden track -> occluder
    in_corr: set[int] = field(default_factory=set)
    area: dict[int, int] = field(default_factory=dict)  # in-corridor tracks: permille of the image
    motion: dict[int, tuple[str, ...]] = field(default_factory=dict)  # filled when asked: _kinds
    ra: dict[tuple[int, int], tuple[int, int]] = field(default_factory=dict)  # (a < b) -> (x, y) codes
    closer: set[tuple[int, int]] = field(default_factory=set)  # (nearer, farther) vehicle pairs
    events: list[Event] = field(default_factory=list)
    person_starts: list[tuple[int, int]] = field(default_factory=list)  # (person, event frame)
    lanes: list[str] = field(default_factory=list)  # lane terms in force
    on_lane: dict[int, list[str]] = field(default_factory=dict)
    surface: dict[int, str] = field(default_factory=dict)


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

    ``update(result)`` once per frame in order, ``reset()`` before another sequence.
    ``stats`` counts frames, solver calls and the time spent in ``update`` (milliseconds).
    """

    def __init__(self, config: SituationConfig | None = None, context: SceneContext | None = None,
                 fps: float = 10.0, image_size: tuple[int, int] | None = (1242, 375)):
        if fps <= 0:
            raise ValueError(f"fps must be positive, got {fps}")
        if image_size is not None and (image_size[0] <= 0 or image_size[1] <= 0):
            raise ValueError(f"image_size must be (width, height) > 0, got {image_size}")
        self.config = config or SituationConfig()
        self.context = context or SceneContext()
        self.fps = float(fps)
        self.image_size = None if image_size is None else (int(image_size[0]), int(image_size[1]))
        self._consts = situation_constants(self.config.constants)
        self._window = self.config.window_frames(self.fps)
        self._lag = self.config.motion.lag_frames(self.fps)
        self._frame_ms = max(1, int(round(1000.0 / self.fps)))
        self._rearm = max(1, int(round(self.config.rearm_s * self.fps)))
        self._enabled = [s for s in Situation if s.name in self.config.situations]
        self._skipped: dict[Situation, str] = {}
        if Situation.BLOCKED_LANE in self._enabled and not self.context.lanes:
            self._skipped[Situation.BLOCKED_LANE] = "needs lanes (no lanes file given)"
        if self.image_size is None:
            for s in (Situation.HIDDEN_ENTITY, Situation.REDUCED_VISIBILITY, Situation.SUDDEN_STOP):
                if s in self._enabled:
                    self._skipped[s] = "needs the image size (for the ego corridor)"
        self._checked = [s for s in self._enabled if s not in self._skipped]
        ap = self.config.anticipation
        # visible boxes kept per track: motion is asked for any frame of the window, against a box
        # up to 2 lag frames before, whose speed needs another 2 lag
        self._hist_len = max(self._window + 4 * self._lag, ap.velocity_points) + 1
        self.reset()

    # -- state ----------------------------------------------------------------------------------
    def reset(self) -> None:
        """Forget all history; the next update starts a new sequence."""
        self._frames: deque[_Frame] = deque(maxlen=self._window)
        # visible frames of each track: [frame, box, centre speed px/s there (None: not computed
        # yet, NaN: no box lag to 2 lag frames before), see _motion_row]
        self._hist: dict[int, deque[list[Any]]] = {}
        self._class: dict[int, int] = {}
        self._last_live: dict[int, int] = {}
        self._last_held: dict[tuple[str, tuple[int, ...]], int] = {}
        self._seq_start: int | None = None
        self._last_frame: int | None = None
        self._anticip: dict[int, Anticipation] = {}
        self._person_started: int | None = None  # the last frame with a person's track start
        # fit_motion of hidden tracks, with (history length, last visible frame) it was made from
        self._fits: dict[int, tuple[tuple[int, int], tuple[int, list[float], list[float]]]] = {}
        self._active: list[Warning] | None = []  # None: not solved yet at this frame (see active)
        self._pending: tuple[int, dict[Situation, Any] | None, list[Situation]] | None = None
        self._held: set[tuple[str, tuple[int, ...]]] = set()  # held at the last frame, exact situations
        self.stats: dict[str, float] = {"frames": 0, "solver_calls": 0, "ms": 0.0}

    @property
    def skipped(self) -> dict[str, str]:
        """Situations that cannot be checked with this context, and why."""
        return {s.name: why for s, why in self._skipped.items()}

    @property
    def anticipations(self) -> list[Anticipation]:
        """Anticipated reappearances of the tracks hidden at the current frame."""
        return list(self._anticip.values())

    # -- the loop -------------------------------------------------------------------------------
    def update(self, result: FrameResult) -> list[Warning]:
        """Process one frame; return the warnings whose situation starts to hold at this frame
        (and, on the first frame, a note for each situation that cannot be checked)."""
        t0 = time.perf_counter()
        f = int(result.frame)
        if self._last_frame is not None and f <= self._last_frame:
            raise ValueError(f"frames must increase: got frame {f} after {self._last_frame}")
        new: list[Warning] = []
        if self._seq_start is None:
            self._seq_start = f
            for s, why in self._skipped.items():
                log.info("%s not checked: it %s", s.name, why)
                new.append(Warning(f, s.name, (), f"{s.name} not checked: it {why}", {"skipped": why}))
        self._last_frame = f
        self._observe(result)
        if self.config.prefilter:
            cands = {s: c for s, c in self._candidates().items() if c and s in self._checked}
            held, fresh = self._continuing(cands)
            parts = [s for s in self._checked if s in fresh]
        else:
            cands, held, fresh, parts = None, [], None, list(self._checked)
        found = [self._warning(f, d) for d in self._solve(fresh, parts)]
        if held:  # the solver saw only the fresh candidates: active asks it about all, if read
            self._active = None
            self._pending = (f, cands, [s for s in self._checked if s in cands])
        else:
            self._active = found
        for w in found:
            key = (w.situation, w.objects)
            last = self._last_held.get(key)
            if last is None or f - last > self._rearm:
                new.append(w)
            held.append(key)
        self._held = {k for k in held if k[0] in _EXACT} if cands is not None else set()
        for key in held:
            self._last_held[key] = f
        self._forget(f)
        self.stats["frames"] += 1
        self.stats["ms"] += (time.perf_counter() - t0) * 1000.0
        return new

    def _continuing(self, cands: dict[Situation, Any]) -> tuple[list[tuple[str, tuple[int, ...]]], dict[Situation, Any]]:
        """Split the candidates into those held at the previous frame by a situation whose
        candidates are exactly the objects its rules hold for (:data:`_EXACT`: they still hold,
        the solver would say so; returned as warning keys) and the rest, to ask the solver about."""
        held: list[tuple[str, tuple[int, ...]]] = []
        fresh: dict[Situation, Any] = {}
        for s, c in cands.items():
            if s.name not in _EXACT or not self._held:
                fresh[s] = c
                continue
            rest = set()
            for o in c:
                key = (s.name, o if isinstance(o, tuple) else (o,))
                if key in self._held:
                    held.append(key)
                else:
                    rest.add(o)
            if rest:
                fresh[s] = rest
        return held, fresh

    def _solve(self, cands: dict[Situation, Any] | None, parts: list[Situation]) -> list[SituationMatch]:
        """The solver's answer for the current frame (no call when no part has candidates)."""
        if not parts:
            return []
        self.stats["solver_calls"] += 1
        return solve_window(self._render(cands), parts, self.config.constants)

    @property
    def active(self) -> list[Warning]:
        """Every situation holding at the current frame, as warnings of this frame. On frames
        where every candidate continues from the previous frame :meth:`update` skips the solver;
        reading this asks it then (same answer as solving in :meth:`update`)."""
        if self._active is None:
            assert self._pending is not None
            f, cands, parts = self._pending
            self._active = [self._warning(f, d) for d in self._solve(cands, parts)]
            self._pending = None
        return list(self._active)

    def run(self, results: Iterable[FrameResult]) -> list[Warning]:
        """Every warning over a sequence of frame results (after :meth:`reset`)."""
        self.reset()
        out: list[Warning] = []
        for r in results:
            out.extend(self.update(r))
        return out

    # -- per-frame snapshot ---------------------------------------------------------------------
    def _observe(self, result: FrameResult) -> None:
        # plain Python over the rows: a frame has a few tracks, and numpy's per-call cost would
        # dominate (the helpers do the same float operations as their numpy counterparts)
        f = int(result.frame)
        fr = _Frame(f, events=list(result.events))
        self._frames.append(fr)
        self._anticip = {}
        tr = result.tracks
        n = len(tr)
        if n == 0:
            return
        ids = tr.tracker_id.tolist()
        cls = tr.class_id.tolist()
        data = tr.data
        states = np.asarray(data["state"], dtype=np.int64).tolist() if "state" in data else [0] * n
        occl = np.asarray(data["occluder"], dtype=np.int64).tolist() if "occluder" in data else [-1] * n
        xyxy = tr.xyxy
        boxes = xyxy.tolist()
        fr.ids = ids
        fr.state = dict(zip(ids, states))
        self._class.update(zip(ids, cls))
        self._last_live.update(dict.fromkeys(ids, f))
        hist, hist_len = self._hist, self._hist_len
        for i, (t, s) in enumerate(zip(ids, states)):
            if s == _VISIBLE:
                h = hist.get(t)
                if h is None:
                    h = hist[t] = deque(maxlen=hist_len)
                h.append([f, boxes[i], None])
            elif s == _HIDDEN and occl[i] >= 0:
                fr.hidden_by[t] = occl[i]

        # corridor and area (permille of the image, np.rint: round half to even)
        if self.image_size is not None:
            W, H = self.image_size
            k = 1000.0 / (W * H)
            for i, inside in enumerate(self.context.corridor.contains_rows(boxes, self.image_size)):
                if inside:
                    x1, y1, x2, y2 = boxes[i]
                    fr.in_corr.add(ids[i])
                    fr.area[ids[i]] = round((x2 - x1) * (y2 - y1) * k)

        if fr.events:
            fr.person_starts = [(e.args[0], e.frame) for e in fr.events
                                if e.name == "starts" and e.args and self._class.get(e.args[0]) in PEOPLE]
            if fr.person_starts:
                self._person_started = f

        # anticipation of hidden tracks
        if fr.hidden_by:
            by_id = dict(zip(ids, boxes))
            for t, o in fr.hidden_by.items():
                a = self._anticipate(t, o, f, by_id)
                if a is not None:
                    self._anticip[t] = a

        # relations of near pairs involving a vehicle (vehicle/vehicle and person/vehicle)
        is_veh = [c in VEHICLES for c in cls]
        if any(is_veh):
            rel = [i for i, c in enumerate(cls) if is_veh[i] or c in PEOPLE]
            if len(rel) >= 2:
                veh = [is_veh[i] for i in rel]
                ra, closer = fr.ra, fr.closer
                for i, j, cx, cy in near_pair_codes([boxes[i] for i in rel], self.config.relations, veh):
                    ta, tb = ids[rel[i]], ids[rel[j]]
                    if ta > tb:
                        ta, tb, cx, cy = tb, ta, _INV[cx], _INV[cy]
                    ra[(ta, tb)] = (cx, cy)
                    if veh[i] and veh[j]:
                        if _BL[cy]:  # ta nearer than tb
                            closer.add((ta, tb))
                        elif _BL[_INV[cy]]:
                            closer.add((tb, ta))

        # lanes and segmentation
        lanes = self.context.lanes.lanes_at(f) if self.context.lanes else ()
        if lanes:
            bottom = np.stack([(xyxy[:, 0] + xyxy[:, 2]) / 2, xyxy[:, 3]], axis=1)
            for lane in lanes:
                term = _lane_term(lane.id)
                fr.lanes.append(term)
                for i in np.flatnonzero(lane.contains_points(bottom)).tolist():
                    fr.on_lane.setdefault(ids[i], []).append(term)
        if self.context.segmentation is not None:
            for i, s in enumerate(self.context.segmentation.surface_under(f, xyxy, self.image_size)):
                if s is not None:
                    fr.surface[ids[i]] = asp_name(s)

    # -- qualitative motion, computed when a rule needs it ------------------------------------------
    def _prev_entry(self, h: deque[list[Any]], k: int) -> int | None:
        """Index of the box ``lag`` frames before entry ``k`` of a history, else of the latest
        earlier one if at most ``2 lag`` frames before, else None."""
        f, lag = h[k][0], self._lag
        j = k - lag
        if j >= 0 and h[j][0] == f - lag:  # seen every frame: the box lag frames before
            return j
        for j in range(k - 1, -1, -1):
            if h[j][0] <= f - lag:
                return j if f - h[j][0] <= 2 * lag else None
        return None

    def _motion_row(self, h: deque[list[Any]], k: int) -> tuple[tuple[bool, ...], float, float, float] | None:
        """:func:`~sensemaking.reasoning.relations.motion_row` of entry ``k`` against its previous
        box (kinds, speed px/s, vx px/s, growth 1/s), or None without one; keeps the speed in the
        entry."""
        j = self._prev_entry(h, k)
        if j is None:
            h[k][2] = np.nan
            return None
        before = h[j][2]
        if before is None:  # the speed there, for `stopping`
            before = self._motion_row(h, j)
            before = np.nan if before is None else before[1]
        row = motion_row(h[j][1], h[k][1], (h[k][0] - h[j][0]) / self.fps, before, self.config.motion)
        h[k][2] = row[1]
        return row

    def _entry(self, t: int, frame: int) -> tuple[deque[list[Any]], int] | None:
        """The history of ``t`` and the index of its box at ``frame`` (None if not visible then)."""
        h = self._hist.get(t)
        if h:
            for k in range(len(h) - 1, -1, -1):
                g = h[k][0]
                if g == frame:
                    return h, k
                if g < frame:
                    break
        return None

    def _kinds(self, fr: _Frame, t: int) -> tuple[str, ...]:
        """Qualitative motion of ``t`` at window frame ``fr`` (:data:`MOTION_KINDS` that hold;
        empty when not visible then or without a box ``lag`` to ``2 lag`` frames before)."""
        m = fr.motion.get(t)
        if m is None:
            m = ()
            at = self._entry(t, fr.frame)
            if at is not None:
                row = self._motion_row(*at)
                if row is not None:
                    m = tuple(compress(MOTION_KINDS, row[0]))
            fr.motion[t] = m
        return m

    def _features(self, t: int) -> tuple[float, float, float]:
        """Centre speed (px/s), horizontal speed (px/s) and growth (1/s) of ``t`` now (zeros
        when unknown)."""
        at = self._entry(t, self._frames[-1].frame)
        row = self._motion_row(*at) if at is not None else None
        return (0.0, 0.0, 0.0) if row is None else (row[1], row[2], row[3])

    def _anticipate(self, t: int, o: int, f: int, boxes: dict[int, list[float]]) -> Anticipation | None:
        h = self._hist.get(t)
        if not h:
            return None
        oh = list(self._hist.get(o, ()))
        if o in boxes and (not oh or oh[-1][0] != f):
            oh.append((f, boxes[o]))  # the occluder's box now (a prediction if not visible)
        if not oh:
            return None
        ap = self.config.anticipation
        points, span = ap.velocity_points, ap.velocity_span_s * self.fps
        # the hidden track's history does not change while it stays hidden: fit it once
        key = (len(h), h[-1][0])
        fit = self._fits.get(t)
        if fit is None or fit[0] != key:
            last = list(h)[-points:]  # fit_motion uses the latest `points` boxes only
            fit = self._fits[t] = (key, fit_motion_rows([p[0] for p in last], [p[1] for p in last], points, span))
        oh = oh[-points:]
        return anticipate_fits(
            fit[1], fit_motion_rows([p[0] for p in oh], [p[1] for p in oh], points, span), f,
            fps=self.fps, track=t, occluder=o, image_size=self.image_size,
            corridor=self.context.corridor, config=ap,
        )

    def _within(self, ms_name: str) -> list[_Frame]:
        """Window frames at most ``#const ms_name`` milliseconds before now (now included)."""
        now, reach = self._last_frame, self._consts[ms_name]
        return [fr for fr in self._frames if (now - fr.frame) * self._frame_ms <= reach]

    # -- candidates (trigger facts present) -------------------------------------------------------
    def _candidates(self) -> dict[Situation, Any]:
        """Per situation, the objects whose trigger facts are present now: a necessary condition
        of the situation's rules (see situations.lp), so grounding only these is exact."""
        now = self._frames[-1]
        c = self._consts
        cls = self._class
        out: dict[Situation, Any] = {}
        # HIDDEN_ENTITY: hidden participant with an anticipated reappearance in the corridor
        # within he_lead_ms
        if self._anticip:
            out[Situation.HIDDEN_ENTITY] = {
                (t, a.occluder) for t, a in self._anticip.items()
                if a.in_corridor and (cls.get(t) in VEHICLES or cls.get(t) in PEOPLE)
                and (a.reappear_frame - now.frame) * self._frame_ms <= c["he_lead_ms"]}
        if now.in_corr:
            # REDUCED_VISIBILITY: in the corridor and large and visible, or hiding someone
            occluders = set(now.hidden_by.values())
            out[Situation.REDUCED_VISIBILITY] = {
                t for t in now.in_corr
                if t in occluders or (now.state.get(t) == TrackState.VISIBLE and now.area[t] >= c["rv_area"])}
            # SUDDEN_STOP: a vehicle in the corridor, large enough, stopping now, or looming now
            # after keeping its distance within ss_ms
            sudden = set()
            for t in now.in_corr:
                if cls.get(t) not in VEHICLES or now.area[t] < c["ss_area"]:
                    continue
                m = self._kinds(now, t)
                if "stopping" in m or ("looming" in m and any(
                        fr.frame < now.frame and "keeping_distance" in self._kinds(fr, t)
                        for fr in self._within("ss_ms"))):
                    sudden.add(t)
            out[Situation.SUDDEN_STOP] = sudden
        # BLOCKED_LANE: on a lane and stopped now
        if now.on_lane:
            out[Situation.BLOCKED_LANE] = {t for t in now.on_lane if "stopped" in self._kinds(now, t)}
        # OVERTAKING: a vehicle pair side by side now, B not approaching, whose depth order
        # flipped within ov_ms
        if now.closer:
            flipped = {(a, b) for (b, a) in now.closer if now.ra[(a, b) if a < b else (b, a)][0] in _LATERAL_CODES}
            if flipped:
                earlier: set[tuple[int, int]] = set()
                for fr in self._within("ov_ms"):
                    if fr.frame < now.frame:
                        earlier |= fr.closer
                out[Situation.OVERTAKING] = {(a, b) for a, b in flipped & earlier
                                             if "approaching" not in self._kinds(now, b)}
        # EXITING_VEHICLE: a person started within ev_ms (after the first frame), and a vehicle
        # stood still in the window
        if self._person_started is not None and self._person_started >= self._frames[0].frame:
            start = self._seq_start if self._seq_start is not None else now.frame
            persons = {(p, f0) for fr in self._frames for p, f0 in fr.person_starts
                       if f0 > start and (now.frame - f0) * self._frame_ms <= c["ev_ms"]}
            if persons:
                parked = {t for fr in self._frames for t in fr.ids
                          if cls.get(t) in VEHICLES and "stopped" in self._kinds(fr, t)}
                if parked:
                    out[Situation.EXITING_VEHICLE] = (persons, parked)
        return out

    # -- rendering facts ------------------------------------------------------------------------
    def _render(self, cands: dict[Situation, Any] | None) -> str:
        """Facts for the candidates of each situation, or (``None``) every fact of the window."""
        now = self._frames[-1]
        n = now.frame
        out: list[str] = [f"now({n}).", f"frame_ms({self._frame_ms}).", f"seq_start({self._seq_start})."]
        tracks: set[int] = set()
        facts: set[str] = set()
        add = facts.add

        def ra(fr: _Frame, a: int, b: int) -> None:
            key = (a, b) if a < b else (b, a)
            c = fr.ra.get(key)
            if c is not None:
                add(f"ra({key[0]},{key[1]},{fr.frame},{IA_RELATIONS[c[0]]},{IA_RELATIONS[c[1]]}).")

        def motion(fr: _Frame, t: int, kinds: Iterable[str] | None = None) -> None:
            for k in self._kinds(fr, t):
                if kinds is None or k in kinds:
                    add(f"motion({t},{fr.frame},{k}).")

        if cands is None:  # everything, every situation
            for fr in self._frames:
                f = fr.frame
                tracks.update(fr.ids)
                for t, s in fr.state.items():
                    add(f"state({t},{f},{_STATE_NAMES[s]}).")
                for t, o in fr.hidden_by.items():
                    add(f"hidden_by({t},{o},{f}).")
                for t in fr.in_corr:
                    add(f"in_corridor({t},{f}).")
                for t in fr.ids:
                    motion(fr, t)
                for a, b in fr.ra:
                    ra(fr, a, b)
                for e in fr.events:
                    add(f"occurs_at({e.name}({','.join(map(str, e.args))}),{e.frame}).")
                for t, lanes in fr.on_lane.items():
                    for term in lanes:
                        add(f"on_lane({t},{term},{f}).")
                for t, s in fr.surface.items():
                    add(f"surface({t},{f},{s}).")
            for t, a in now.area.items():
                add(f"area({t},{n},{a}).")
            for term in now.lanes:
                add(f"lane({term}).")
            for t, a in self._anticip.items():
                self._anticipation_facts(a, add)
        else:
            for t, o in cands.get(Situation.HIDDEN_ENTITY, ()):
                tracks.add(t)
                add(f"hidden_by({t},{o},{n}).")
                self._anticipation_facts(self._anticip[t], add)
            for o in cands.get(Situation.REDUCED_VISIBILITY, ()):
                tracks.add(o)
                add(f"in_corridor({o},{n}).")
                add(f"state({o},{n},{_STATE_NAMES[now.state[o]]}).")
                add(f"area({o},{n},{now.area[o]}).")
                for t, occ in now.hidden_by.items():
                    if occ == o:
                        add(f"hidden_by({t},{o},{n}).")
            for v in cands.get(Situation.SUDDEN_STOP, ()):
                tracks.add(v)
                add(f"in_corridor({v},{n}).")
                add(f"area({v},{n},{now.area[v]}).")
                for fr in self._within("ss_ms"):
                    motion(fr, v, ("stopping", "looming", "keeping_distance"))
            for t in cands.get(Situation.BLOCKED_LANE, ()):
                tracks.add(t)
                for term in now.lanes:
                    add(f"lane({term}).")
                for term in now.on_lane.get(t, ()):
                    add(f"on_lane({t},{term},{n}).")
                if t in now.surface:
                    add(f"surface({t},{n},{now.surface[t]}).")
                for fr in self._within("bl_ms"):
                    motion(fr, t, ("stopped",))
            for a, b in cands.get(Situation.OVERTAKING, ()):
                tracks.update((a, b))
                for fr in self._within("ov_ms"):
                    ra(fr, a, b)
                motion(now, b, ("approaching",))
            if Situation.EXITING_VEHICLE in cands:
                persons, parked = cands[Situation.EXITING_VEHICLE]
                for p, f0 in persons:
                    tracks.add(p)
                    add(f"occurs_at(starts({p}),{f0}).")
                    for v in parked:
                        for fr in self._frames:
                            if fr.frame >= f0:
                                ra(fr, p, v)
                for v in parked:
                    tracks.add(v)
                    for fr in self._frames:
                        motion(fr, v, ("stopped",))
        for t in sorted(tracks):
            c = self._class.get(t, 0)
            out.append(f"track({t},{asp_name(class_name(c))}).")
            if c in VEHICLES:
                out.append(f"vehicle({t}).")
            elif c in PEOPLE:
                out.append(f"person({t}).")
        out.extend(sorted(facts))
        return "\n".join(out) + "\n"

    @staticmethod
    def _anticipation_facts(a: Anticipation, add: Any) -> None:
        x, y = int(round(a.position[0])), int(round(a.position[1]))
        add(f"anticipated({a.track},{a.occluder},{a.reappear_frame},{x},{y}).")
        if a.in_corridor:
            add(f"anticipated_in_corridor({a.track},{a.occluder},{a.reappear_frame}).")

    def _forget(self, f: int) -> None:
        if f % self._window:
            return
        for t in [t for t, last in self._last_live.items() if f - last > self._window]:
            for d in (self._hist, self._class, self._last_live, self._fits):
                d.pop(t, None)
        for key in [k for k, last in self._last_held.items() if f - last > self._rearm]:
            del self._last_held[key]

    # -- warnings -------------------------------------------------------------------------------
    def _describe(self, t: int) -> str:
        c = self._class.get(t)
        return f"track {t} ({class_name(c)})" if c is not None else f"track {t}"

    def _warning(self, f: int, d: SituationMatch) -> Warning:
        s, objs, info = d.situation, d.objects, d.info
        desc = self._describe
        details: dict[str, Any] = {"classes": [class_name(self._class.get(t, 0)) for t in objs]}
        for k, v in info.items():
            details[k] = v[0] if len(v) == 1 else v
        if s is Situation.OVERTAKING:
            a, b = objs
            msg = f"{desc(a)} is overtaking {desc(b)}"
        elif s is Situation.HIDDEN_ENTITY:
            t, o = objs
            a = self._anticip[t]
            details["anticipation"] = a.to_json()
            details["lead_frames"], details["lead_s"] = a.lead_frames, round(a.lead_s, 3)
            msg = (f"{desc(t)} is hidden behind {desc(o)} and may reappear in front of the ego vehicle "
                   f"at frame {a.reappear_frame} (in {a.lead_frames} frames, {a.lead_s:.1f} s) at "
                   f"x={a.position[0]:.0f}, y={a.position[1]:.0f} px")
        elif s is Situation.REDUCED_VISIBILITY:
            (o,) = objs
            parts = []
            if "area_permille" in details:
                parts.append(f"it takes {details['area_permille'] / 10:.0f}% of the image")
            hides = info.get("hides", [])
            if hides:
                parts.append("it hides " + ", ".join(desc(h) for h in hides))
            msg = f"{desc(o)} in front of the ego vehicle reduces visibility" + (f" ({'; '.join(parts)})" if parts else "")
        elif s is Situation.SUDDEN_STOP:
            (v,) = objs
            sp, vx, g = self._features(v)
            details.update({"speed_px_s": round(sp, 1), "vx_px_s": round(vx, 1), "growth_per_s": round(g, 3)})
            if "stopping" in info.get("cause", []):
                msg = f"{desc(v)} in front of the ego vehicle stops suddenly"
            else:
                details["ttc_s"] = round(1.0 / g, 2) if g > 0 else None
                ttc = f" (time to contact about {1.0 / g:.1f} s)" if g > 0 else ""
                msg = f"{desc(v)} in front of the ego vehicle brakes: the ego vehicle closes in fast{ttc}"
        elif s is Situation.BLOCKED_LANE:
            (t,) = objs
            lanes = info.get("lane", [])
            msg = f"lane {', '.join(str(x) for x in lanes) or '?'} is blocked by {desc(t)}, standing still"
        else:  # EXITING_VEHICLE
            p, v = objs
            msg = f"{desc(p)} appeared next to {desc(v)}, which stands still: a person may be getting out"
        return Warning(f, s.name, tuple(int(o) for o in objs), msg, details)
