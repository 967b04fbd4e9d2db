"""A frame's abduction, component by component, with clingo's answers remembered.

Four shortcuts, each forced by the structure of the problem rather than by any rule:

* **Independent components** are solved apart from each other's answers
  (:meth:`FrameProblem.components` gives the argument: no rule of ``tracking.lp`` joins atoms of
  two components and the objective is a sum at every priority). Off for encodings not known to
  be local (``decompose=False``): the frame is one program.
* **A component solved before** is answered from a cache of clingo's answers, keyed by its
  canonical facts (:class:`~sensemaking.abduction.problem.Component`). Answers cut short by the
  wall-clock budget are not remembered (they depend on machine load); answers cut short by the
  deterministic conflict budget are (they do not).
* **A small component not in the cache** is answered by a ``Control`` ground once for its shape
  (:class:`~sensemaking.abduction.slots.SlotSolver`): the facts are externals, and the ground
  program with them fixed is the program of those facts, so the optimum and its cost are a fresh
  solve's; where optima tie, the one chosen may differ (1 in ~7,700 real components). A shape
  starts grounding in a worker thread before it is due (:data:`GROUND_LEAD`), so that no frame
  waits for it; it is the same Control from the same component on as without.
* **The other components not in the cache are solved together**, in one program on one fresh
  ``Control``: the grounder's fixed cost (~1.6 ms per ``Control``, whatever the facts) is paid
  once a frame. Their atoms are told apart by their numbers (each component gets its own range).
  An optimal answer of that program is optimal for each component at every priority, since each
  level is a sum over components.

The cache and the slot Controls live in a :class:`SolverCache`, per program and options; the
trackers of a process share :data:`SHARED` unless given their own. Nothing here depends on
time or machine load, so the same input gives the same output on any machine. Where several
optimal answers tie (measured: about 1 in 7,700 components on KITTI), which one a component
gets may depend on what the cache's solvers solved before: the components solved beside it,
and whether its shape's Control was ground yet.
"""

from __future__ import annotations

import marshal
import threading
import time
from bisect import bisect_right
from collections import OrderedDict
from collections.abc import Iterable
from dataclasses import fields
from operator import attrgetter

from sensemaking.abduction.problem import Component, ComponentFields, FrameProblem
from sensemaking.abduction.slots import SlotSolver
from sensemaking.abduction.solver import AbductionSolver, Answer, Det, Ref

__all__ = ["ComponentSolver", "SolverCache", "SHARED"]

_Key = tuple[str, tuple[str, ...]]  # (program, options)
#: a component as the bytes of its fields (:func:`_plain`), and an answer as plain tuples
#: (:func:`_pack`): bytes and tuples of numbers and strings only, which Python's garbage
#: collector does not walk (measured: 50-60 ms pauses on MOT17 with a few thousand
#: :class:`Answer` objects and their lists remembered); the bytes take ~330 B where the nested
#: tuples took ~1.5 kB, and the cache holds up to 20,000 (issue 23)
Plain = bytes
Packed = tuple


#: a shape's Control starts grounding in a worker thread at this fraction of the components
#: after which it is used (:class:`~sensemaking.abduction.slots.SlotSolver` ``lead``), so that
#: no frame waits 50-150 ms for it; the Control and the answers are the same as without
GROUND_LEAD = 0.5


class SolverCache:
    """What :class:`ComponentSolver` objects remember between frames, per program and options:
    clingo's answers by component (least recently used first) and the Controls ground once for
    small components (grounding a shape costs far more than a solve; clasp forgets between
    solves). Solvers given the same cache share both, so where optima tie, one tracker's
    answers may depend on what another solved before; a cache of its own makes a tracker's
    output depend on its input only. Thread-safe."""

    def __init__(self, lead: float = GROUND_LEAD) -> None:
        #: the slot Controls' ``lead`` (0: every shape ground on the caller's thread, no worker
        #: thread, e.g. before forking a process)
        self.lead = lead
        self._answers: dict[_Key, OrderedDict[Plain, Packed]] = {}
        self._slots: dict[_Key, SlotSolver] = {}
        self.lock = threading.Lock()

    def answers(self, solver: AbductionSolver) -> OrderedDict[Plain, Packed]:
        """The answers remembered for ``solver``'s program and options, keyed by
        :func:`_plain` components, as :func:`_pack` tuples (guard with ``lock``)."""
        with self.lock:
            return self._answers.setdefault(_key(solver), OrderedDict())

    def slots(self, solver: AbductionSolver) -> SlotSolver:
        """The slot Controls of ``solver``'s program and options."""
        with self.lock:
            key = _key(solver)
            found = self._slots.get(key)
            if found is None:
                found = self._slots[key] = SlotSolver(solver, lead=self.lead)
            return found

    def __len__(self) -> int:
        """Answers remembered, over every program."""
        with self.lock:
            return sum(len(a) for a in self._answers.values())

    def clear(self) -> None:
        """Forget every answer and ground Control."""
        with self.lock:
            self._answers.clear()
            self._slots.clear()


