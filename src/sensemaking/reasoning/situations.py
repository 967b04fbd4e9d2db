"""Safety-critical situations (Table 3 of the paper) as ASP rules, and the warnings they raise.

The rules live in ``encodings/situations.lp`` (one ``#program`` part per situation, parameters as
``#const``); :class:`~sensemaking.reasoning.online.SituationMonitor` keeps a snapshot of the
last few frames, answers the four situations whose rule bodies it checks completely from it, and
calls :func:`solve_window` on a fresh clingo Control with the facts of the candidates of the
other two (or, with ``prefilter=False``, of everything, every frame).

=================== ================ =====================================================
situation           objects          holds when
=================== ================ =====================================================
OVERTAKING          vehicle, vehicle A was nearer than B a moment ago, is farther now, side by side
HIDDEN_ENTITY       entity, occluder a hidden road user may reappear in the ego corridor soon
REDUCED_VISIBILITY  object           an object in front takes much of the view, or hides others
SUDDEN_STOP         vehicle          a vehicle in front stops suddenly or looms
BLOCKED_LANE        object           an object stands still on a lane (needs lanes)
EXITING_VEHICLE     person, vehicle  a person appears touching a vehicle that stands still
=================== ================ =====================================================
"""

from __future__ import annotations

import logging
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from enum import Enum
from functools import lru_cache
from importlib import resources
from typing import Any

import clingo
from clingo import ast as clingo_ast

from sensemaking.reasoning.anticipation import AnticipationConfig
from sensemaking.reasoning.relations import MotionThresholds, RelationConfig

__all__ = ["Situation", "Warning", "SituationWarning", "SituationConfig", "SituationMatch", "situation_constants",
           "solve_window", "encoding_text", "ALL_SITUATIONS"]

log = logging.getLogger(__name__)


class Situation(str, Enum):
    """The situations of Table 3; ``value`` is the ASP name and the program part."""

    OVERTAKING = "overtaking"
    HIDDEN_ENTITY = "hidden_entity"
    REDUCED_VISIBILITY = "reduced_visibility"
    SUDDEN_STOP = "sudden_stop"
    BLOCKED_LANE = "blocked_lane"
    EXITING_VEHICLE = "exiting_vehicle"

    @classmethod
    def parse(cls, name: str) -> Situation:
        """From ``"HIDDEN_ENTITY"``, ``"hidden_entity"`` or ``"hidden-entity"``. Raises ValueError."""
        key = str(name).strip().lower().replace("-", "_")
        for s in cls:
            if s.value == key:
                return s
        raise ValueError(f"unknown situation {name!r} (one of {', '.join(s.name for s in cls)})")


#: every situation, by upper-case name
ALL_SITUATIONS: frozenset[str] = frozenset(s.name for s in Situation)


@dataclass(frozen=True)
class Warning:  # noqa: A001 - the name the API promises; SituationWarning is an alias
    """A safety-critical situation detected at ``frame``.

    Attributes:
        frame: the frame at which it was detected.
        situation: upper-case name (``"HIDDEN_ENTITY"``, ...).
        objects: the track ids involved, in the order of Table 3 (e.g. hidden entity, occluder);
            empty for a note that the situation was skipped.
        message: one readable sentence.
        details: JSON-able extras (anticipated frame and position, lane, cause; ``"skipped"``
            with the reason when the situation could not be checked).
    """

    frame: int
    situation: str
    objects: tuple[int, ...]
    message: str
    details: dict[str, Any] = field(default_factory=dict, hash=False, compare=False)

    def to_json(self) -> dict[str, Any]:
        """The JSON-lines record ``{"frame", "situation", "objects", "message", "details"}``."""
        return {"frame": int(self.frame), "situation": self.situation, "objects": [int(o) for o in self.objects],
                "message": self.message, "details": self.details}

    @classmethod
    def from_json(cls, record: Mapping[str, Any]) -> Warning:
        return cls(int(record["frame"]), str(record["situation"]), tuple(int(o) for o in record["objects"]),
                   str(record["message"]), dict(record.get("details") or {}))

    def __str__(self) -> str:
        return f"[{self.frame}] {self.situation}: {self.message}"


