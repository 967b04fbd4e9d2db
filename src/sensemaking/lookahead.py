"""Fixed-lag abduction: frame t is decided together with frames t+1..t+k (issue 27).

The online tracker commits each frame to its own optimum; when two people cross, the optimum
at the crossing frame can swap them, and no later frame undoes it. :class:`LookaheadTracker`
keeps the last k frames undecided. When frame t+k arrives it decides frame t: where a part of
frame t is *contested* -- the encoding's next-best explanation of that part (solved again with
the chosen actions forbidden, as :meth:`AbductionSolver.alternatives` does) costs at most
``lookahead_margin`` more than the optimum -- each such hypothesis (at most
``lookahead_hypotheses`` in all, the optimum included) is rolled forward through t+1..t+k by
the ordinary online tracker on a copy of the tracker's state, and frame t gets the hypothesis
whose summed abduction cost over t..t+k is lowest (multiple-hypothesis tracking with N-best
pruning, over a window of k frames). Ties keep the online optimum. The costs are the
encoding's (``tracking.lp``): this module only chooses between its answers.

Outputs of frame t are final k frames later: :meth:`LookaheadTracker.push` returns the results
that became final, :meth:`LookaheadTracker.flush` decides the frames still waiting at the end
of the input. ``k = 0`` is the online tracker, result for result.

Work per frame (the budget, deterministic: counted in units of about one online frame update,
not in time): one online update of the new frame, as online; for a part that passes a cheap
likelihood test (a swap or a rival detection within the margin, or a resumed track) one ground
program solved at most ``hypotheses`` times to find its alternatives (remembered by the part's
canonical facts; ``CHECK_UNITS``); and the roll-forwards, ``k + 1`` frames per hypothesis, each
a frame update and the costs of the parts where the hypotheses differ (``ROLL_UNITS``). Each
decided frame earns ``CREDIT_PER_FRAME`` (0.75) units of credit, saved up to
``2 * ROLL_UNITS * (hypotheses - 1) * (k + 1)``; a check or a hypothesis the credit does not
pay for is not done (the frame is decided online, counted in ``stats["over_budget"]``). So the
look-ahead's extra work averages at most 0.75 units per frame (under twice the online work),
and the worst frame's is bounded by the
saved credit, each solve under the solver's ``max_conflicts`` budget.

Two refinements, off by default (settings, docs/DESIGN-NOTES.md "Look-ahead with a continuity
term"): ``lookahead_continuity`` adds to each chain's score how far the boxes its tracks take
over the window stray from the constant-velocity extrapolation of their motion before frame t
(per box height, capped at one; summed over the tracks both chains see), so a swap is judged by
the motion it breaks as well as by the encoding's costs; ``lookahead_crowd_budget`` counts the
work in candidate pairs instead of frames (:meth:`LookaheadTracker._work`): a frame earns in
proportion to its problem's size, a check costs in proportion to its part's, a rolled frame a
share of its size (:data:`ROLL_SHARE`, the unchanged parts come from the cache) and the parts
that differ, so the credit follows the crowd.
"""

from __future__ import annotations

import time
from collections import Counter, OrderedDict, deque
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from clingo import Function, Number, Symbol

from sensemaking import asp
from sensemaking.abduction.problem import Component, FrameProblem
from sensemaking.abduction.solver import Answer, Det, Ref, answer_of
from sensemaking.config import TrackerConfig
from sensemaking.results import FrameResult, TrackState
from sensemaking.tracker import Tracker, TrackerState, frozen_problem

__all__ = ["LookaheadTracker", "make_tracker"]

#: work units (one unit: about one online frame update) of one frame of a roll-forward: the
#: frame's update and the costs of the parts where the hypotheses differ
ROLL_UNITS = 2.0
#: work units of finding a part's alternatives (one ground program, solved a few times)
CHECK_UNITS = 1.0
#: work units each decided frame earns: below one, so that the look-ahead stays under twice the
#: online work where its frames cost more than an online one (fresh parts, not in the cache)
CREDIT_PER_FRAME = 0.75