def _key(solver: AbductionSolver) -> _Key:
    return (solver.program, tuple(solver.options))


#: the cache shared by every solver (and tracker) of the process not given its own: the
#: default, as it was before caches were objects, so that outputs stay as they were
SHARED = SolverCache()


class ComponentSolver:
    """Solves frames component by component through an LRU cache of clingo's answers.

    Args:
        solver: the clingo solver (program, constants, options).
        decompose: solve independent components separately (True) or the frame as one
            program (False; for encodings whose rules may relate unconnected objects).
        cache_size: components remembered per program and options, for the whole process (least
            recently used first out); 0 disables the cache. Memory stays bounded on runs of any
            length.
        slots: answer small components missing from the cache with Controls ground once
            (:class:`~sensemaking.abduction.slots.SlotSolver`) instead of a fresh Control.
        numbers: the likelihoods and confidences (0..1000) the facts take, e.g. the tracker's
            likelihood grid: ground into the slots up front (others are learnt as they come).
        cache: where answers and slot Controls are kept (default :data:`SHARED`, the process's).
    """

    def __init__(
        self,
        solver: AbductionSolver,
        decompose: bool = True,
        cache_size: int = 20_000,
        slots: bool = True,
        numbers: Iterable[int] = (),
        cache: SolverCache | None = None,
    ):
        self.solver = solver
        self.decompose = decompose
        self.cache_size = cache_size
        self.cache = SHARED if cache is None else cache
        self._lock = self.cache.lock
        self._slots: SlotSolver | None = None
        self._cache = self.cache.answers(solver)
        #: whether the facts state the cover pairs' shares and depths (only for encodings that
        #: read them): else components that differ in those alone share one answer
        self._levels = bool({"cover_share", "cover_depth"} & solver.uses)
        if slots:
            self._slots = self.cache.slots(solver)
            self._slots.expect(numbers)
        self.stats = {"components": 0, "cache_hits": 0, "solver_calls": 0, "slot_calls": 0}

    def solve(self, problem: FrameProblem, budget_ms: float | None = None) -> Answer | None:
        """The frame's answer in its terms (track ids, detection rows); None if no model was
        found within the budgets (the caller falls back for the whole frame)."""
        t0 = time.perf_counter()
        parts = problem.component_fields() if self.decompose else [problem.whole_fields()]
        answer = Answer()
        #: the components not remembered, by their fields (first met first), each with its
        #: cache key and where it occurs in the frame
        missed: dict[ComponentFields, tuple[Plain, list[tuple[list[int], list[int]]]]] = {}
        levels, cache, hits = self._levels, self._cache, 0
        for fields_, track_ids, det_rows in parts:
            key = _plain_fields(fields_, levels)
            with self._lock:
                packed = cache.get(key)
                if packed is not None:
                    cache.move_to_end(key)
            if packed is None:
                missed.setdefault(fields_, (key, []))[1].append((track_ids, det_rows))
                continue
            hits += 1
            _unpack_into(answer, packed, track_ids, det_rows)
        self.stats["cache_hits"] += hits
        comps = {f: Component(*f) for f in missed}
        if missed and self._slots is not None:
            for fields_, component in comps.items():
                left = None if budget_ms is None else budget_ms - (time.perf_counter() - t0) * 1e3
                self._take_slot(answer, missed, fields_, self._slots.solve(component, left))
        if missed:
            remaining = None if budget_ms is None else budget_ms - (time.perf_counter() - t0) * 1e3
            solved = self._solve_together([comps[f] for f in missed], remaining)
            if solved is None:
                return None
            for (key, uses), local in zip(missed.values(), solved, strict=True):
                self._remember(key, local)
                for track_ids, det_rows in uses:
                    answer.merge(local.mapped(track_ids, det_rows))
        self.stats["components"] += len(parts)
        answer.solve_ms = (time.perf_counter() - t0) * 1e3
        return answer

    def _take_slot(
        self,
        answer: Answer,
        missed: dict[ComponentFields, tuple[Plain, list[tuple[list[int], list[int]]]]],
        fields_: ComponentFields,
        local: Answer | None,
    ) -> None:
        """A slot solve's answer into the frame's (None: the component stays in ``missed``,
        for the fresh program)."""
        if local is None:
            return
        self.stats["slot_calls"] += 1
        key, uses = missed.pop(fields_)
        self._remember(key, local)
        for track_ids, det_rows in uses:
            answer.merge(local.mapped(track_ids, det_rows))

    def remembered_cost(self, component: Component) -> int | None:
        """The cost of the cache's answer to ``component``, None if not remembered or solved
        together with other components (no cost of its own); read only."""
        with self._lock:
            packed = self._cache.get(_plain(component, self._levels))
        return None if packed is None else packed[9]

    def _remember(self, key: Plain, local: Answer) -> None:
        if not local.timed_out and self.cache_size > 0:
            packed = _pack(local)
            with self._lock:
                self._cache[key] = packed
                while len(self._cache) > self.cache_size:
                    self._cache.popitem(last=False)

    def _solve_together(
        self, components: list[Component], budget_ms: float | None
    ) -> list[Answer] | None:
        """Each component's answer (in its own numbering), from one program for all of them."""
        self.stats["solver_calls"] += 1
        uses = self.solver.uses
        if len(components) == 1:
            one = self.solver.solve_facts(components[0].facts(uses), budget_ms)
            return None if one is None else [one]
        t_starts, d_starts, facts = [], [], []
        t0 = d0 = 0
        for c in components:
            t_starts.append(t0)
            d_starts.append(d0)
            facts += c.facts(uses, t0, d0)
            t0 += c.n_refs
            d0 += len(c.dets)
        whole = self.solver.solve_facts(facts, budget_ms)
        if whole is None:
            return None
        return _split(whole, t_starts, d_starts)