SituationWarning = Warning


@lru_cache(maxsize=None)
def encoding_text(name: str) -> str:
    """Text of an encoding shipped in ``sensemaking/reasoning/encodings`` (e.g. ``"situations.lp"``)."""
    return resources.files("sensemaking.reasoning").joinpath("encodings", name).read_text(encoding="utf-8")


#: situations whose rules use the rectangle relations of relations.lp
_USES_RELATIONS = frozenset({"overtaking", "exiting_vehicle"})


@lru_cache(maxsize=1)
def _parts() -> tuple[dict[str, list[Any]], dict[str, int]]:
    """Parsed statements by program part (``relations`` holds relations.lp) and the #const
    defaults. Comments and ``#defined`` directives are dropped (the latter only silence
    warnings, which are off)."""
    parts: dict[str, list[Any]] = {}
    consts: dict[str, int] = {}
    for name, first in (("relations.lp", "relations"), ("situations.lp", "base")):
        current = [first]

        def collect(stmt: Any) -> None:
            kind = stmt.ast_type
            if kind in (clingo_ast.ASTType.Defined, clingo_ast.ASTType.Comment):
                return
            if kind == clingo_ast.ASTType.Program:
                if first == "relations":
                    return  # relations.lp is grounded as part of base
                current[0] = stmt.name
            elif kind == clingo_ast.ASTType.Definition:
                consts[stmt.name] = int(stmt.value.symbol.number)
            parts.setdefault(current[0], []).append(stmt)

        clingo_ast.parse_string(encoding_text(name), collect)
    return parts, consts


class _Substitute(clingo_ast.Transformer):
    """Replaces constants by their values (what ``#const`` does at parse time)."""

    def __init__(self, values: Mapping[str, int]):
        self.values = values

    def visit_SymbolicTerm(self, node: Any) -> Any:  # noqa: N802 - clingo's visitor naming
        sym = node.symbol
        if sym.type == clingo.SymbolType.Function and not sym.arguments and sym.name in self.values:
            return clingo_ast.SymbolicTerm(node.location, clingo.Number(self.values[sym.name]))
        return node


@lru_cache(maxsize=8)
def _program(constants: tuple[tuple[str, int], ...]) -> dict[str, list[Any]]:
    """The statements by part with the #const values substituted (and the definitions dropped):
    fewer statements to add and ground on every Control."""
    parts, _ = _parts()
    sub = _Substitute(dict(constants))
    return {name: [sub(s) for s in stmts if s.ast_type != clingo_ast.ASTType.Definition]
            for name, stmts in parts.items()}


def situation_constants(overrides: Mapping[str, int] | None = None) -> dict[str, int]:
    """The ``#const`` parameters of situations.lp with ``overrides`` applied. Raises ValueError
    for unknown names or non-integer values."""
    consts = dict(_parts()[1])
    for k, v in (overrides or {}).items():
        if k not in consts:
            raise ValueError(f"unknown situation parameter {k!r} (one of {', '.join(sorted(consts))})")
        if isinstance(v, bool) or int(v) != v:
            raise ValueError(f"situation parameter {k} must be an integer, got {v!r}")
        consts[k] = int(v)
    return consts


