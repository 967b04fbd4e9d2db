"""Solve abduction problems with clingo: one fresh Control per problem, facts as symbols.

Measured facts behind the choices (see ../shared/DESIGN.md): core-guided optimisation (``usc``)
instead of clingo's default branch-and-bound keeps per-frame abduction in milliseconds; a fresh
``Control`` costs ~0.06 ms and never accumulates atoms (a long-lived one slowed 10x over 400
frames); fluent values are carried in Python and given as facts, never re-grounded.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import clingo
from clingo import Function, Number, Symbol, SymbolType

from sensemaking import asp
from sensemaking.abduction.problem import FrameProblem
from sensemaking.errors import InputError, ProgramError
from sensemaking.sandbox import LimitError, check_atoms, check_program

__all__ = [
    "Alternative",
    "Alternatives",
    "Answer",
    "AbductionSolver",
    "Det",
    "Ref",
    "load_encoding",
    "encoding_constants",
    "read_encoding",
    "answer_of",
]

log = logging.getLogger(__name__)

#: clingo options: core-guided optimisation with stratification by weight (on crowded MOT17
#: frames 20-90x faster than plain usc, same optimum), single thread (deterministic)
DEFAULT_OPTIONS: tuple[str, ...] = ("--opt-strategy=usc,stratify", "--warn=none")


class Det(NamedTuple):
    """A detection of the frame, by its row in the frame's detections."""

    row: int


#: an object an event or fluent names: a track id, a detection, or a constant (``true``, ...)
Ref = int | Det | str


def load_encoding(name: str = "tracking.lp") -> str:
    """Text of an encoding shipped as package data in ``sensemaking/abduction/encodings``."""
    return asp.encoding("sensemaking.abduction", name)


def read_encoding(source: str | Path) -> str:
    """An encoding's text from a path (``.lp`` file) or the text itself. Raises a
    :class:`~sensemaking.errors.InputError` naming the file and clingo's message when it does
    not parse."""
    path = Path(source) if isinstance(source, Path) or str(source).endswith(".lp") else None
    if path is not None:
        from sensemaking.sandbox import read_program_file

        try:
            text = read_program_file(path)
        except (OSError, UnicodeDecodeError) as exc:
            raise InputError(f"cannot read the encoding: {exc}", path) from None
    else:
        text = str(source)
    # no #include / #script (reading files, running code); a syntax error is one line
    check_program(text, str(path) if path is not None else "rules")
    return text


def encoding_constants(encoding: str | None = None) -> dict[str, int]:
    """The ``#const`` defaults of an encoding's text (default: the packaged ``tracking.lp``)."""
    return dict(asp.constants(encoding if encoding is not None else load_encoding()))


