"""Ground once, solve many: small components answered by long-lived clingo Controls.

A fresh ``Control`` per component pays the grounder's fixed cost per statement of the encoding
(~1.6 ms, whatever the facts). For components of a small *shape* (tracks, detections, outside
occluders) this module grounds the encoding once per shape, with every fact such a component
can state declared ``#external`` over a bounded universe (its slots, the classes and numbers
seen so far), and answers each component by assuming its facts true and every other external
false. The ground program with its externals fixed is the program of those facts, so the
optima and their costs are the fresh solve's; only ties may be broken differently.

The universe comes from the fact vocabulary, never from the rules: it is the union of the facts
:meth:`Component.facts` writes for synthetic components of the shape. A component with a fact
outside the universe (a larger shape, a class or number not seen yet, an optional predicate such
as ``speed/2``) is not answered here (None): the caller solves it on a fresh Control.

With ``lead``, a shape's Control is ground ahead in a worker thread (the grounder lets go of
Python's lock), so that the frame where it becomes due does not pay 50-150 ms for it; the due
component takes it only when it holds the universe that component would be ground with.

Measured on KITTI RRC car (misses of the answer cache, one process): a slot solve takes
0.1-0.8 ms for 1x1 to 3x3 components where a fresh Control takes 2.5-5 ms; every answer had
the fresh solve's cost and atoms. clasp forgets between solves, so an answer does not depend on
the components solved before it; where several optima tie, it may differ from the fresh one's
(1 of ~7,700 real components), and which of the two paths a component takes depends on the
shapes met before it in the process.
"""

from __future__ import annotations

import logging
import os
import threading
import time
import weakref
from collections import OrderedDict
from collections.abc import Collection, Iterable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, replace
from typing import Any

from clingo import Symbol

from sensemaking import asp
from sensemaking.abduction.problem import SHARE_STEP, TRACK_FLAGS, VISIBILITY_VALUES, Component
from sensemaking.abduction.solver import AbductionSolver, Answer, answer_of

__all__ = ["SlotSolver", "Shape", "shape_of", "vocabulary", "pieces", "piece_facts"]

log = logging.getLogger(__name__)

#: clasp forgets what one solve learnt before the next: an answer depends on its facts only,
#: not on the components solved before it in the same Control
_FORGET = "--forget-on-step=varScores,signs,lemmaScores,lemmas"
_UNSEEN: tuple[int, ...] = (-1,)  # the memo's "not looked up yet", compared by identity
#: bound of the memo of each shape's pieces (their literals); past it the memo starts afresh
_MAX_PIECES = 20_000
#: solvers with a worker thread: a fork waits for their groundings (a child must not inherit
#: clingo's locks in the middle of a grounding, e.g. the sandbox's limited child)
_WITH_WORKERS: weakref.WeakSet[SlotSolver] = weakref.WeakSet()
_FORK_HOOK: list[bool] = []


def _settle_before_fork() -> None:
    """Wait for every grounding under way in a worker thread (``os.register_at_fork``)."""
    for solver in list(_WITH_WORKERS):
        for _, future in list(solver._pending.values()):
            if not future.cancelled():
                try:
                    future.result()
                except Exception:  # noqa: BLE001 - the due component grounds it again and says why
                    pass


@dataclass(frozen=True)
class Shape:
    """Counts of a component: tracks, detections, occluders outside it (named by ``hidden_by``)."""

    tracks: int
    dets: int
    occluders: int


def shape_of(component: Component) -> Shape:
    """The shape of a component (its outside occluders are the indices past its tracks)."""
    named = max((o + 1 for _, o in component.hidden_by), default=0)
    return Shape(len(component.tracks), len(component.dets), max(named - len(component.tracks), 0))