@dataclass(frozen=True)
class SituationConfig:
    """Parameters of online situation detection.

    Attributes:
        situations: upper-case names of the situations to detect (default: all six).
        constants: overrides of the ``#const`` parameters of situations.lp (integers; see
            :func:`situation_constants` for names and defaults).
        window_s: seconds of recent frames given to the solver; extended as needed to cover
            the duration parameters (``*_ms``).
        rearm_s: a warning is issued when its situation starts; it is issued again only after
            the situation has not held for this long (seconds).
        prefilter: True: the monitor answers OVERTAKING, HIDDEN_ENTITY, REDUCED_VISIBILITY and
            SUDDEN_STOP from its snapshot (it checks every condition of their rules) and grounds
            BLOCKED_LANE and EXITING_VEHICLE only for the objects whose trigger facts are present.
            False: every situation is grounded every frame with every fact of the window (the
            reference; the same results, many times slower).
        motion, relations, anticipation: see their classes.
    """

    situations: frozenset[str] = ALL_SITUATIONS
    constants: Mapping[str, int] = field(default_factory=dict)
    window_s: float = 1.0
    rearm_s: float = 1.0
    prefilter: bool = True
    motion: MotionThresholds = field(default_factory=MotionThresholds)
    relations: RelationConfig = field(default_factory=RelationConfig)
    anticipation: AnticipationConfig = field(default_factory=AnticipationConfig)

    def __post_init__(self) -> None:
        names = frozenset(Situation.parse(s).name for s in self.situations)
        object.__setattr__(self, "situations", names)
        object.__setattr__(self, "constants", dict(self.constants))
        situation_constants(self.constants)  # validates
        if self.window_s <= 0 or self.rearm_s < 0:
            raise ValueError("window_s must be positive and rearm_s >= 0")

    def window_frames(self, fps: float) -> int:
        """Frames in the window at ``fps``: ``window_s`` or the longest ``*_ms`` parameter, + 1."""
        consts = situation_constants(self.constants)
        longest = max([self.window_s * 1000.0] + [v for k, v in consts.items() if k.endswith("_ms") and k != "he_lead_ms"])
        return int(-(-longest * fps // 1000)) + 1


@dataclass(frozen=True)
class SituationMatch:
    """One ``warn/2`` answer of the solver with its ``info/4`` details."""

    situation: Situation
    objects: tuple[int, ...]
    info: dict[str, list[Any]]


def _value(sym: clingo.Symbol) -> Any:
    if sym.type == clingo.SymbolType.Number:
        return sym.number
    if sym.type == clingo.SymbolType.String:
        return sym.string
    return str(sym)


class _Names(clingo_ast.Transformer):
    """Collects the predicate names of the symbolic atoms under a node."""

    def __init__(self) -> None:
        self.names: set[str] = set()

    def visit_SymbolicAtom(self, node: Any) -> Any:  # noqa: N802 - clingo's visitor naming
        self.names.update(_atom_names(node))
        return node


def _atom_names(node: Any) -> set[str]:
    """Predicate names of a SymbolicAtom (several for a pool ``p(a;b)``, none if unknown)."""
    term = node.symbol
    if term.ast_type == clingo_ast.ASTType.Function:
        return {term.name}
    if term.ast_type == clingo_ast.ASTType.SymbolicTerm and term.symbol.type == clingo.SymbolType.Function:
        return {term.symbol.name}
    if term.ast_type == clingo_ast.ASTType.Pool:
        return {a.name for a in term.arguments if a.ast_type == clingo_ast.ASTType.Function}
    return set()


@dataclass(frozen=True)
class _Stmt:
    """One statement of a program part with the predicate names it defines and uses.

    ``heads`` is None for statements that are kept whatever the facts (directives, and rules
    that are not plain ``atom :- body``)."""

    text: str
    heads: frozenset[str] | None
    required: frozenset[str]  # positive body literals: the rule has no instance without them
    uses: frozenset[str]  # every predicate in the body
    negated: frozenset[str]  # predicates under default negation in the body
    strict: frozenset[str] = frozenset()  # ... and those inside aggregates and conditions


def _stmt(stmt: Any) -> _Stmt:
    text = str(stmt)
    if stmt.ast_type != clingo_ast.ASTType.Rule or stmt.head.ast_type != clingo_ast.ASTType.Literal \
            or stmt.head.atom.ast_type != clingo_ast.ASTType.SymbolicAtom or stmt.head.sign:
        return _Stmt(text, None, frozenset(), frozenset(), frozenset())
    heads = _atom_names(stmt.head.atom)
    required, negated, strict = set(), set(), set()
    uses = _Names()
    for lit in stmt.body:
        uses(lit)
        if lit.ast_type == clingo_ast.ASTType.Literal and lit.atom.ast_type == clingo_ast.ASTType.SymbolicAtom:
            (negated if lit.sign else required).update(_atom_names(lit.atom))
        else:
            sub = _Names()
            sub(lit)
            strict.update(sub.names)
            if "not " in str(lit):
                negated.update(sub.names)  # negation inside an aggregate or condition
    if not heads:
        return _Stmt(text, None, frozenset(), frozenset(), frozenset())
    return _Stmt(text, frozenset(heads), frozenset(required), frozenset(uses.names), frozenset(negated),
                 frozenset(negated | strict))


@lru_cache(maxsize=64)
def _statements(constants: tuple[tuple[str, int], ...], names: tuple[str, ...]) -> tuple[_Stmt, ...]:
    """Base plus the parts ``names`` (and relations.lp when they use it), constants substituted."""
    parts = _program(constants)
    stmts = [stmt for name in ("base",) + names for stmt in parts.get(name, [])]
    if _USES_RELATIONS.intersection(names):
        stmts += parts["relations"]
    return tuple(_stmt(stmt) for stmt in stmts if stmt.ast_type != clingo_ast.ASTType.Program)


def _stratified(stmts: Iterable[_Stmt]) -> bool:
    """True when ``stmts`` are plain rules ``atom :- body`` (and #show) without a cycle through
    negation or an aggregate in their predicate dependencies: a stratified normal program, with
    exactly one answer set, which grounding computes (every derived atom a fact)."""
    edges: dict[str, dict[str, bool]] = {}  # head -> {body predicate: through negation/aggregate}
    for s in stmts:
        if s.heads is None:
            if s.text.startswith("#show"):
                continue
            return False
        strict = s.strict
        for h in s.heads:
            out = edges.setdefault(h, {})
            for p in s.uses:
                out[p] = out.get(p, False) or p in strict

    def reaches(a: str, b: str) -> bool:
        seen, todo = {a}, [a]
        while todo:
            for q in edges.get(todo.pop(), {}):
                if q == b:
                    return True
                if q not in seen:
                    seen.add(q)
                    todo.append(q)
        return False

    return not any(strict and (p == h or reaches(p, h)) for h, out in edges.items() for p, strict in out.items())


def _program_text(constants: tuple[tuple[str, int], ...], names: tuple[str, ...],
                  present: frozenset[str] | None = None) -> str:
    """The program text of :func:`_pruned`."""
    return _pruned(constants, names, present)[0]


@lru_cache(maxsize=256)
def _pruned(constants: tuple[tuple[str, int], ...], names: tuple[str, ...],
            present: frozenset[str] | None = None) -> tuple[str, frozenset[str] | None, bool]:
    """Base plus the parts ``names`` (and relations.lp when they use it) as one program text for
    ``#program base``, the constants substituted: clingo parses it in one call, cheaper than
    adding the statements one by one (grounding base and the parts together is the same).

    With ``present``, the names of the predicates the facts may contain, rules that cannot
    matter are left out, so that clingo grounds less; the answer on warn/2 and info/4 is the
    same: (1) a rule with a positive body literal whose predicate has no atoms (not among the
    facts, no rule left for it) has no ground instance; (2) rules whose heads warn/2 and info/4
    do not depend on form a top part of the program that the rest does not use -- dropped only
    when that part is stratified by construction (negation only of predicates without rule
    bodies, no constraints or other statements), so it extends every answer set of the rest.
    Also returns the predicate names the program left uses (None if nothing was left out):
    facts of other predicates change no answer either; and whether it is stratified
    (:func:`_stratified`), for :func:`answer_of_grounded`."""
    stmts = _statements(constants, names)
    if present is not None and all(s.heads is not None or s.text.startswith("#show") for s in stmts):
        avail = set(present)
        while True:  # (1) rules that can have instances, to a fixpoint
            live = [s for s in stmts if s.heads is None or s.required <= avail]
            grown = set(present).union(*(s.heads for s in live if s.heads is not None))
            if grown == avail:
                break
            avail = grown
        needed = {"warn", "info"}
        while True:  # (2) rules warn/info depend on
            keep = [s for s in live if s.heads is None or s.heads & needed]
            grown = needed.union(*(s.uses for s in keep))
            if grown == needed:
                break
            needed = grown
        with_body = set().union(*(s.heads for s in live if s.heads is not None and s.uses))
        if all(not (s.negated & with_body) for s in live if s not in keep):
            stmts = tuple(keep)
        else:
            stmts = tuple(live)
        used = frozenset({"warn", "info"}.union(*(s.uses | s.heads for s in stmts if s.heads is not None)))
        return "".join(f"{s.text}\n" for s in stmts), used, _stratified(stmts)
    return "".join(f"{s.text}\n" for s in stmts), None, _stratified(stmts)


#: one fact on a line, its predicate name (no "." inside, so not several facts)
_FACT_LINE = re.compile(r"([a-z_][A-Za-z0-9_']*)\([^.]*\)\.")


def _fact_names(facts: str) -> frozenset[str] | None:
    """Names of the predicates of ``facts`` (over-approximated by every lower-case identifier in
    it), or None when the text is not made of facts only."""
    if ":-" in facts or "#" in facts or "{" in facts or ";" in facts or "%" in facts:
        return None
    return frozenset(re.findall(r"(?<![A-Za-z0-9_'\"])[a-z_][A-Za-z0-9_']*", facts))


def answer_of_grounded(ctl: clingo.Control, signatures: Iterable[tuple[str, int]],
                       stratified: bool = False) -> list[clingo.Symbol]:
    """The atoms of ``signatures`` (name, arity) in the first answer set of a grounded Control;
    empty when there is none. When grounding decided the answer, the solver is not run (it costs
    about as much as grounding): when every atom left is a fact and grounding found no conflict,
    the facts are the one answer set; for a program known to be stratified (``stratified``, see
    :func:`_stratified`: such as situations.lp), whose one answer set grounding computes, it
    suffices that the atoms of ``signatures`` are facts. Otherwise the solver is run."""
    signatures = list(signatures)
    if stratified:
        atoms = [a for sig in signatures for a in ctl.symbolic_atoms.by_signature(*sig)]
        if all(a.is_fact for a in atoms):
            return [a.symbol for a in atoms]
    elif not ctl.is_conflicting and all(a.is_fact for a in ctl.symbolic_atoms):
        return [a.symbol for sig in signatures for a in ctl.symbolic_atoms.by_signature(*sig)]
    wanted = set(signatures)
    found: list[clingo.Symbol] = []

    def on_model(model: clingo.Model) -> None:
        found[:] = [s for s in model.symbols(atoms=True) if (s.name, len(s.arguments)) in wanted]

    ctl.solve(on_model=on_model)
    return found


def solve_window(facts: str, situations: Iterable[Situation | str],
                 constants: Mapping[str, int] | None = None) -> list[SituationMatch]:
    """Ground base plus the parts of ``situations`` with ``facts`` on a fresh Control and return
    the detections, sorted. ``constants`` override #const parameters (same effect as clingo's
    ``-c name=value``; the values are substituted into the cached program)."""
    parts_wanted = [Situation.parse(s.value if isinstance(s, Situation) else s) for s in situations]
    if not parts_wanted:
        return []
    consts = tuple(sorted(situation_constants(constants).items()))
    ctl = clingo.Control(["--warn=none"])
    program, used, stratified = _pruned(consts, tuple(s.value for s in parts_wanted), _fact_names(facts))
    if used is not None:  # drop the lines holding one fact of a predicate the program does not use
        facts = "".join(f"{line}\n" for line in facts.splitlines()
                        if (m := _FACT_LINE.fullmatch(line)) is None or m.group(1) in used)
    ctl.add("base", [], program + facts)
    ctl.ground([("base", [])])
    warns: dict[tuple[Situation, tuple[int, ...]], dict[str, list[Any]]] = {}
    infos: list[clingo.Symbol] = []
    for sym in answer_of_grounded(ctl, (("warn", 2), ("info", 4)), stratified):
        if sym.name == "warn":
            warns[(Situation(sym.arguments[0].name), tuple(a.number for a in sym.arguments[1].arguments))] = {}
        else:
            infos.append(sym)
    for sym in infos:
        key = (Situation(sym.arguments[0].name), tuple(a.number for a in sym.arguments[1].arguments))
        if key in warns:
            warns[key].setdefault(sym.arguments[2].name, []).append(_value(sym.arguments[3]))
    out = [SituationMatch(s, objs, {k: sorted(v, key=str) for k, v in info.items()}) for (s, objs), info in warns.items()]
    out.sort(key=lambda d: (list(Situation).index(d.situation), d.objects))
    return out