#: every field of a component, in order: a new field is part of the cache key by itself
_FIELDS = attrgetter(*(f.name for f in fields(Component)))
_COVERS = [f.name for f in fields(Component)].index("covers")


def _plain(c: Component, levels: bool = True) -> Plain:
    """The component's fields as bytes (:func:`_plain_fields`)."""
    return _plain_fields(_FIELDS(c), levels)


def _plain_fields(plain: ComponentFields, levels: bool = True) -> Plain:
    """A component's fields as bytes, equal exactly when the components are (marshal's format
    2 writes no back-references, so equal values of the same types give the same bytes; each
    field holds ints or bools, never both at one place); without ``levels``, the ``covers``
    rows lose their share and depth (facts that do not state them)."""
    if not levels and plain[_COVERS]:
        covers = tuple(row[:3] for row in plain[_COVERS])
        plain = (*plain[:_COVERS], covers, *plain[_COVERS + 1 :])
    return marshal.dumps(plain, 2)


def _pack_ref(x: Ref) -> int | str | tuple[int]:
    return (x.row,) if isinstance(x, Det) else x


def _pack(a: Answer) -> Packed:
    """The answer as nested plain tuples (a detection ``Det(j)`` as ``(j,)``); see
    :func:`_unpack_into`."""
    return (
        tuple(a.assign.items()),
        tuple(a.resume.items()),
        tuple(a.start),
        tuple(a.end),
        tuple(a.halt),
        tuple(a.ignore_trk),
        tuple(a.ignore_det),
        tuple((n, tuple(map(_pack_ref, args))) for n, args in a.events),
        tuple((n, tuple(map(_pack_ref, args)), v) for n, args, v in a.fluents),
        a.cost,
        a.optimal,
        a.budget_hit,
        a.timed_out,
        a.solve_ms,
        tuple((n, tuple(map(_pack_ref, args)), c) for n, args, c in a.confidence),
    )