#: crowd budget: work of a rolled frame, per candidate pair of the frame. A cached update costs
#: a tenth of an uncached one, but a changed identity changes the facts of the crowd's large
#: parts downstream: on MOT17-02 a rolled frame cost about an online frame (0.25 here: 2.3x)
ROLL_SHARE = 1.0
#: crowd budget: work of finding a part's alternatives (one grounding, a few solves) and of a
#: differing part of a rolled frame (solved, its cost compared), per candidate pair of the part
PART_UNITS = 2.0
#: continuity term: a track's deviation from its extrapolated motion counts at most this many
#: box heights per frame (a track that jumped to another person deviates by about one)
CONTINUITY_CAP = 1.0
#: continuity term: the tracks whose velocity is known (matched at least this many times)
CONTINUITY_MIN_HITS = 3

#: the actions that say who is who in a part of a frame: an alternative must change one
_IDENTITY = ("assign", "resume", "start")


@dataclass
class _Step:
    """One frame of the window: its input, what the tracker made of it, the state after it."""

    frame: int
    detections: Any
    result: FrameResult
    answer: Answer
    after: TrackerState
    #: the problem as it was solved (None without abduction)
    problem: FrameProblem | None
    _parts: list[tuple[Component, list[int], list[int]]] | None = None

    @property
    def parts(self) -> list[tuple[Component, list[int], list[int]]]:
        """The frame's parts ``(component, track ids, detection rows)``, cut when first asked
        (none without abduction): most frames are never asked."""
        if self._parts is None:
            self._parts = [] if self.problem is None else self.problem.components()
        return self._parts


