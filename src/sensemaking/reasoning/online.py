"""Online detection of safety-critical situations: ``SituationMonitor.update(result) -> warnings``.

Per frame the monitor condenses the tracker's :class:`~sensemaking.results.FrameResult` into a
small snapshot, computed once (in plain Python over the few rows: numpy's per-call cost would
dominate; same float operations) and kept for the last ``window`` frames: states and
occluders, which boxes stand in the ego corridor, qualitative motion of visible boxes,
rectangle relations of near pairs involving a vehicle, events, lanes and ground labels, and the
anticipated reappearance of hidden tracks. From the snapshots it finds the *candidates* of each
situation -- the objects for which the trigger facts of its rules are present, a necessary
condition of the rule bodies.

For OVERTAKING, HIDDEN_ENTITY, REDUCED_VISIBILITY and SUDDEN_STOP the candidate test checks
every condition of the rule body, so the candidates are exactly the objects the rules of
situations.lp hold for, and the monitor reads the answer, details included (``info/4``), off
the snapshot: no solver call, as the tracker settles the frames whose optimum is evident without
one. BLOCKED_LANE and EXITING_VEHICLE are only prefiltered: when they have candidates,
``situations.lp`` is grounded on a fresh clingo Control with the facts of those objects
(:func:`~sensemaking.reasoning.situations.solve_window` leaves out the rules that cannot fire with
those facts). With ``SituationConfig(prefilter=False)`` every situation is grounded every frame
with every fact of the window -- the reference the fast path is tested against: the warnings
and the active situations are the same.

A warning is returned when its situation starts to hold; :attr:`SituationMonitor.active`
lists every situation holding at the current frame.
"""

from __future__ import annotations

import logging
import time
from collections import deque
from collections.abc import Iterable
from itertools import compress
from typing import Any

import numpy as np

from sensemaking.classes import PEOPLE, VEHICLES, class_name
from sensemaking.reasoning.anticipation import Anticipation, anticipate_fits, fit_motion_rows
from sensemaking.reasoning.context import SceneContext, asp_name
from sensemaking.reasoning.relations import (
    BOTTOM_LOWER, IA_RELATIONS, INVERSE_CODES, MOTION_KINDS, motion_row, near_depth_order, near_pair_codes,
)
from sensemaking.reasoning.situations import (
    SituationMatch, Situation, SituationConfig, Warning, situation_constants, solve_window,
)
from sensemaking.results import Event, FrameResult, TrackState

__all__ = ["SituationMonitor", "BOTTOM_LOWER"]

log = logging.getLogger(__name__)

_STATE_NAMES = tuple(s.name.lower() for s in TrackState)
#: x relations of boxes side by side (``lateral/1`` of relations.lp; closed under the converse)
_LATERAL_CODES = frozenset(IA_RELATIONS.index(r) for r in
                           ("before", "after", "meets", "met_by", "overlaps", "overlapped_by"))
_VISIBLE, _HIDDEN = int(TrackState.VISIBLE), int(TrackState.HIDDEN)
#: class ids of the near-pair relations: True for a vehicle, False for a person
_ROLE: dict[int, bool] = {**dict.fromkeys(PEOPLE, False), **dict.fromkeys(VEHICLES, True)}


#: situations whose candidates (SituationMonitor._candidates) are exactly the objects their rules
#: hold for: every condition of the rule body is checked there, so the monitor answers them
#: itself (SituationMonitor._decided). BLOCKED_LANE (how long on the lane, off the road) and
#: EXITING_VEHICLE (touching) are only prefiltered: the solver answers them.
_EXACT: frozenset[str] = frozenset({"OVERTAKING", "HIDDEN_ENTITY", "REDUCED_VISIBILITY", "SUDDEN_STOP"})
_ORDER: dict[Situation, int] = {s: i for i, s in enumerate(Situation)}


def _match_order(d: SituationMatch) -> tuple[int, tuple[int, ...]]:
    """Sort key of matches as solve_window sorts them: by situation, then objects."""
    return _ORDER[d.situation], d.objects


def _lane_term(lane_id: int | str) -> str:
    if isinstance(lane_id, int):
        return str(lane_id)
    return '"' + str(lane_id).replace("\\", "\\\\").replace('"', '\\"') + '"'