@dataclass
class Answer:
    """The abduced hypothesis for one frame (or one component of it).

    Tracks are ints (ids; local indices inside a component), detections are rows. ``events``
    are ``(name, args)``, ``fluents`` ``(name, args, value)`` for the values that changed;
    their arguments are :data:`Ref`: an int names a track, :class:`Det` a detection.
    """

    assign: dict[int, int] = field(default_factory=dict)  # track id -> detection row
    resume: dict[int, int] = field(default_factory=dict)  # track id -> detection row
    start: list[int] = field(default_factory=list)  # detection rows
    end: list[int] = field(default_factory=list)  # track ids
    halt: list[int] = field(default_factory=list)
    ignore_trk: list[int] = field(default_factory=list)
    ignore_det: list[int] = field(default_factory=list)
    events: list[tuple[str, tuple[Ref, ...]]] = field(default_factory=list)
    fluents: list[tuple[str, tuple[Ref, ...], str]] = field(default_factory=list)
    #: ``(event name, args, confidence 0..1000)``: the shown ``confidence/2`` of an event
    confidence: list[tuple[str, tuple[Ref, ...], int]] = field(default_factory=list)
    #: the objective's value at priority >= 0 (None: not known for this part alone)
    cost: int | None = 0
    optimal: bool = True
    #: the deterministic work budget (``max_conflicts``) ended the search: best answer so far
    budget_hit: bool = False
    #: the wall-clock budget ended the search (the answer then depends on machine load)
    timed_out: bool = False
    solve_ms: float = 0.0

    def atoms(self) -> list[str]:
        """Sorted readable atoms (for tests and debugging)."""

        def fmt(x: Ref) -> str:
            return f"d({x.row})" if isinstance(x, Det) else str(x)

        out = [f"assign({t},d({d}))" for t, d in self.assign.items()]
        out += [f"resume({t},d({d}))" for t, d in self.resume.items()]
        out += [f"start(d({d}))" for d in self.start] + [
            f"ignore_det(d({d}))" for d in self.ignore_det
        ]
        out += [f"{n}({t})" for n in ("end", "halt", "ignore_trk") for t in getattr(self, n)]
        out += [f"{n}({','.join(map(fmt, a))})" for n, a in self.events]
        return sorted(out)

    def mapped(self, track_ids: list[int], det_rows: list[int]) -> Answer:
        """This answer of a component, in the frame's terms: local track ``i`` becomes
        ``track_ids[i]``, local detection ``j`` becomes ``det_rows[j]``."""
        ref = _mapper(track_ids, det_rows)
        tid, row = track_ids.__getitem__, det_rows.__getitem__
        return Answer(
            assign={tid(t): row(d) for t, d in self.assign.items()},
            resume={tid(t): row(d) for t, d in self.resume.items()},
            start=[row(d) for d in self.start],
            end=[tid(t) for t in self.end],
            halt=[tid(t) for t in self.halt],
            ignore_trk=[tid(t) for t in self.ignore_trk],
            ignore_det=[row(d) for d in self.ignore_det],
            events=[(n, tuple(ref(a) for a in args)) for n, args in self.events],
            fluents=[(n, tuple(ref(a) for a in args), v) for n, args, v in self.fluents],
            confidence=[(n, tuple(ref(a) for a in args), c) for n, args, c in self.confidence],
            cost=self.cost,
            optimal=self.optimal,
            budget_hit=self.budget_hit,
            timed_out=self.timed_out,
            solve_ms=self.solve_ms,
        )

    def merge(self, part: Answer) -> None:
        """Add the answer of another component (in the frame's terms)."""
        self.assign.update(part.assign)
        self.resume.update(part.resume)
        for name in (
            "start",
            "end",
            "halt",
            "ignore_trk",
            "ignore_det",
            "events",
            "fluents",
            "confidence",
        ):
            getattr(self, name).extend(getattr(part, name))
        self.cost = None if self.cost is None or part.cost is None else self.cost + part.cost
        self.optimal &= part.optimal
        self.budget_hit |= part.budget_hit
        self.timed_out |= part.timed_out


def grounded(
    options: Sequence[str],
    program: str,
    facts: Iterable[Symbol],
    what: str,
    max_atoms: int | None = None,
    scope: str | None = None,
) -> clingo.Control:
    """A fresh Control of ``program`` and ``facts``, its base part ground. A program that fails
    to ground (only a user's rules do, on some facts) is an InputError naming ``what``; more
    than ``max_atoms`` ground atoms one naming ``scope`` (default ``what``)."""
    ctl = asp.control(options, asp.parsed(program), facts)
    try:
        ctl.ground([("base", [])])
    except RuntimeError as exc:
        msg = " ".join(str(exc).split())
        raise ProgramError(f"{what} failed to ground: {msg}") from None
    if max_atoms is not None:
        try:
            check_atoms(len(ctl.symbolic_atoms), max_atoms, scope or what)
        except LimitError as exc:
            raise ProgramError(str(exc)) from None
    return ctl