class LookaheadTracker:
    """A :class:`~sensemaking.tracker.Tracker` whose frame t is decided at frame t + ``lag``.

    Args:
        tracker: the online tracker (its state is the front of the window; its solver and
            caches serve the hypotheses too).
        lag: frames of look-ahead k (default: ``config.lookahead_frames``); 0: online.
        hypotheses: most hypotheses per decided frame, the online optimum included (default
            ``config.lookahead_hypotheses``).
        margin: a part of a frame is contested when an alternative costs at most this much
            more than its optimum (solver units; default ``config.lookahead_margin``).
    """

    def __init__(
        self,
        tracker: Tracker,
        lag: int | None = None,
        hypotheses: int | None = None,
        margin: int | None = None,
        memo_size: int = 20_000,
        continuity: int | None = None,
        crowd_budget: bool | None = None,
    ):
        c = tracker.config
        self.tracker = tracker
        self.lag = c.lookahead_frames if lag is None else int(lag)
        self.hypotheses = c.lookahead_hypotheses if hypotheses is None else int(hypotheses)
        self.margin = c.lookahead_margin if margin is None else int(margin)
        self.continuity = c.lookahead_continuity if continuity is None else int(continuity)
        self.crowd = c.lookahead_crowd_budget if crowd_budget is None else bool(crowd_budget)
        if self.lag < 0 or self.hypotheses < 1 or self.margin < 0 or self.continuity < 0:
            raise ValueError("lag, margin and continuity must be >= 0, hypotheses >= 1")
        self.memo_size = memo_size
        # the work budget, in frame updates: each decided frame earns one (look-ahead at most
        # twice the online updates on average), a roll-forward spends one per frame of the
        # window and hypothesis; saved up to one worst frame's need, twice over
        self._max_credit = 2.0 * ROLL_UNITS * (self.hypotheses - 1) * (self.lag + 1)
        self._credit = self._max_credit
        self._full = self.crowd  # with the crowd budget, filled at the first decided frame
        self._base = tracker.snapshot()  # the state before the oldest frame of the window
        self._window: deque[_Step] = deque()
        self._alternatives: OrderedDict[tuple[Component, tuple[Symbol, ...]], list[Any]] = (
            OrderedDict()
        )
        self._costs: OrderedDict[Component, int] = OrderedDict()
        self.stats: dict[str, Any] = {
            "frames": 0,
            "decided": 0,
            "contested": 0,
            "rollouts": 0,
            "switched": 0,
            "by_continuity": 0,
            "checked": 0,
            "over_budget": 0,
            "timed_out": 0,
            "solve_ms": 0.0,
            "lookahead_ms": 0.0,
        }

    # -- what the pipeline reads ----------------------------------------------------------------
    @property
    def config(self) -> TrackerConfig:
        return self.tracker.config

    @property
    def n_tracks(self) -> int:
        """Live tracks at the front of the window (after the newest frame)."""
        return self.tracker.n_tracks

    @property
    def pending(self) -> int:
        """Frames given and not yet decided."""
        return len(self._window)

    # -- frames in, final results out ---------------------------------------------------------
    def push(self, detections: Any, frame: int | None = None) -> list[FrameResult]:
        """Take one frame (as :meth:`Tracker.update`); return the results that became final
        (frame ``frame - lag``; none while the window fills)."""
        before = self.tracker.stats["solve_ms"]
        result, answer, solved = self._decide(detections, frame)
        self.stats["solve_ms"] += self.tracker.stats["solve_ms"] - before
        self.stats["frames"] += 1
        self.stats["timed_out"] += int(result.timed_out)
        step = _Step(result.frame, detections, result, answer, self.tracker.snapshot(), solved)
        self._window.append(step)
        out = []
        while len(self._window) > self.lag:
            out.append(self._decide_oldest())
        return out

    def update(self, detections: Any, frame: int | None = None) -> list[FrameResult]:
        """:meth:`push` (the name the online tracker's callers know)."""
        return self.push(detections, frame)

    def flush(self) -> list[FrameResult]:
        """Decide every frame still waiting, with the frames that followed it (end of input)."""
        out = []
        while self._window:
            out.append(self._decide_oldest())
        return out

    def reset(self) -> None:
        """Forget every track and waiting frame (a new sequence)."""
        self.tracker.reset()
        self._base = self.tracker.snapshot()
        self._window.clear()

    # -- deciding the oldest frame ----------------------------------------------------------------
    def _decide_oldest(self) -> FrameResult:
        t0 = time.perf_counter()
        frames = len(self._window)  # the roll-forward of one hypothesis updates this many
        earned = CREDIT_PER_FRAME * self._work(self._window[0])
        cap = self._max_credit * self._window_work() / frames
        if self._full:  # the credit starts saved up, in the budget's units
            self._credit, self._full = cap, False
        self._credit = min(self._credit + earned, cap)
        if frames > 1:
            hypotheses = self._hypotheses(self._window[0])
            if hypotheses:
                self.stats["contested"] += 1
                paid = []
                for delta, answer, size in hypotheses:
                    need = self._roll_units(size)
                    if self._credit < need:
                        self.stats["over_budget"] += 1
                        break
                    self._credit -= need
                    paid.append((delta, answer, size))
                if paid:
                    self._roll(paid)
        step = self._window.popleft()
        self._base = step.after
        self.stats["decided"] += 1
        self.stats["lookahead_ms"] += (time.perf_counter() - t0) * 1e3
        return step.result

    # -- the work budget ----------------------------------------------------------------------
    def _work(self, step: _Step) -> float:
        """What an online update of the frame is counted: one unit, or with the crowd budget
        its problem's size (candidate pairs, tracks and detections, plus one)."""
        if not self.crowd:
            return 1.0
        problem = step.problem
        if problem is None:
            return 1.0
        return float(1 + len(problem.cand) + len(problem.track_id) + len(step.detections))

    def _window_work(self) -> float:
        """:meth:`_work` summed over the frames of the window."""
        return sum(self._work(s) for s in self._window)

    def _part_work(self, component: Component) -> float:
        """What solving a part is counted with the crowd budget (its size, plus one)."""
        return float(1 + len(component.cand) + len(component.tracks) + len(component.dets))

    def _roll_units(self, size: float) -> float:
        """The work of rolling one hypothesis forward through the window: ``ROLL_UNITS`` a
        frame; with the crowd budget a share of each frame (cached parts) and the contested
        part (``size``, :meth:`_part_work`) solved in each frame."""
        frames = len(self._window)
        if not self.crowd:
            return ROLL_UNITS * frames
        return ROLL_SHARE * self._window_work() + PART_UNITS * size * frames

    def _check_units(self, component: Component) -> float:
        return PART_UNITS * self._part_work(component) if self.crowd else CHECK_UNITS

    def _hypotheses(self, step: _Step) -> list[tuple[int, Answer, float]]:
        """The frame's alternatives within the margin, cheapest first, at most
        ``hypotheses - 1``: ``(cost above the chosen answer, the whole frame's answer, the
        work of its part)``."""
        if self.hypotheses < 2 or not _frame_may_be_contested(step, self.margin):
            return []
        found: list[tuple[int, Answer, float]] = []
        for component, track_ids, det_rows in step.parts:
            if not component.cand:
                continue
            own = track_ids[: len(component.tracks)]
            chosen = _identity_atoms(step.answer, own, det_rows)
            if not chosen or not _may_be_contested(component, chosen, self.margin):
                continue
            for delta, local in self._component_alternatives(component, tuple(chosen)):
                if delta <= self.margin:
                    whole = _replace_part(step.answer, own, det_rows)
                    whole.merge(local.mapped(track_ids, det_rows))
                    found.append((delta, whole, self._part_work(component)))
        found.sort(key=lambda x: x[0])
        return found[: self.hypotheses - 1]

    def _component_alternatives(
        self, component: Component, chosen: tuple[Symbol, ...]
    ) -> list[tuple[int, Answer]]:
        """The next-best answers of a part (local terms) with the chosen identity actions
        forbidden, each with its cost above the part's optimum (remembered by the facts)."""
        key = (component, chosen)
        hit = self._alternatives.get(key)
        if hit is not None:
            self._alternatives.move_to_end(key)
            return hit
        check = self._check_units(component)
        # with the crowd budget a check is made only if a roll-forward of its part can follow
        need = check + (self._roll_units(self._part_work(component)) if self.crowd else 0.0)
        if self._credit < need:
            self.stats["over_budget"] += 1
            return []
        self._credit -= check
        self.stats["checked"] += 1
        solver = self.tracker.solver.solver
        # one ground program, solved again after each forbidden explanation
        ctl = asp.control(solver.options, asp.parsed(solver.program), component.facts(solver.uses))
        ctl.ground([("base", [])])
        best = self._known_cost(component)
        if best is None:
            solved = asp.solve(ctl)
            best = 0 if solved is None else solved.cost
            _remember(self._costs, component, best, self.memo_size)
        out: list[tuple[int, Answer]] = []
        forbid = list(chosen)
        while len(out) < self.hypotheses - 1:
            asp.forbid(ctl, [forbid])
            solved = asp.solve(ctl)
            if solved is None or solved.cost - best > self.margin:
                break
            alt = answer_of(solved)
            out.append((solved.cost - best, alt))
            forbid = _local_identity_atoms(alt)
            if not forbid:
                break
        _remember(self._alternatives, key, out, self.memo_size)
        return out

    def _known_cost(self, component: Component) -> int | None:
        """The optimal cost of a part if known (remembered here, or by the tracker's cache)."""
        hit = self._costs.get(component)
        if hit is not None:
            self._costs.move_to_end(component)
            return hit
        cost = self.tracker.solver.remembered_cost(component)
        if cost is None:
            return None
        _remember(self._costs, component, cost, self.memo_size)
        return cost

    def _cost(self, component: Component) -> int:
        """The optimal cost of a part (solver units at priority >= 0), remembered."""
        known = self._known_cost(component)
        if known is not None:
            return known
        solver = self.tracker.solver.solver
        answer = solver.solve_facts(component.facts(solver.uses))
        cost = 0 if answer is None or answer.cost is None else answer.cost
        _remember(self._costs, component, cost, self.memo_size)
        return cost

    def _cost_sum(self, parts: Counter[Component]) -> int:
        """The summed optimal cost of parts (counted): the unknown ones in one program (the
        objective is a sum over parts, so its optimum is the sum of theirs)."""
        total = 0
        unknown: list[Component] = []
        for component, n in parts.items():
            known = self._known_cost(component)
            if known is None:
                unknown += [component] * n
            else:
                total += known * n
        if len(unknown) == 1:
            return total + self._cost(unknown[0])
        if unknown:
            solver = self.tracker.solver.solver
            facts: list[Symbol] = []
            t0 = d0 = 0
            for c in unknown:
                facts += c.facts(solver.uses, t0, d0)
                t0 += c.n_refs
                d0 += len(c.dets)
            answer = solver.solve_facts(facts)
            total += 0 if answer is None or answer.cost is None else answer.cost
        return total

    def _roll(self, hypotheses: list[tuple[int, Answer, float]]) -> None:
        """Roll each hypothesis of the oldest frame forward through the window; keep the one
        cheapest over the window (the online one on ties) as the window."""
        window = list(self._window)
        parts0 = [_parts(s) for s in window[1:]]
        motion = _motion(self._base) if self.continuity else None
        strays0 = _strays(window, motion) if motion is not None else {}
        best: list[_Step] | None = None
        best_score = 0.0
        best_by_continuity = False
        for delta, answer, size in hypotheses:
            self.stats["rollouts"] += 1
            self.tracker.restore(self._base)
            steps = []
            first = window[0]
            result, applied, solved = self._decide(first.detections, first.frame, answer)
            steps.append(
                _Step(first.frame, first.detections, result, applied, self._snap(), solved)
            )
            score = float(delta)
            differing = 0.0  # crowd budget: the work of the parts solved beyond the contested
            for s, p0 in zip(window[1:], parts0, strict=True):
                result, applied, solved = self._decide(s.detections, s.frame)
                steps.append(_Step(s.frame, s.detections, result, applied, self._snap(), solved))
                mine = _parts(steps[-1])
                score += self._cost_sum(mine - p0) - self._cost_sum(p0 - mine)
                if self.crowd:
                    differing += sum(self._part_work(c) for c in (mine - p0).elements())
            if self.crowd:  # charged after the fact: the estimate counted one part a frame
                self._credit -= max(0.0, PART_UNITS * (differing - size * (len(window) - 1)))
            encoding_score = score
            if motion is not None:
                strays = _strays(steps, motion)
                both = strays.keys() & strays0.keys()
                score += self.continuity * sum(strays[key] - strays0[key] for key in both)
            if score < best_score:
                best, best_score = steps, score
                best_by_continuity = encoding_score >= 0
        if best is None:
            self.tracker.restore(window[-1].after)
            return
        self.stats["switched"] += 1
        self.stats["by_continuity"] += int(best_by_continuity)
        self.tracker.restore(best[-1].after)
        self._window = deque(best)

    def _decide(
        self, detections: Any, frame: int | None, answer: Answer | None = None
    ) -> tuple[FrameResult, Answer, FrameProblem | None]:
        """:meth:`Tracker.decide`, with the result's problem copied: some of its arrays are the
        track table's columns, which the frames after change in place (online, the sinks read
        the problem before the next frame; here k frames later); and the problem as solved."""
        result, applied, solved = self.tracker.decide(
            detections, frame, answer=answer, keep_problem=True
        )
        ab = result.abduction
        if ab is None:
            return result, applied, None
        frozen = replace(ab, problem=frozen_problem(ab.problem))  # as online sinks see it
        return replace(result, abduction=frozen), applied, solved

    def _snap(self) -> TrackerState:
        return self.tracker.snapshot()