class _Frame:
    """One frame of the window: everything the situation rules may use, before rendering (a
    plain class: made every frame, and literals are cheaper than dataclass factories)."""

    __slots__ = ("frame", "events", "ids", "state", "hidden_by", "in_corr", "area", "motion", "ra", "rel",
                 "closer", "person_starts", "lanes", "on_lane", "surface")

    def __init__(self, frame: int = -1, events: list[Event] | None = None) -> None:  # defaults: copy makes it empty first
        self.frame = frame
        self.events: list[Event] = [] if events is None else events
        self.ids: list[int] = []
        self.state: dict[int, int] = {}
        self.hidden_by: dict[int, int] = {}  # hidden track -> occluder
        self.in_corr: set[int] = set()
        self.area: dict[int, int] = {}  # in-corridor tracks: permille of the image
        self.motion: dict[int, tuple[str, ...]] = {}  # filled when asked: _kinds
        # (a < b) -> (x, y) codes; None until asked (SituationMonitor._relations), from:
        self.ra: dict[tuple[int, int], tuple[int, int]] | None = None
        self.rel: tuple[list[int], list[list[float]], list[bool]] | None = None  # ids, boxes, vehicle?
        self.closer: set[tuple[int, int]] = set()  # (nearer, farther) vehicle pairs
        self.person_starts: list[tuple[int, int]] = []  # (person, event frame)
        self.lanes: list[str] = []  # lane terms in force
        self.on_lane: dict[int, list[str]] = {}
        self.surface: dict[int, str] = {}


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
        self._in_corridor = None if self.image_size is None else self.context.corridor.row_test(self.image_size)
        # box area (px²) -> permille of the image
        self._permille = 0.0 if self.image_size is None else 1000.0 / (self.image_size[0] * self.image_size[1])
        self._decide = [s for s in self._checked if s.name in _EXACT]  # answered from the snapshot
        self._ask = [s for s in self._checked if s.name not in _EXACT]  # answered by the solver
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
        # the last frame at which vehicle a stood nearer than vehicle b, by (a, b)
        self._closer_last: dict[tuple[int, int], int] = {}
        # by track, for _kept_distance: (frame checked up to, last frame keeping its distance)
        self._kept: dict[int, tuple[int, int | None]] = {}
        self._found: list[SituationMatch] = []  # what holds at the current frame
        self._active: list[Warning] | None = []  # its warnings, made when read (None: not yet)
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
            cands = self._candidates()
            found = self._decided(cands)
            parts = [s for s in self._ask if cands.get(s)]
            if parts:
                found += self._solve({s: cands[s] for s in parts}, parts)
                found.sort(key=_match_order)
        else:
            found = self._solve(None, self._checked)
        self._found, self._active = found, None
        for d in found:
            key = (d.situation.name, d.objects)
            last = self._last_held.get(key)
            if last is None or f - last > self._rearm:
                new.append(self._warning(f, d))
            self._last_held[key] = f
        self._forget(f)
        self.stats["frames"] += 1
        self.stats["ms"] += (time.perf_counter() - t0) * 1000.0
        return new

    def _solve(self, cands: dict[Situation, Any] | None, parts: list[Situation]) -> list[SituationMatch]:
        """The solver's answer for the current frame (no call when no part has candidates)."""
        if not parts:
            return []
        self.stats["solver_calls"] += 1
        return solve_window(self._render(cands), parts, self.config.constants)

    @property
    def active(self) -> list[Warning]:
        """Every situation holding at the current frame, as warnings of this frame."""
        if self._active is None:
            self._active = [self._warning(self._last_frame, d) for d in self._found]  # type: ignore[arg-type]
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
        fr = _Frame(f, list(result.events))
        self._frames.append(fr)
        if self._anticip:
            self._anticip = {}
        tr = result.tracks
        if tr.tracker_id is None or tr.class_id is None:
            raise ValueError(f"frame {f}: the tracks of a frame result need tracker_id and class_id")
        ids = tr.tracker_id.tolist()
        n = len(ids)
        if n == 0:
            return
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
        if self._in_corridor is not None:
            k = self._permille
            for i, inside in enumerate(self._in_corridor(boxes)):
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

        # relations of near pairs involving a vehicle (vehicle/vehicle and person/vehicle): kept
        # for _relations; the depth order of vehicle pairs (the y relation) is needed every frame
        rel = [i for i, c in enumerate(cls) if c in _ROLE]
        if len(rel) >= 2:
            veh = [_ROLE[cls[i]] for i in rel]
            if True in veh:
                rel_ids, rel_boxes = [ids[i] for i in rel], [boxes[i] for i in rel]
                fr.rel = (rel_ids, rel_boxes, veh)
                if False in veh:  # people too: the depth order is of vehicle pairs
                    rel_ids = [t for t, v in zip(rel_ids, veh) if v]
                    rel_boxes = [b for b, v in zip(rel_boxes, veh) if v]
                closer, last = fr.closer, self._closer_last
                for i, j in near_depth_order(rel_boxes, self.config.relations):
                    pair = (rel_ids[i], rel_ids[j])  # (nearer, farther)
                    closer.add(pair)
                    last[pair] = f

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

    def _relations(self, fr: _Frame) -> dict[tuple[int, int], tuple[int, int]]:
        """Rectangle relations (x, y codes) of the near pairs involving a vehicle at window frame
        ``fr``, by ``(a, b)`` with ``a < b`` (computed when a rule first needs them)."""
        if fr.ra is None:
            fr.ra = {}
            if fr.rel is not None:
                ids, boxes, veh = fr.rel
                for i, j, cx, cy in near_pair_codes(boxes, self.config.relations, veh):
                    ta, tb = ids[i], ids[j]
                    fr.ra[(ta, tb) if ta < tb else (tb, ta)] = (cx, cy) if ta < tb else (INVERSE_CODES[cx], INVERSE_CODES[cy])
        return fr.ra

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
        dt = (h[k][0] - h[j][0]) / self.fps
        row = motion_row(h[j][1], h[k][1], dt, np.nan if before is None else before, self.config.motion)
        if before is None and row[0][4]:  # stopped: `stopping` needs the speed there, not known yet
            prev = self._motion_row(h, j)
            if prev is not None:
                row = motion_row(h[j][1], h[k][1], dt, prev[1], self.config.motion)
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
        ap = self.config.anticipation
        points, span = ap.velocity_points, ap.velocity_span_s * self.fps
        ho = self._hist.get(o)
        oh = [ho[i] for i in range(max(0, len(ho) - points), len(ho))] if ho else []  # fit_motion's
        if o in boxes and (not oh or oh[-1][0] != f):
            oh.append([f, boxes[o]])  # the occluder's box now (a prediction if not visible)
        if not oh:
            return None
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

    def _kept_distance(self, t: int) -> bool:
        """``kept_distance(t)`` of situations.lp: ``t`` was keeping its distance at a window frame
        before now, at most ``ss_ms`` before. A frame asked about is not asked again (its motion
        does not change): by track, the frame checked up to and the last such frame. Scanning the
        window for every looming vehicle every frame cost ~2 points of reasoning_overhead's ratio
        inside the tracker loop (it reads old frames), though nothing measurable on its own."""
        now, first = self._frames[-1].frame, self._frames[0].frame
        reach, ms = self._consts["ss_ms"], self._frame_ms
        checked, last = self._kept.get(t, (first - 1, None))
        for fr in reversed(self._frames):  # newest first: the first found is the last
            g = fr.frame
            if g <= checked or (now - g) * ms > reach:
                break
            if g < now and "keeping_distance" in self._kinds(fr, t):
                last = g
                break
        self._kept[t] = (now - 1, last)
        return last is not None and last >= first and (now - last) * ms <= reach

    def _within(self, ms_name: str) -> list[_Frame]:
        """Window frames at most ``#const ms_name`` milliseconds before now (now included)."""
        now, reach = self._frames[-1].frame, self._consts[ms_name]
        return [fr for fr in self._frames if (now - fr.frame) * self._frame_ms <= reach]

    # -- candidates (trigger facts present) -------------------------------------------------------
    def _candidates(self) -> dict[Situation, Any]:
        """Per situation, the objects whose trigger facts are present now: a necessary condition
        of the situation's rules (see situations.lp), so grounding only these is exact; for the
        situations of :data:`_EXACT` every condition of the rule body is checked here."""
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
                if t in occluders or (now.state.get(t) == _VISIBLE and now.area[t] >= c["rv_area"])}
            # SUDDEN_STOP: a vehicle in the corridor, large enough, stopping now, or looming now
            # after keeping its distance within ss_ms; by vehicle, the causes (sudden/2)
            sudden: dict[int, list[str]] = {}
            for t in now.in_corr:
                if cls.get(t) not in VEHICLES or now.area[t] < c["ss_area"]:
                    continue
                m = self._kinds(now, t)
                causes = []
                if "looming" in m and self._kept_distance(t):
                    causes.append("looming")
                if "stopping" in m:
                    causes.append("stopping")
                if causes:
                    sudden[t] = causes
            out[Situation.SUDDEN_STOP] = sudden
        # BLOCKED_LANE: on a lane and stopped now
        if now.on_lane:
            out[Situation.BLOCKED_LANE] = {t for t in now.on_lane if "stopped" in self._kinds(now, t)}
        # OVERTAKING: a vehicle pair side by side now, B not approaching, whose depth order
        # flipped within ov_ms (A nearer at a window frame at most ov_ms ago: the last such frame,
        # the nearer_until of info/4, by pair; A is not nearer now, B is)
        if now.closer:
            first, last = self._frames[0].frame, self._closer_last
            over: dict[tuple[int, int], int] = {}
            for b, a in now.closer:
                g = last.get((a, b))
                if g is not None and g >= first and (now.frame - g) * self._frame_ms <= c["ov_ms"] \
                        and self._relations(now)[(a, b) if a < b else (b, a)][0] in _LATERAL_CODES \
                        and "approaching" not in self._kinds(now, b):
                    over[(a, b)] = g
            out[Situation.OVERTAKING] = over
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

    def _decided(self, cands: dict[Situation, Any]) -> list[SituationMatch]:
        """The answer for the situations of :data:`_EXACT` (their candidates are exactly the objects
        their rules hold for), with the details of their ``info/4`` rules, in the solver's order."""
        now = self._frames[-1]
        out: list[SituationMatch] = []
        for s in self._decide:
            c = cands.get(s)
            if not c:
                continue
            if s is Situation.OVERTAKING:
                out += [SituationMatch(s, ab, {"nearer_until": [g]}) for ab, g in sorted(c.items())]
            elif s is Situation.HIDDEN_ENTITY:
                out += [SituationMatch(s, to, {"reappear_frame": [self._anticip[to[0]].reappear_frame]})
                        for to in sorted(c)]
            elif s is Situation.REDUCED_VISIBILITY:
                for o in sorted(c):
                    info: dict[str, list[Any]] = {"area_permille": [now.area[o]]}
                    hides = [t for t, occ in now.hidden_by.items() if occ == o]
                    if hides:
                        info["hides"] = sorted(hides, key=str)  # as solve_window sorts values
                    out.append(SituationMatch(s, (o,), info))
            else:  # SUDDEN_STOP
                out += [SituationMatch(s, (v,), {"cause": causes}) for v, causes in sorted(c.items())]
        return out

    # -- rendering facts ------------------------------------------------------------------------
    def _render(self, cands: dict[Situation, Any] | None) -> str:
        """Facts for the candidates of BLOCKED_LANE and EXITING_VEHICLE, or (``None``) every fact of
        the window."""
        now = self._frames[-1]
        n = now.frame
        out: list[str] = [f"now({n}).", f"frame_ms({self._frame_ms}).", f"seq_start({self._seq_start})."]
        tracks: set[int] = set()
        facts: set[str] = set()
        add = facts.add

        def ra(fr: _Frame, a: int, b: int) -> None:
            key = (a, b) if a < b else (b, a)
            c = self._relations(fr).get(key)
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
                for a, b in self._relations(fr):
                    ra(fr, a, b)
                for e in fr.events:
                    add(f"occurs_at({e.name}({','.join(map(str, e.args))}),{e.frame}).")
                for t, lanes in fr.on_lane.items():
                    for term in lanes:
                        add(f"on_lane({t},{term},{f}).")
                for t, surf in fr.surface.items():
                    add(f"surface({t},{f},{surf}).")
            for t, a in now.area.items():
                add(f"area({t},{n},{a}).")
            for term in now.lanes:
                add(f"lane({term}).")
            for ant in self._anticip.values():
                self._anticipation_facts(ant, add)
        else:  # the situations that are only prefiltered (the rest is decided without facts)
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
            for d in (self._hist, self._class, self._last_live, self._fits, self._kept):
                d.pop(t, None)
        for key in [k for k, last in self._last_held.items() if f - last > self._rearm]:
            del self._last_held[key]
        for pair in [p for p, last in self._closer_last.items() if f - last > self._window]:
            del self._closer_last[pair]

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
            ant = self._anticip[t]
            details["anticipation"] = ant.to_json()
            details["lead_frames"], details["lead_s"] = ant.lead_frames, round(ant.lead_s, 3)
            msg = (f"{desc(t)} is hidden behind {desc(o)} and may reappear in front of the ego vehicle "
                   f"at frame {ant.reappear_frame} (in {ant.lead_frames} frames, {ant.lead_s:.1f} s) at "
                   f"x={ant.position[0]:.0f}, y={ant.position[1]:.0f} px")
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
            (veh,) = objs
            sp, vx, g = self._features(veh)
            details.update({"speed_px_s": round(sp, 1), "vx_px_s": round(vx, 1), "growth_per_s": round(g, 3)})
            if "stopping" in info.get("cause", []):
                msg = f"{desc(veh)} in front of the ego vehicle stops suddenly"
            else:
                details["ttc_s"] = round(1.0 / g, 2) if g > 0 else None
                ttc = f" (time to contact about {1.0 / g:.1f} s)" if g > 0 else ""
                msg = f"{desc(veh)} in front of the ego vehicle brakes: the ego vehicle closes in fast{ttc}"
        elif s is Situation.BLOCKED_LANE:
            (t,) = objs
            lanes = info.get("lane", [])
            msg = f"lane {', '.join(str(x) for x in lanes) or '?'} is blocked by {desc(t)}, standing still"
        else:  # EXITING_VEHICLE
            p, veh = objs
            msg = f"{desc(p)} appeared next to {desc(veh)}, which stands still: a person may be getting out"
        return Warning(f, s.name, tuple(int(o) for o in objs), msg, details)