class AbductionSolver:
    """Grounds and solves an encoding (default: the packaged ``tracking.lp``) plus facts.

    Args:
        constants: values for the encoding's ``#const`` (integers), e.g. ``{"cost_lost": 600}``.
        options: clingo command-line options (default: core-guided optimisation).
        encoding: encoding text (default: the packaged ``tracking.lp``).
        rules: more rules (text) added to the encoding, e.g. a user's events.
        max_conflicts: deterministic work budget per solve, in solver conflicts (clingo's
            ``--solve-limit``): past it the best answer so far is used (``budget_hit``). The
            same input gives the same answer on any machine. None: no limit.
        unread: optional facts (``cover_share``, ...) not given although the program mentions
            them: the caller knows that with its constants they cannot change an answer.
    """

    def __init__(
        self,
        constants: Mapping[str, int] | None = None,
        options: tuple[str, ...] = DEFAULT_OPTIONS,
        encoding: str | None = None,
        rules: Iterable[str] = (),
        max_conflicts: int | None = None,
        unread: Iterable[str] = (),
    ):
        self.constants = {k: int(v) for k, v in (constants or {}).items()}
        self.options = list(options) + [f"-c{k}={v}" for k, v in sorted(self.constants.items())]
        self.options += asp.limits(max_conflicts=max_conflicts)
        base = encoding if encoding is not None else load_encoding()
        rules = list(rules)
        #: the program's texts: the encoding, then each of ``rules``
        self.texts = (base, *rules)
        self.program = "\n".join(self.texts)
        #: ground atoms a frame's program may have (set for a user's encoding or rules)
        self.max_atoms: int | None = None
        #: names the program mentions: optional facts are only given when read
        self.uses = asp.mentioned(self.program) - frozenset(unread)

    def solve(self, problem: FrameProblem, budget_ms: float | None = None) -> Answer | None:
        """The whole frame in one program (no decomposition); None if no model in time."""
        component, track_ids, det_rows = problem.whole()
        answer = self.solve_facts(component.facts(self.uses), budget_ms)
        return None if answer is None else answer.mapped(track_ids, det_rows)

    def solve_facts(
        self,
        facts: Iterable[Symbol],
        budget_ms: float | None = None,
        forbid: Iterable[Iterable[Symbol]] = (),
    ) -> Answer | None:
        """Abduce the optimal hypothesis for the facts; None if no model was found in budget.

        ``budget_ms`` bounds solving in wall-clock time (grounding, not interrupted, counts
        against it); past it the best model so far is used (``Answer.timed_out``). None means
        not even one model was found within the budgets (the caller falls back). An
        unsatisfiable program (only a user's rules can be) raises InputError. ``forbid``:
        conjunctions of shown atoms (e.g. ``occurs(hides_behind(0,1))``) that no answer may
        hold together: integrity constraints added to the ground program (for
        :meth:`alternatives`; none in the normal path).
        """
        found = self._run(facts, budget_ms, forbid)
        return None if found is None else found[1]

    def alternatives(
        self,
        problem: FrameProblem,
        event: tuple[str, tuple[Ref, ...]],
        k: int = 3,
        *,
        decompose: bool | None = None,
    ) -> Alternatives:
        """The next-best explanations of ``event``'s subject (its first argument) in this frame.

        ``event`` is ``(name, args)`` in the frame's terms (track ids, :class:`Det` rows), as
        in :attr:`Answer.events`. The part of the frame that holds the subject is solved as the
        tracker solves it (its component; the whole frame when ``decompose`` is False, default:
        components only for the packaged encoding), then again with the event forbidden, then
        with each explanation found so far forbidden too, up to ``k`` alternatives: the cheapest
        answers of the encoding that explain the subject otherwise, each with its cost. Raises
        ValueError when the event names an object the frame does not have.
        """
        if decompose is None:
            decompose = self.program == load_encoding()
        name, args = event
        if not args:
            raise ValueError(f"event {name} names no object")
        parts = problem.components() if decompose else [problem.whole()]
        for component, track_ids, det_rows in parts:
            local = _local_refs(args, track_ids, len(component.tracks), det_rows)
            if local is None:
                continue
            found = self.alternatives_facts(component.facts(self.uses), (name, local), k)
            return found.mapped(track_ids, det_rows)
        raise ValueError(f"event {name}{tuple(args)} names an object this frame does not have")

    def alternatives_facts(
        self, facts: Iterable[Symbol], event: tuple[str, tuple[Ref, ...]], k: int = 3
    ) -> Alternatives:
        """:meth:`alternatives` of the program of ``facts`` (local terms: ints name tracks,
        :class:`Det` detections ``d(J)``). Work: at most ``k`` + 1 solves, each under the
        solver's ``max_conflicts`` budget."""
        if k < 0:
            raise ValueError(f"k must be >= 0, got {k}")
        facts = list(facts)
        name, args = event
        target = Function("occurs", [Function(name, [_symbol(a) for a in args])])
        subject = _symbol(args[0])
        found = self._run(facts)
        if found is None:
            return Alternatives(event, None, [])
        chosen_atoms, chosen = found
        if target not in chosen_atoms:
            return Alternatives(event, chosen, [])
        mine = {a for a in chosen_atoms if _names(a, subject)}
        forbid: list[list[Symbol]] = [[target]]
        out: list[Alternative] = []
        while len(out) < k:
            found = self._run(facts, forbid=forbid)
            if found is None:
                break
            atoms, answer = found
            theirs = {a for a in atoms if _names(a, subject)}
            if not theirs:
                break
            out.append(
                Alternative(
                    answer=answer,
                    delta=_delta(answer.cost, chosen.cost),
                    instead=tuple(_atom(a) for a in sorted(theirs - mine)),
                    rather=tuple(_atom(a) for a in sorted(mine - theirs)),
                    about=tuple(_atom(a) for a in sorted(theirs)),
                )
            )
            forbid.append(sorted(theirs))
        return Alternatives(event, chosen, out)

    def _run(
        self,
        facts: Iterable[Symbol],
        budget_ms: float | None = None,
        forbid: Iterable[Iterable[Symbol]] = (),
    ) -> tuple[list[Symbol], Answer] | None:
        """The shown atoms of the optimal model and their :class:`Answer` (see solve_facts)."""
        t0 = time.perf_counter()
        forbid = [list(f) for f in forbid]
        ctl = grounded(
            self.options,
            self.program,
            facts,
            "the encoding",
            self.max_atoms,
            "the encoding (one frame)",
        )
        asp.forbid(ctl, forbid)
        try:
            # only a user's encoding or rules can rule out every explanation of a frame
            solved = asp.solve(ctl, budget_ms, started=t0, refuse_unsat=not forbid)
        except asp.Unsatisfiable:
            raise ProgramError(
                "the encoding has no answer set for a frame's facts (UNSATISFIABLE): a "
                "constraint of your rules rules out every explanation"
            ) from None
        return None if solved is None else (solved.symbols, answer_of(solved))