def make_tracker(tracker: Tracker) -> Tracker | LookaheadTracker:
    """``tracker`` itself when its ``lookahead_s`` gives no frame of look-ahead, else it wrapped
    in a :class:`LookaheadTracker`."""
    if tracker.config.lookahead_frames <= 0:
        return tracker
    return LookaheadTracker(tracker)


def _motion(state: TrackerState) -> tuple[int, dict[int, np.ndarray]] | None:
    """The tracks' motion before the decided frame: ``(last frame, track id -> (cx, cy, vx,
    vy, h))`` (pixels, pixels per frame) of the tracks matched at least
    :data:`CONTINUITY_MIN_HITS` times; None before the first frame."""
    if state.last_frame is None:
        return None
    table = state.tracks
    keep = np.flatnonzero(table.hits >= CONTINUITY_MIN_HITS)
    if not len(keep):
        return state.last_frame, {}
    x, v = table.kf.cxcywh()[keep], table.kf.velocity()[keep]
    rows = np.column_stack([x[:, :2], v[:, :2], x[:, 3]])
    return state.last_frame, dict(zip(table.id[keep].tolist(), rows, strict=True))


def _strays(
    steps: Sequence[_Step], motion: tuple[int, dict[int, np.ndarray]]
) -> dict[tuple[int, int], float]:
    """``(track id, frame) -> deviation`` over a chain: how far each visible track's box
    centre lies from its constant-velocity extrapolation (:func:`_motion`), in extrapolated
    box heights, at most :data:`CONTINUITY_CAP`."""
    last, rows = motion
    out: dict[tuple[int, int], float] = {}
    if not rows:
        return out
    for step in steps:
        tracks = step.result.tracks
        visible = tracks.data["state"] == TrackState.VISIBLE
        for t, box in zip(tracks.tracker_id[visible].tolist(), tracks.xyxy[visible], strict=True):
            row = rows.get(t)
            if row is None:
                continue
            ahead = step.frame - last
            dx = (box[0] + box[2]) / 2 - (row[0] + ahead * row[2])
            dy = (box[1] + box[3]) / 2 - (row[1] + ahead * row[3])
            out[(t, step.frame)] = min(float(np.hypot(dx, dy)) / max(row[4], 1.0), CONTINUITY_CAP)
    return out