def vocabulary(
    shape: Shape,
    classes: Iterable[int],
    numbers: Iterable[int],
    uses: Iterable[str] = (),
    heading: bool = False,
    size_gap: bool = False,
) -> frozenset[Symbol]:
    """Every fact :meth:`Component.facts` can write for a component of ``shape`` whose classes
    lie in ``classes`` and whose likelihoods and confidences lie in ``numbers``: the union of
    the facts of synthetic components that take each value of each field once. ``heading``:
    with the ``moving`` and ``heading`` facts (given only with ``direction_weight``);
    ``size_gap``: with the ``size_gap`` facts (only with ``size_weight``)."""
    nt, nd, no = shape.tracks, shape.dets, shape.occluders
    classes, numbers, uses = sorted(set(classes)), sorted(set(numbers)), tuple(uses)
    flags_on = (True,) * len(TRACK_FLAGS)
    pairs = [(t, d) for t in range(nt) for d in range(nd)]
    parts: list[Component] = [Component(True, (), (), (), (), (), (), ())]
    for active in (True, False):
        for cls in classes:
            for vis in range(len(VISIBILITY_VALUES)):
                row = (active, *flags_on, cls, vis, -1)
                parts.append(Component(True, (row,) * nt, (), (), (), (), (), ()))
    for number in numbers:
        for cls in classes:
            det_row = (number, cls, True, True)
            parts.append(Component(False, (), (det_row,) * nd, (), (), (), (), ()))
        parts.append(
            Component(False, (), (), tuple((t, d, number, True) for t, d in pairs), (), (), (), ())
        )
    parts.append(
        Component(
            False,
            (),
            (),
            (),
            covers=tuple(
                (d, t, r, level, margin)  # each share, and the two margins (clear or not)
                for t, d in pairs
                for r in range(-1, nd)
                for level in range(0, 1001, SHARE_STEP)
                for margin in ((0, 1000) if level == 0 else (1000,))
            ),
            keeps_covering=tuple((d, t) for t, d in pairs),
            emerges=tuple((d, t) for t, d in pairs),
            hidden_by=tuple((t, o) for t in range(nt) for o in range(nt + no)),
            fits=tuple(pairs),
        )
    )
    if heading:
        levels = tuple((t, d, a) for t, d in pairs for a in range(1, 5))
        parts.append(replace(_NOTHING, moving=tuple(range(nt)), heading=levels))
    if size_gap:
        gaps = tuple((t, d, a) for t, d in pairs for a in range(1, 5))
        parts.append(replace(_NOTHING, size_gap=gaps))
    out: set[Symbol] = set()
    for part in parts:
        out.update(part.facts(uses))
    return frozenset(out)


_NOTHING = Component(False, (), (), (), (), (), (), ())


def pieces(component: Component) -> list[tuple]:
    """The component element by element: its ``first_frame`` flag, each track and detection row
    with its index, each row of its relations. :func:`piece_facts` of all of them together are
    :meth:`Component.facts` (each fact is written from one element)."""
    out: list[tuple] = [("first_frame", component.first_frame)]
    out += [("tracks", i, row) for i, row in enumerate(component.tracks)]
    out += [("dets", j, row) for j, row in enumerate(component.dets)]
    for name in _RELATIONS:
        out += [(name, row) for row in getattr(component, name)]
    return out


# ended tracks (gone, back) and last seen fits (at_last_seen) lie outside every universe: such
# components take a fresh Control
_RELATIONS = (
    "cand",
    "covers",
    "keeps_covering",
    "emerges",
    "hidden_by",
    "fits",
    "gone",
    "back",
    "moving",
    "heading",
    "size_gap",
    "at_last_seen",
)


def piece_facts(piece: tuple, uses: Collection[str] = ()) -> frozenset[Symbol]:
    """The facts :meth:`Component.facts` writes for one element of :func:`pieces`: those of a
    component holding only that element (a track or detection row at index ``i``: the facts of
    ``i + 1`` copies of the row less those of ``i`` copies)."""
    name = piece[0]
    if name == "first_frame":
        return frozenset(replace(_NOTHING, first_frame=piece[1]).facts(uses))
    if name in ("tracks", "dets"):
        _, index, row = piece
        more: dict[str, Any] = {name: (row,) * (index + 1)}
        less: dict[str, Any] = {name: (row,) * index}
        return frozenset(replace(_NOTHING, **more).facts(uses)) - frozenset(
            replace(_NOTHING, **less).facts(uses)
        )
    only: dict[str, Any] = {name: (piece[1],)}
    return frozenset(replace(_NOTHING, **only).facts(uses))