def answer_of(solved: asp.Solved) -> Answer:
    """The :class:`Answer` of a solve of the tracking encoding: its shown atoms read, with the
    cost, optimality and budget flags of the search."""
    answer = _decode(solved.symbols)
    answer.cost = solved.cost
    answer.optimal = solved.exhausted and not solved.timed_out
    answer.budget_hit = not answer.optimal and not solved.timed_out
    answer.timed_out = solved.timed_out
    answer.solve_ms = solved.ms
    return answer


@dataclass(frozen=True)
class Alternative:
    """One alternative explanation: the best answer of the encoding once the chosen explanation
    (and the alternatives before this one) is forbidden.

    Attributes:
        answer: the whole answer of the part of the frame (its ``cost`` at priority >= 0).
        delta: ``answer.cost`` minus the chosen answer's cost (>= 0 when both are optimal;
            None when a cost is not known).
        instead: what this answer holds about the subject and the chosen one does not, as
            ``(name, args)``: events (``missing_detections``, ...) and actions (``end``,
            ``halt``, ``assign``, ``resume``, ``start``, ``ignore_trk``, ``ignore_det``).
        rather: what the chosen answer holds about the subject and this one does not.
        about: everything this answer holds about the subject (``instead`` is empty when it
            is part of the chosen explanation, e.g. a track left unseen without hiding).
    """

    answer: Answer
    delta: int | None
    instead: tuple[tuple[str, tuple[Ref, ...]], ...]
    rather: tuple[tuple[str, tuple[Ref, ...]], ...]
    about: tuple[tuple[str, tuple[Ref, ...]], ...] = ()

    @property
    def cost(self) -> int | None:
        return self.answer.cost

    def mapped(self, track_ids: list[int], det_rows: list[int]) -> Alternative:
        """In the frame's terms (see :meth:`Answer.mapped`)."""
        ref = _mapper(track_ids, det_rows)
        return Alternative(
            answer=self.answer.mapped(track_ids, det_rows),
            delta=self.delta,
            instead=tuple((n, tuple(map(ref, a))) for n, a in self.instead),
            rather=tuple((n, tuple(map(ref, a))) for n, a in self.rather),
            about=tuple((n, tuple(map(ref, a))) for n, a in self.about),
        )


@dataclass(frozen=True)
class Alternatives:
    """The chosen explanation of ``event`` and its next-best alternatives, cheapest first.

    ``chosen`` is None when no model was found within the budget; ``alternatives`` is empty when
    the chosen answer does not hold the event (then it is not this encoding's answer) or nothing
    else explains the subject.
    """

    event: tuple[str, tuple[Ref, ...]]
    chosen: Answer | None
    alternatives: list[Alternative]

    @property
    def holds(self) -> bool:
        """The chosen answer holds the event."""
        return self.chosen is not None and self.event in self.chosen.events

    def mapped(self, track_ids: list[int], det_rows: list[int]) -> Alternatives:
        """In the frame's terms (see :meth:`Answer.mapped`)."""
        ref = _mapper(track_ids, det_rows)
        name, args = self.event
        return Alternatives(
            (name, tuple(map(ref, args))),
            None if self.chosen is None else self.chosen.mapped(track_ids, det_rows),
            [a.mapped(track_ids, det_rows) for a in self.alternatives],
        )