def _frame_may_be_contested(step: _Step, margin: int) -> bool:
    """:func:`_may_be_contested` over the whole frame, before it is cut into parts (a swap or
    a rival detection always lies within one part)."""
    problem, answer = step.problem, step.answer
    if problem is None or not len(problem.cand):
        return False
    if answer.resume:
        return True
    index = {t: i for i, t in enumerate(problem.track_id.tolist())}
    likelihood = {(t, d): lik for t, d, lik in problem.cand.tolist()}
    halted = {i for i, on in enumerate(problem.active.tolist()) if not on}
    matched = {index[t]: d for t, d in answer.assign.items() if t in index}
    return _screen(likelihood, matched, set(answer.start), halted, margin)


def _may_be_contested(component: Component, chosen: Sequence[Symbol], margin: int) -> bool:
    """A cheap necessary test before solving again: the chosen answer of a part (its local
    identity atoms) resumes a track (or a new one could take the detection), starts a track on
    a detection a hidden or missing track could resume, or matches a track and a detection
    that have another candidate whose likelihood is within ``margin`` (a swap of two matches
    costs their two likelihood differences: one of them is then within the margin)."""
    likelihood = {(t, d): lik for t, d, lik, _ in component.cand}
    halted = {t for t, row in enumerate(component.tracks) if not row[0]}
    matched: dict[int, int] = {}
    started: set[int] = set()
    for atom in chosen:
        name, args = atom.name, atom.arguments
        if name == "resume":
            return True
        if name == "start":
            started.add(args[0].arguments[0].number)
            continue
        matched[args[0].number] = args[1].arguments[0].number
    return _screen(likelihood, matched, started, halted, margin)