class _Grounded:
    """One shape's encoding, ground once with its universe of facts as free externals."""

    def __init__(
        self,
        solver: AbductionSolver,
        universe: frozenset[Symbol],
        classes: frozenset[int] = frozenset(),
        numbers: frozenset[int] = frozenset(),
    ):
        #: the classes and numbers the universe was made with
        self.classes, self.numbers = classes, numbers
        self.ctl = asp.control([*solver.options, _FORGET], asp.parsed(solver.program))
        externals = "\n".join(f"#external {fact}. [free]" for fact in sorted(universe))
        self.ctl.add("base", [], externals)
        self.ctl.ground([("base", [])])
        atoms = self.ctl.symbolic_atoms
        # a fact some rule also derives is no longer external: it cannot be set, so a component
        # stating it is not answered here
        #: fact (its text: a Symbol is an object Python's garbage collector walks, thousands
        #: a shape) -> its program literal (0: no rule reads the fact, the grounder dropped it:
        #: true or false, it changes nothing)
        self.literal: dict[str, int] = {}
        for fact in universe:
            atom = atoms[fact]
            if atom is None:
                self.literal[str(fact)] = 0
            elif atom.is_external:
                self.literal[str(fact)] = atom.literal
        literals = [lit for lit in self.literal.values() if lit]
        #: every external false: a component's assumptions are this with its facts made true
        self._all_false = [-lit for lit in literals]
        self._position = {lit: i for i, lit in enumerate(literals)}
        #: piece -> the literals of its facts, or None when one lies outside the universe
        self._piece_literals: dict[tuple, tuple[int, ...] | None] = {}
        self._uses = solver.uses

    def literals_of(self, component: Component) -> set[int] | None:
        """The literals of the component's facts; None if one is not a settable external."""
        true: set[int] = set()
        known = self._piece_literals
        for piece in pieces(component):
            lits = known.get(piece, _UNSEEN)
            if lits is _UNSEEN:
                if len(known) >= _MAX_PIECES:
                    known.clear()
                lits = known[piece] = self._lookup(piece_facts(piece, self._uses))
            if lits is None:
                return None
            true.update(lits)
        return true

    def _lookup(self, facts: Iterable[Symbol]) -> tuple[int, ...] | None:
        lits = []
        for fact in facts:
            lit = self.literal.get(str(fact))
            if lit is None:
                return None
            lits.append(lit)
        return tuple(lits)

    def solve(self, true: set[int], budget_ms: float | None) -> Answer | None:
        """Solve with the externals of ``true`` (literals) true and all others false."""
        t0 = time.perf_counter()
        assumptions = self._all_false.copy()
        position = self._position
        for lit in true:
            if lit:  # 0: a fact no rule reads
                assumptions[position[lit]] = lit
        solved = asp.solve(self.ctl, budget_ms, assumptions=assumptions, started=t0)
        return None if solved is None else answer_of(solved)