def _unpack_into(answer: Answer, p: Packed, track_ids: list[int], det_rows: list[int]) -> None:
    """Merge the answer :func:`_pack` made ``p`` of into ``answer`` (as :meth:`Answer.merge`),
    its tracks as ``track_ids`` and detections as ``det_rows`` name them (in the frame's
    terms), without building the Answer between."""
    assign, resume, start, end, halt, ignore_trk, ignore_det, events, fluents = p[:9]
    tid, row = track_ids.__getitem__, det_rows.__getitem__
    if assign:
        answer.assign.update({tid(t): row(d) for t, d in assign})
    if resume:
        answer.resume.update({tid(t): row(d) for t, d in resume})
    if start:
        answer.start += [row(d) for d in start]
    if end:
        answer.end += [tid(t) for t in end]
    if halt:
        answer.halt += [tid(t) for t in halt]
    if ignore_trk:
        answer.ignore_trk += [tid(t) for t in ignore_trk]
    if ignore_det:
        answer.ignore_det += [row(d) for d in ignore_det]
    if events or fluents or p[14]:
        n_tracks = len(track_ids)

        def ref(x: int | str | tuple[int]) -> Ref:
            if isinstance(x, tuple):
                return Det(row(x[0]))
            if isinstance(x, int) and 0 <= x < n_tracks:
                return tid(x)
            return x

        answer.events += [(n, tuple([ref(a) for a in args])) for n, args in events]
        answer.fluents += [(n, tuple([ref(a) for a in args]), v) for n, args, v in fluents]
        answer.confidence += [(n, tuple([ref(a) for a in args]), c) for n, args, c in p[14]]
    cost = p[9]
    answer.cost = None if answer.cost is None or cost is None else answer.cost + cost
    answer.optimal &= p[10]
    answer.budget_hit |= p[11]
    answer.timed_out |= p[12]


def _split(answer: Answer, t_starts: list[int], d_starts: list[int]) -> list[Answer]:
    """The answer of a program of several components, cut into each one's answer in its own
    numbering (component ``k`` owns tracks from ``t_starts[k]`` and detections from
    ``d_starts[k]`` on). The objective's value is known for the whole only: parts get None."""
    parts = [
        Answer(
            cost=None,
            optimal=answer.optimal,
            budget_hit=answer.budget_hit,
            timed_out=answer.timed_out,
        )
        for _ in t_starts
    ]

    def of_track(t: int) -> int:
        return bisect_right(t_starts, t) - 1

    def of_det(d: int) -> int:
        return bisect_right(d_starts, d) - 1

    def local(k: int, args: tuple[Ref, ...]) -> tuple[Ref, ...]:
        return tuple(
            Det(a.row - d_starts[k])
            if isinstance(a, Det)
            else a - t_starts[k]
            if isinstance(a, int)
            else a
            for a in args
        )

    def owner(args: tuple[Ref, ...]) -> int:
        first = next(a for a in args if isinstance(a, (int, Det)))
        return of_det(first.row) if isinstance(first, Det) else of_track(first)

    for name in ("assign", "resume"):
        for t, d in getattr(answer, name).items():
            k = of_track(t)
            getattr(parts[k], name)[t - t_starts[k]] = d - d_starts[k]
    for name in ("start", "ignore_det"):
        for d in getattr(answer, name):
            k = of_det(d)
            getattr(parts[k], name).append(d - d_starts[k])
    for name in ("end", "halt", "ignore_trk"):
        for t in getattr(answer, name):
            k = of_track(t)
            getattr(parts[k], name).append(t - t_starts[k])
    for ev, args in answer.events:
        k = owner(args)
        parts[k].events.append((ev, local(k, args)))
    for fl, args, value in answer.fluents:
        k = owner(args)
        parts[k].fluents.append((fl, local(k, args), value))
    for ev, args, level in answer.confidence:
        k = owner(args)
        parts[k].confidence.append((ev, local(k, args), level))
    return parts