#: the shown actions (tracking.lp's #show), each naming tracks and detections
_ACTIONS = frozenset({"assign", "resume", "start", "end", "halt", "ignore_trk", "ignore_det"})


def _symbol(x: Ref) -> Symbol:
    if isinstance(x, Det):
        return Function("d", [Number(x.row)])
    if isinstance(x, int):
        return Number(x)
    return Function(str(x))


def _names(atom: Symbol, subject: Symbol) -> bool:
    """The shown atom is about ``subject``: an event with it as first argument, or an action
    that names it."""
    if atom.name == "occurs" and len(atom.arguments) == 1:
        inner = atom.arguments[0].arguments
        return bool(inner) and inner[0] == subject
    return atom.name in _ACTIONS and subject in atom.arguments


def _atom(atom: Symbol) -> tuple[str, tuple[Ref, ...]]:
    """A shown event or action as ``(name, args)``."""
    if atom.name == "occurs":
        atom = atom.arguments[0]
    return atom.name, tuple(_ref(a) for a in atom.arguments)


def _delta(cost: int | None, base: int | None) -> int | None:
    return None if cost is None or base is None else cost - base


def _mapper(track_ids: list[int], det_rows: list[int]) -> Callable[[Ref], Ref]:
    """Local track ``i`` -> ``track_ids[i]``, ``Det(j)`` -> ``Det(det_rows[j])``; others as
    they are."""

    def ref(x: Ref) -> Ref:
        if isinstance(x, Det):
            return Det(det_rows[x.row])
        if isinstance(x, int) and 0 <= x < len(track_ids):
            return track_ids[x]
        return x

    return ref


def _local_refs(
    args: tuple[Ref, ...], track_ids: list[int], own: int, det_rows: list[int]
) -> tuple[Ref, ...] | None:
    """``args`` (track ids, :class:`Det` rows) in a component's local terms; None when they are
    not all in it. The first must be one of its ``own`` tracks or a detection; later ones (an
    occluder) may be an occluder outside it that ``track_ids`` names after its own tracks."""
    tracks = {t: i for i, t in enumerate(track_ids)}
    dets = {d: j for j, d in enumerate(det_rows)}

    def local(x: Ref) -> Ref | None:
        if isinstance(x, Det):
            return Det(dets[x.row]) if x.row in dets else None
        if isinstance(x, int):
            return tracks.get(x)
        return x

    first = local(args[0])
    if first is None or (isinstance(first, int) and first >= own):
        return None
    rest: list[Ref] = []
    for a in args[1:]:
        r = local(a)
        if r is None:
            return None
        rest.append(r)
    return (first, *rest)


def _ref(sym: Symbol) -> Ref:
    if sym.type == SymbolType.Number:
        return sym.number
    if sym.type == SymbolType.Function:
        if sym.name == "d" and len(sym.arguments) == 1:
            return Det(sym.arguments[0].number)
        if not sym.arguments:
            return sym.name
    if sym.type == SymbolType.String:
        return sym.string
    return str(sym)


def _decode(symbols: list[Symbol]) -> Answer:
    """The shown atoms as an :class:`Answer` (read through the symbols' names and arguments)."""
    ans = Answer()
    for sym in symbols:
        name, args = sym.name, sym.arguments
        if name == "occurs" and len(args) == 1:
            ans.events.append((args[0].name, tuple(_ref(a) for a in args[0].arguments)))
        elif name == "confidence" and len(args) == 2 and args[1].type == SymbolType.Number:
            event, level = args
            ans.confidence.append(
                (event.name, tuple(_ref(a) for a in event.arguments), level.number)
            )
        elif name == "value" and len(args) == 2:
            fluent, value = args
            ans.fluents.append(
                (fluent.name, tuple(_ref(a) for a in fluent.arguments), str(_ref(value)))
            )
        elif name in ("assign", "resume") and len(args) == 2:
            getattr(ans, name)[args[0].number] = args[1].arguments[0].number
        elif name in ("start", "ignore_det") and len(args) == 1:
            getattr(ans, name).append(args[0].arguments[0].number)
        elif name in ("end", "halt", "ignore_trk") and len(args) == 1:
            getattr(ans, name).append(args[0].number)
    return ans