def _screen(
    likelihood: dict[tuple[int, int], int],
    matched: dict[int, int],
    started: set[int],
    halted: set[int],
    margin: int,
) -> bool:
    """The test of :func:`_may_be_contested` on ``track, detection -> likelihood`` candidates,
    the matches ``track -> detection``, the detections started and the halted tracks."""
    if any((t, d) in likelihood for d in started for t in halted):
        return True
    matched = {t: d for t, d in matched.items() if (t, d) in likelihood}
    if not matched:
        return False
    taken = {d: t for t, d in matched.items()}
    for (t, d), other in likelihood.items():
        mine = matched.get(t)
        if mine is None or mine == d:
            continue
        rival = taken.get(d)
        if rival is None:  # t could take a detection nobody else has
            gap = likelihood[(t, mine)] - other
        elif (rival, mine) in likelihood:  # t and its rival could swap detections
            gap = (
                likelihood[(t, mine)] + likelihood[(rival, d)] - other - likelihood[(rival, mine)]
            )
        else:
            continue
        if gap <= margin:
            return True
    return False


def _parts(step: _Step) -> Counter[Component]:
    """The frame's parts (canonical facts), counted."""
    return Counter(c for c, _, _ in step.parts)


def _det(row: int) -> Symbol:
    return Function("d", [Number(row)])