class SlotSolver:
    """Answers components up to a small shape from Controls ground once per shape.

    A shape is ground once its components declined so far would have cost about as much on
    fresh Controls as grounding it costs (rent, then buy: never more than twice the better of
    the two), so shapes met a few times stay on fresh Controls. The cost is counted in
    components, not measured in time: which components take which path, and so how ties are
    broken, does not depend on the machine's load.

    Args:
        solver: the program, constants and options (the answers are optimal answers of
            ``solver.solve_facts(component.facts())``, with the same cost).
        numbers: likelihoods and confidences expected in the facts (0..1000), e.g. the
            tracker's likelihood grid; others are learnt when they appear.
        max_tracks, max_dets, max_occluders: the largest shape answered here.
        max_classes, max_numbers: bounds of the learnt universe (memory and grounding time);
            a component with a class or number past them goes to the fresh Control.
        max_controls: ground shapes kept (least recently used out): bounds the memory (the
            largest shape, 6 x 6 with 2 occluders, 2 classes and 42 numbers: ~6 MB).
        misses_per_cell: a shape is ground at its n-th component, n = this times
            ``(tracks + 1) x (detections + 1)`` (grounding measured ~2 ms per such cell with
            the 42 numbers of the tracker's grid, a fresh solve 2.5-5 ms); 0: at once.
        lead: 0: a shape is ground in the caller's thread at its n-th component (that frame
            pays for it: 50-150 ms for the larger shapes). 0 < lead < 1: a worker thread starts
            grounding it at its ``lead`` x n-th component, with the classes and numbers known
            then, and the n-th component takes that Control (waiting for the worker if it is
            not done) when they are the ones it would be ground with now; otherwise it is
            ground at once as without ``lead``. Either way the shape's Control is the same
            program from the same component on: the answers are those of ``lead=0``.
        max_pending: groundings started ahead and not taken yet, at most (memory: a Control
            each); past it the one started first is dropped.
    """

    def __init__(
        self,
        solver: AbductionSolver,
        numbers: Iterable[int] = (),
        max_tracks: int = 6,
        max_dets: int = 6,
        max_occluders: int = 2,
        max_classes: int = 8,
        max_numbers: int = 128,
        max_controls: int = 32,
        misses_per_cell: float = 0.5,
        lead: float = 0.0,
        max_pending: int = 8,
    ):
        self.solver = solver
        self.max_shape = Shape(max_tracks, max_dets, max_occluders)
        self.max_classes, self.max_numbers = max_classes, max_numbers
        self.classes: set[int] = set()
        self.numbers: set[int] = {int(n) for n in numbers}
        self.max_controls = max_controls
        self.misses_per_cell = misses_per_cell
        #: the ground shapes, least recently used first
        self._grounded: OrderedDict[Shape, _Grounded] = OrderedDict()
        #: components declined per shape not ground yet
        self._misses: dict[Shape, int] = {}
        self.lead, self.max_pending = lead, max_pending
        #: shapes being ground ahead in the worker: the classes and numbers, the grounding
        self._pending: dict[Shape, tuple[tuple[frozenset[int], frozenset[int]], Future]] = {}
        self._worker: ThreadPoolExecutor | None = None
        self._lock = threading.Lock()
        self.stats = {"answered": 0, "outside": 0, "grounded": 0, "ahead": 0}

    def expect(self, numbers: Iterable[int]) -> None:
        """Add likelihoods and confidences to the universe (shapes ground later include them)."""
        with self._lock:
            more = {int(n) for n in numbers} - self.numbers
            if len(self.numbers) + len(more) <= self.max_numbers:
                self.numbers |= more

    def fits(self, shape: Shape) -> bool:
        """Whether components of this shape are answered here (given known values)."""
        m = self.max_shape
        return shape.tracks <= m.tracks and shape.dets <= m.dets and shape.occluders <= m.occluders

    def solve(self, component: Component, budget_ms: float | None = None) -> Answer | None:
        """The component's answer (local indices), or None when it lies outside the slots or
        got no complete answer here (the caller then solves it on a fresh Control)."""
        shape = shape_of(component)
        if not self.fits(shape):
            self.stats["outside"] += 1
            return None
        with self._lock:
            grounded = self._grounded.get(shape)
            if grounded is not None:
                self._grounded.move_to_end(shape)
            else:
                self._misses[shape] = misses = self._misses.get(shape, 0) + 1
                due = self.misses_per_cell * (shape.tracks + 1) * (shape.dets + 1)
                if misses > due:
                    grounded = self._ground(shape, component)
                elif misses > self.lead * due and self.lead > 0:
                    self._start(shape, component)
            true = None if grounded is None else grounded.literals_of(component)
            if true is None and grounded is not None and self._brings_values(component, grounded):
                grounded = self._ground(shape, component)
                true = grounded.literals_of(component)
            if true is None or grounded is None:  # grounded is None only with true None
                self.stats["outside"] += 1
                return None
            answer = grounded.solve(true, budget_ms)
        if answer is None or answer.budget_hit:
            # a search cut short by the conflict budget may stop elsewhere than the fresh one's
            self.stats["outside"] += 1
            return None
        self.stats["answered"] += 1
        return answer

    def _values(self, component: Component) -> tuple[set[int], set[int]]:
        """The classes and the numbers (confidences, likelihoods) of the component's facts."""
        classes = {row[-3] for row in component.tracks} | {row[1] for row in component.dets}
        numbers = {row[0] for row in component.dets} | {row[2] for row in component.cand}
        return classes, numbers

    def _brings_values(self, component: Component, grounded: _Grounded) -> bool:
        """Whether the component has a class or number the shape was not ground with (and the
        universe may grow by them)."""
        classes, numbers = self._values(component)
        if classes <= grounded.classes and numbers <= grounded.numbers:
            return False
        return (
            len(self.classes | classes) <= self.max_classes
            and len(self.numbers | numbers) <= self.max_numbers
        )

    def _with(self, component: Component) -> tuple[frozenset[int], frozenset[int]]:
        """The classes and numbers known with the component's added (within the bounds)."""
        classes, numbers = self._values(component)
        if len(self.classes | classes) <= self.max_classes:
            classes = self.classes | classes
        else:
            classes = set(self.classes)
        if len(self.numbers | numbers) <= self.max_numbers:
            numbers = self.numbers | numbers
        else:
            numbers = set(self.numbers)
        return frozenset(classes), frozenset(numbers)

    def _ground(self, shape: Shape, component: Component) -> _Grounded:
        """Ground the shape with the classes and numbers known, the component's added; the
        Control ground ahead for them if there is one."""
        values = self._with(component)
        self.classes, self.numbers = set(values[0]), set(values[1])
        self._misses.pop(shape, None)
        ahead = self._pending.pop(shape, None)
        if ahead is not None and ahead[0] == values:
            self.stats["ahead"] += 1
            return self._install(shape, ahead[1].result())  # waits for the worker if need be
        return self._install(shape, _build(self.solver, shape, *values))

    def _start(self, shape: Shape, component: Component) -> None:
        """Start grounding the shape in the worker with the values known now (the
        component's added), unless it is started already; past ``max_pending``, the grounding
        started first is dropped (a shape whose components stopped coming)."""
        if shape in self._pending:
            return
        while len(self._pending) >= self.max_pending:
            oldest = next(iter(self._pending))
            self._pending.pop(oldest)[1].cancel()
        values = self._with(component)
        if self._worker is None:
            self._worker = ThreadPoolExecutor(max_workers=1, thread_name_prefix="slots")
            _WITH_WORKERS.add(self)
            if not _FORK_HOOK and hasattr(os, "register_at_fork"):
                os.register_at_fork(before=_settle_before_fork)
                _FORK_HOOK.append(True)
        self._pending[shape] = (values, self._worker.submit(_build, self.solver, shape, *values))

    def _install(self, shape: Shape, grounded: _Grounded) -> _Grounded:
        """Keep a ground shape (least recently used out past ``max_controls``)."""
        self._grounded[shape] = grounded
        self._grounded.move_to_end(shape)
        while len(self._grounded) > self.max_controls:
            self._grounded.popitem(last=False)
        self.stats["grounded"] += 1
        return grounded


def _build(
    solver: AbductionSolver, shape: Shape, classes: frozenset[int], numbers: frozenset[int]
) -> _Grounded:
    """A shape's Control, ground with its universe (reads nothing but its arguments: it may run
    in a worker thread; clingo's symbol table is locked, and the grounder lets go of Python's
    lock while it works)."""
    t0 = time.perf_counter()
    heading = solver.constants.get("direction_weight", 0) > 0
    size_gap = solver.constants.get("size_weight", 0) > 0
    universe = vocabulary(shape, classes, numbers, solver.uses, heading, size_gap)
    grounded = _Grounded(solver, universe, classes, numbers)
    ms = (time.perf_counter() - t0) * 1000.0
    log.debug("ground shape %s: %d externals, %.1f ms", shape, len(universe), ms)
    return grounded