def _identity_atoms(answer: Answer, own: Sequence[int], rows: Sequence[int]) -> list[Symbol]:
    """The answer's identity actions on a part (``own`` track ids, detection ``rows``), as the
    part's local atoms."""
    tracks = {t: i for i, t in enumerate(own)}
    dets = {d: j for j, d in enumerate(rows)}
    out = []
    for name in ("assign", "resume"):
        for t, d in getattr(answer, name).items():
            if t in tracks:
                out.append(Function(name, [Number(tracks[t]), _det(dets[d])]))
    out += [Function("start", [_det(dets[d])]) for d in answer.start if d in dets]
    return sorted(out)


def _local_identity_atoms(answer: Answer) -> list[Symbol]:
    out = [
        Function(name, [Number(t), _det(d)])
        for name in ("assign", "resume")
        for t, d in getattr(answer, name).items()
    ]
    out += [Function("start", [_det(d)]) for d in answer.start]
    return sorted(out)


def _replace_part(answer: Answer, own: Sequence[int], rows: Sequence[int]) -> Answer:
    """A copy of the frame's answer without what it says about one part (its own tracks and
    its detections), to take that part's alternative instead."""
    tracks, dets = set(own), set(rows)

    def mine(args: tuple[Ref, ...]) -> bool:
        first = next((a for a in args if isinstance(a, (int, Det))), None)
        if isinstance(first, Det):
            return first.row in dets
        return first is not None and first in tracks

    return Answer(
        assign={t: d for t, d in answer.assign.items() if t not in tracks},
        resume={t: d for t, d in answer.resume.items() if t not in tracks},
        start=[d for d in answer.start if d not in dets],
        end=[t for t in answer.end if t not in tracks],
        halt=[t for t in answer.halt if t not in tracks],
        ignore_trk=[t for t in answer.ignore_trk if t not in tracks],
        ignore_det=[d for d in answer.ignore_det if d not in dets],
        events=[(n, a) for n, a in answer.events if not mine(a)],
        fluents=[(n, a, v) for n, a, v in answer.fluents if not mine(a)],
        cost=None,
        optimal=answer.optimal,
    )


def _remember(memo: OrderedDict[Any, Any], key: Any, value: Any, size: int) -> None:
    memo[key] = value
    while len(memo) > size:
        memo.popitem(last=False)
