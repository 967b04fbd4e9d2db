"""Safety-critical situations (Table 3 of the paper) as ASP rules, and the warnings they raise.

The rules live in ``encodings/situations.lp`` (one ``#program`` part per situation, parameters as
``#const``), and nowhere else: :class:`~sensemaking.reasoning.online.SituationMonitor` turns
the last few frames into facts and :class:`SituationSolver` asks clingo, every frame, for the
``warn/2`` and ``info/4`` atoms. Users add situations with their own encodings
(``extra_encodings``).

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
from collections import OrderedDict
from collections.abc import Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from enum import Enum
from functools import cache, lru_cache
from importlib import resources
from os import PathLike
from pathlib import Path
from typing import Any

import clingo
from clingo import ast as clingo_ast

from sensemaking import asp
from sensemaking.errors import InputError, ProgramError
from sensemaking.reasoning.anticipation import AnticipationConfig
from sensemaking.reasoning.facts import AspString, Fact, fact_symbol, symbol
from sensemaking.reasoning.relations import MotionThresholds, RelationConfig
from sensemaking.records import warning_fields, warning_record
from sensemaking.sandbox import Limits

__all__ = [
    "Situation",
    "SituationWarning",
    "SituationConfig",
    "SituationMatch",
    "SituationSolver",
    "situation_constants",
    "encoding_text",
    "ALL_SITUATIONS",
]

log = logging.getLogger(__name__)


class Situation(str, Enum):  # noqa: UP042 (StrEnum would change str() and format())
    """The situations of Table 3; ``value`` is the ASP name and the program part."""

    OVERTAKING = "overtaking"
    HIDDEN_ENTITY = "hidden_entity"
    REDUCED_VISIBILITY = "reduced_visibility"
    SUDDEN_STOP = "sudden_stop"
    BLOCKED_LANE = "blocked_lane"
    EXITING_VEHICLE = "exiting_vehicle"

    @classmethod
    def parse(cls, name: str) -> Situation:
        """From ``"HIDDEN_ENTITY"``, ``"hidden_entity"`` or ``"hidden-entity"``. Raises
        ValueError."""
        key = str(name).strip().lower().replace("-", "_")
        for s in cls:
            if s.value == key:
                return s
        raise ValueError(f"unknown situation {name!r} (one of {', '.join(s.name for s in cls)})")


#: every situation, by upper-case name
ALL_SITUATIONS: frozenset[str] = frozenset(s.name for s in Situation)


@dataclass(frozen=True)
class SituationWarning:
    """A safety-critical situation detected at ``frame``.

    Attributes:
        frame: the frame at which it was detected.
        situation: upper-case name (``"HIDDEN_ENTITY"``, ...; a situation of a user's encoding:
            its ASP name upper-cased).
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
        """The warning's record (:func:`sensemaking.records.warning_record`)."""
        return warning_record(self)

    @classmethod
    def from_json(cls, record: Mapping[str, Any]) -> SituationWarning:
        return cls(*warning_fields(record))

    def __str__(self) -> str:
        return f"[{self.frame}] {self.situation}: {self.message}"


@cache
def encoding_text(name: str) -> str:
    """Text of an encoding shipped in ``sensemaking/reasoning/encodings`` (e.g.
    ``"situations.lp"``)."""
    return (
        resources.files("sensemaking.reasoning")
        .joinpath("encodings", name)
        .read_text(encoding="utf-8")
    )


@lru_cache(maxsize=1)
def _shipped() -> tuple[tuple[Any, ...], dict[str, int]]:
    """The parsed statements of relations.lp and situations.lp (relations.lp in ``base``) and
    the ``#const`` defaults of situations.lp."""
    stmts: list[Any] = []
    consts: dict[str, int] = {}

    def collect(stmt: Any) -> None:
        if stmt.ast_type == clingo_ast.ASTType.Definition:
            consts[stmt.name] = int(stmt.value.symbol.number)
        stmts.append(stmt)

    text = encoding_text("relations.lp") + "\n#program base.\n" + encoding_text("situations.lp")
    clingo_ast.parse_string(text, collect)
    return tuple(stmts), consts


def _parse_user_encoding(path: str | PathLike[str]) -> tuple[Any, ...]:
    """The statements of a user's encoding file. Raises InputError naming the file and line."""
    messages: list[str] = []
    stmts: list[Any] = []
    if not Path(path).is_file():
        raise InputError("no such situation encoding file", path)
    from sensemaking.sandbox import check_program, read_program_file

    try:  # no #include / #script anywhere (clingo's parser would open the file): issue 24
        check_program(read_program_file(path), str(path))
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the situation encoding: {exc}", path) from None
    try:
        # a user's rules go to base unless the file opens its own parts
        clingo_ast.parse_string("#program base.", stmts.append)
        clingo_ast.parse_files(
            [str(path)], stmts.append, logger=lambda _code, msg: messages.append(msg)
        )
    except RuntimeError as exc:
        raise InputError(_first_line(messages, exc)) from None
    return tuple(stmts)


def _first_line(messages: list[str], exc: Exception) -> str:
    """clingo's first message (``file:line:col: error: ...``) on one line."""
    text = messages[0] if messages else str(exc)
    return " ".join(text.split())


def situation_constants(overrides: Mapping[str, int] | None = None) -> dict[str, int]:
    """The ``#const`` parameters of situations.lp with ``overrides`` applied. Raises ValueError
    for unknown names or non-integer values."""
    consts = dict(_shipped()[1])
    for k, v in (overrides or {}).items():
        if k not in consts:
            raise ValueError(
                f"unknown situation parameter {k!r} (one of {', '.join(sorted(consts))})"
            )
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
        window_s: seconds of recent frames given to clingo as facts; extended as needed to
            cover the duration parameters (``*_ms``).
        rearm_s: a warning is issued when its situation starts; it is issued again only after
            the situation has not held for this long (seconds).
        motion, relations, anticipation: see their classes.
    """

    situations: frozenset[str] = ALL_SITUATIONS
    constants: Mapping[str, int] = field(default_factory=dict)
    window_s: float = 1.0
    rearm_s: float = 1.0
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
        longest = max(
            [self.window_s * 1000.0]
            # the two look ahead, not back
            + [
                v
                for k, v in consts.items()
                if k.endswith("_ms") and k not in ("he_lead_ms", "he_path_ms")
            ]
        )
        return int(-(-longest * fps // 1000)) + 1


@dataclass(frozen=True)
class SituationMatch:
    """One ``warn/2`` answer with its ``info/4`` details; ``situation`` is the upper-case name."""

    situation: str
    objects: tuple[int, ...]
    info: dict[str, list[Any]]


#: program parts of the built-in situations
_ALL_PARTS: tuple[str, ...] = tuple(s.value for s in Situation)
#: fact symbols a SituationSolver keeps (about 100 bytes each) before it starts afresh
_SYMBOLS_KEPT = 100_000


#: a frame the user's situations rule out: an error, not a frame without warnings
_UNSATISFIABLE = (
    "the situations have no answer set for a frame's facts (UNSATISFIABLE): a constraint of "
    "your situations rules out every answer"
)


class SituationSolver:
    """situations.lp (with relations.lp and the user's encodings) solved by clingo for the facts
    of one frame, with a cache of clingo's own answers.

    Args:
        parts: the program parts (situations, by ASP name) to ground besides ``base``.
        constants: overrides of the ``#const`` parameters (clingo's ``-c name=value``).
        extra_encodings: paths of ASP files added to the program (their rules go to ``base``
            unless they open their own ``#program`` part: add a new situation with a rule for
            ``warn/2``, and its details with ``info/4``).
        cache_size: answers kept, by their facts (least recently used dropped first).
        limits: time, memory and atom limits of ``extra_encodings``, checked once (default:
            ``ask``'s; :func:`sensemaking.sandbox.probe_program`).

    :meth:`answer` takes the facts of a frame as tuples (see :mod:`~sensemaking.reasoning.facts`)
    and returns the ``warn/2`` and ``info/4`` atoms of the first answer set (none when there is
    no answer set). The answer is a function of the program and the facts alone: clingo is
    deterministic for the same program and the same facts in the same order, so a cached answer
    for an equal fact tuple is the answer clingo would give (the cache is forced, whatever the
    encoding). ``calls`` counts clingo calls, ``hits`` answers from the cache.
    """

    def __init__(
        self,
        parts: Sequence[str] = _ALL_PARTS,
        constants: Mapping[str, int] | None = None,
        extra_encodings: Sequence[str | PathLike[str]] = (),
        cache_size: int = 256,
        limits: Limits | None = None,
    ):
        situation_constants(constants)  # validates
        self._args = ["--warn=none"] + [f"-c{k}={int(v)}" for k, v in (constants or {}).items()]
        self._extra = tuple(str(p) for p in extra_encodings)
        self._stmts = self._program()
        self._parts: list[tuple[str, list[clingo.Symbol]]] = [("base", [])]
        self._parts += [(p, []) for p in parts]
        self._cache: OrderedDict[tuple[Fact, ...], tuple[clingo.Symbol, ...]] = OrderedDict()
        self._cache_size = max(0, int(cache_size))
        # the symbol of each fact seen lately: facts recur from frame to frame (relative frames,
        # window indices), and making a clingo symbol costs more than grounding it
        self._symbols: dict[Fact, clingo.Symbol] = {}
        self.calls = self.hits = 0
        if self._extra:  # the user's code: grounded and solved once under ask's limits
            from sensemaking.sandbox import probe_program

            probe_program(
                self._build,
                self._args,
                where=", ".join(self._extra),
                parts=self._parts,
                limits=limits,
            )
        try:  # surface the user's grounding errors (unsafe variables, ...) now, as InputError
            ctl = asp.control(self._args, self._stmts)
            ctl.ground(self._parts)
            ctl.solve()
        except RuntimeError as exc:
            raise InputError(
                f"situation encodings: {' '.join(str(exc).split())}",
                extra_encodings[0] if len(extra_encodings) == 1 else None,
            ) from None
        self._severities = _severity_tables(ctl)  # read from the same grounding

    def severities(self) -> tuple[dict[str, int], dict[str, int]]:
        """The program's ``severity(S,N)`` and ``severity_on_ego_lane(S,N)`` facts, as
        ``({SITUATION: N}, {SITUATION: N})`` (names upper-case, as warnings name them)."""
        return self._severities

    def _build(self, ctl: clingo.Control) -> None:
        with clingo_ast.ProgramBuilder(ctl) as builder:
            for stmt in self._stmts:
                builder.add(stmt)

    def _program(self) -> tuple[Any, ...]:
        return _shipped()[0] + tuple(s for p in self._extra for s in _parse_user_encoding(p))

    def __getstate__(self) -> dict[str, Any]:
        # clingo's ASTs and symbols do not pickle: the program is parsed again (user files too)
        return {**self.__dict__, "_stmts": None, "_cache": OrderedDict(), "_symbols": {}}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._stmts = self._program()

    def answer(self, facts: tuple[Fact, ...]) -> tuple[clingo.Symbol, ...]:
        """The ``warn/2`` and ``info/4`` atoms clingo finds for ``facts``."""
        cached = self._cache.get(facts)
        if cached is not None:
            self._cache.move_to_end(facts)
            self.hits += 1
            return cached
        self.calls += 1
        atoms = self._solve(facts)
        if self._cache_size:
            self._cache[facts] = atoms
            if len(self._cache) > self._cache_size:
                self._cache.popitem(last=False)
        return atoms

    def _solve(self, facts: Iterable[Fact]) -> tuple[clingo.Symbol, ...]:
        ctl = asp.control(self._args, self._stmts)  # parsed once: cheaper than text per call
        memo = self._symbols
        asp.add_facts(ctl, [fact_symbol(f, memo, _SYMBOLS_KEPT) for f in facts])
        ctl.ground(self._parts)
        found: list[clingo.Symbol] = []

        def first(model: clingo.Model) -> bool:
            found.extend(
                s
                for s in model.symbols(shown=True)
                if (s.name, len(s.arguments)) in (("warn", 2), ("info", 4))
            )
            return False  # the first answer set is the answer

        if ctl.solve(on_model=first).unsatisfiable and self._extra:
            raise ProgramError(_UNSATISFIABLE, ", ".join(self._extra))
        return tuple(found)


def _severity_tables(ctl: clingo.Control) -> tuple[dict[str, int], dict[str, int]]:
    """The ``severity/2`` and ``severity_on_ego_lane/2`` facts of a ground ``ctl``."""
    tables: tuple[dict[str, int], dict[str, int]] = ({}, {})
    for table, name in zip(tables, ("severity", "severity_on_ego_lane"), strict=True):
        for atom in ctl.symbolic_atoms.by_signature(name, 2):
            s, n = atom.symbol.arguments
            if atom.is_fact and n.type == clingo.SymbolType.Number:
                table[str(s).upper()] = n.number
    return tables


# -- stream reasoning ---------------------------------------------------------------------------
#: input predicates of situations.lp that hold at one frame, and the index of that frame among
#: their arguments: their facts enter the stream solver with their frame and leave with it
FRAME_ARGUMENT: dict[tuple[str, int], int] = {
    ("state", 3): 1,
    ("hidden_by", 3): 2,
    ("in_corridor", 2): 1,
    ("area", 3): 1,
    ("motion", 3): 1,
    ("ra", 5): 2,
    ("front", 3): 2,
    ("on_lane", 3): 2,
    ("surface", 3): 1,
    ("ego_speed", 2): 0,
    ("position", 4): 1,
    ("position_sd", 3): 1,
    ("closing", 4): 1,
    ("world_speed", 4): 1,
    ("world_long", 3): 1,
    ("world_lat", 3): 1,
    ("occurs_at", 2): 1,
    ("confidence_at", 3): 1,
}
#: inputs fixed for the life of a monitor: base facts of the stream solver, so that the rules
#: they decide (the scene profile's ego_vehicle, image) are simplified once, at grounding
STATIC_INPUTS: frozenset[tuple[str, int]] = frozenset(
    {("profile", 1), ("camera", 0), ("frame_ms", 1)}
)
#: every input predicate of situations.lp
INPUTS: frozenset[tuple[str, int]] = (
    frozenset(FRAME_ARGUMENT)
    | STATIC_INPUTS
    | {
        ("now", 1),
        ("seq_start", 1),
        ("track", 2),
        ("vehicle", 1),
        ("person", 1),
        ("occurs_at", 2),
        ("anticipated", 5),
        ("anticipated_in_corridor", 3),
        ("hidden_motion", 5),
        ("lane", 1),
    }
)
_STEP = "sm_step"  # the external that guards the rules of one frame's answer
_NOW = ("now", 1)  # the current frame: given as now(N,n), the answer's own (_stream_program)
_DETAILS = "sm_details_"  # the parts grounded once a warning holds (see _details)
_ATOM_TYPES = (clingo_ast.ASTType.SymbolicAtom,)


def _signature(atom: Any) -> tuple[str, int] | None:
    """(name, arity) of a symbolic atom's term (a pool's, when all its terms agree), None for
    anything else."""
    term = atom.symbol
    if term.ast_type == clingo_ast.ASTType.Pool:
        sigs = {_signature(clingo_ast.SymbolicAtom(t)) for t in term.arguments}
        return sigs.pop() if len(sigs) == 1 else None
    if term.ast_type == clingo_ast.ASTType.Function and not term.external:
        return term.name, len(term.arguments)
    if term.ast_type == clingo_ast.ASTType.SymbolicTerm:
        sym = term.symbol
        if sym.type == clingo.SymbolType.Function:
            return sym.name, len(sym.arguments)
    return None


def _atoms(node: Any) -> list[Any]:
    """Every symbolic atom inside ``node`` (literals, aggregates, conditions)."""
    found: list[Any] = []

    class Visit(clingo_ast.Transformer):
        def visit_SymbolicAtom(self, atom: Any) -> Any:  # noqa: N802 (clingo's visitor name)
            found.append(atom)
            return atom

    visit = Visit()
    for n in node if isinstance(node, clingo_ast.ASTSequence) else (node,):
        visit(n)
    return found


def _plain_body(rule: Any) -> list[Any] | None:
    """The body's literals that are atoms (sign kept), or None when the body has aggregates,
    conditions or anything but atoms and comparisons."""
    out = []
    for lit in rule.body:
        if lit.ast_type != clingo_ast.ASTType.Literal:
            return None
        if lit.atom.ast_type == clingo_ast.ASTType.SymbolicAtom:
            out.append(lit.atom)
        elif lit.atom.ast_type not in (
            clingo_ast.ASTType.Comparison,
            clingo_ast.ASTType.BooleanConstant,
        ):
            return None
    return out


def _frame_variable(atom: Any, position: int) -> str | None:
    term = atom.symbol
    if term.ast_type != clingo_ast.ASTType.Function or position >= len(term.arguments):
        return None
    arg = term.arguments[position]
    return arg.name if arg.ast_type == clingo_ast.ASTType.Variable else None


class _Layers:
    """The rules of a window program split for the stream solver.

    * static: rules over static predicates only (program facts, the inputs fixed for a
      monitor): grounded once, in ``base``;
    * frame: rules whose atoms all hold at one frame, the same variable F in every atom's frame
      argument (a rectangle relation's converse, "moving at F"): grounded once per frame, in
      ``frame(f)`` with F bound to f;
    * now: the rest (they join frames of the window, or read the current frame): grounded once
      per answered frame in ``now(n)``; the predicates they define get ``n`` as one more
      argument (an atom is defined in one grounding step only) and each rule the guard
      ``sm_step(n)``, an external released once the frame is answered.
    """

    def __init__(self, stmts: Sequence[Any], inputs: Mapping[tuple[str, int], int]) -> None:
        rules = [s for s in stmts if s.ast_type == clingo_ast.ASTType.Rule]
        heads: dict[tuple[str, int], list[Any]] = {}
        for r in rules:
            for a in _atoms(r.head):
                sig = _signature(a)
                if sig is not None:
                    heads.setdefault(sig, []).append(r)
        self.derived = set(heads)
        # static: every rule of the predicate has only static atoms
        static: set[tuple[str, int]] = set(STATIC_INPUTS)
        changed = True
        while changed:
            changed = False
            for sig, rs in heads.items():
                if sig in static or sig in inputs:
                    continue
                if all(
                    all(_signature(a) in static for a in _atoms(r.body) if _signature(a) != sig)
                    for r in rs
                ):
                    static.add(sig)
                    changed = True
        self.static = static
        # frame-local: position of the frame argument of each predicate
        pos: dict[tuple[str, int], int] = {k: v for k, v in inputs.items()}
        local: set[tuple[str, int]] = set()
        changed = True
        while changed:
            changed = False
            for sig, rs in heads.items():
                if sig in local or sig in static:
                    continue
                p = self._frame_position(sig, rs, pos, static)
                if p is not None:
                    pos[sig] = p
                    local.add(sig)
                    changed = True
        self.position = pos
        self.frame_preds = local
        self.now_preds = self.derived - static - local

    @staticmethod
    def _frame_position(
        sig: tuple[str, int],
        rules: list[Any],
        pos: Mapping[tuple[str, int], int],
        static: set[tuple[str, int]],
    ) -> int | None:
        """The frame argument of ``sig`` when every rule defining it is frame-local, else None."""
        found: set[int] = set()
        for r in rules:
            body = _plain_body(r)
            head = _atoms(r.head)
            if body is None or len(head) != 1 or r.head.ast_type != clingo_ast.ASTType.Literal:
                return None
            var: str | None = None
            for a in body:
                s = _signature(a)
                if s in static:
                    continue
                if s not in pos:
                    return None
                v = _frame_variable(a, pos[s])  # type: ignore[index]
                if v is None or var not in (None, v):
                    return None
                var = v
            if var is None:
                return None
            term = head[0].symbol
            if term.ast_type != clingo_ast.ASTType.Function:
                return None
            hits = [
                i
                for i, arg in enumerate(term.arguments)
                if arg.ast_type == clingo_ast.ASTType.Variable and arg.name == var
            ]
            if len(hits) != 1:
                return None
            found.add(hits[0])
        return found.pop() if len(found) == 1 else None

    def kind(self, rule: Any) -> str:
        """``static``, ``frame`` or ``now``: where a rule is grounded."""
        sigs = {_signature(a) for a in _atoms(rule.head)}
        sigs.discard(None)
        if not sigs:  # an integrity constraint: about the current frame
            return "now"
        if sigs <= self.static:
            return "static"
        if sigs <= self.frame_preds:
            return "frame"
        return "now"


def _used(stmts: list[Any]) -> list[Any]:
    """``stmts`` without the rules of predicates that no answer depends on: the answer is
    ``warn/2``, ``info/4`` and what is shown; integrity constraints count too."""
    rules = [s for s in stmts if s.ast_type == clingo_ast.ASTType.Rule]
    heads = [{_signature(a) for a in _atoms(r.head)} - {None} for r in rules]
    needed: set[Any] = {("warn", 2), ("info", 4)}
    needed |= {(s.name, s.arity) for s in stmts if s.ast_type == clingo_ast.ASTType.ShowSignature}
    if any(s.ast_type == clingo_ast.ASTType.ShowTerm for s in stmts):
        return stmts  # a #show term may name anything
    changed = True
    while changed:
        changed = False
        for r, hs in zip(rules, heads, strict=True):
            if hs and not hs & needed:
                continue
            body = {_signature(a) for a in _atoms(r.body)} | {
                _signature(a) for a in _atoms(r.head)
            }
            new = body - needed - {None}
            if new:
                needed |= new
                changed = True
    drop = {id(r) for r, hs in zip(rules, heads, strict=True) if hs and not hs & needed}
    return [s for s in stmts if id(s) not in drop]


def _first(atom: Any, consts: Collection[str]) -> str | None:
    """The first argument of a symbolic atom when it is a constant (``warn(overtaking,...)``),
    else None (also for a ``#const`` name, ``consts``: its value is not known here)."""
    term = atom.symbol
    if term.ast_type != clingo_ast.ASTType.Function or not term.arguments:
        return None
    arg = term.arguments[0]
    if arg.ast_type == clingo_ast.ASTType.SymbolicTerm:
        sym = arg.symbol
        named = sym.type == clingo.SymbolType.Function and not sym.arguments
        return None if named and sym.name in consts else str(sym)
    if arg.ast_type == clingo_ast.ASTType.Function and not arg.arguments and not arg.external:
        return None if arg.name in consts else str(arg.name)
    return None


def _dead(
    sig: Any, c: str | None, out: set[Any], defined: set[Any], firsts: Mapping[Any, set[Any]]
) -> bool:
    """Whether a positive body atom (signature, constant first argument or None) can never
    hold: its predicate is ``out``, or the rules left for it (``firsts``: the first arguments of
    their heads, None for any) never give that constant."""
    if sig in out:
        return True
    if c is None or sig not in defined:
        return False
    return None not in firsts[sig] and c not in firsts[sig]


def _pruned(stmts: list[Any], empty: Collection[tuple[str, int]]) -> list[Any]:
    """``stmts`` without the rules that can never fire: a positive body literal of a predicate
    in ``empty`` (certain to have no atom for this monitor), and then of a predicate whose every
    rule was so dropped, or whose rules left define it for other constants in its first
    argument only (``warn(hidden_entity,...)`` when no rule for that situation is left); never
    of an input the caller may give (:data:`INPUTS`) nor of an ``#external``."""
    rules = [s for s in stmts if s.ast_type == clingo_ast.ASTType.Rule]
    consts = {s.name for s in stmts if s.ast_type == clingo_ast.ASTType.Definition}
    consts.add("sm_window")
    heads = [[(_signature(a), _first(a, consts)) for a in _atoms(r.head)] for r in rules]
    declared = {
        _signature(a)
        for s in stmts
        if s.ast_type == clingo_ast.ASTType.External
        for a in _atoms(s.atom)
    }
    positive = [
        {
            (_signature(lit.atom), _first(lit.atom, consts))
            for lit in r.body
            if lit.ast_type == clingo_ast.ASTType.Literal
            and lit.sign == clingo_ast.Sign.NoSign
            and lit.atom.ast_type == clingo_ast.ASTType.SymbolicAtom
        }
        for r in rules
    ]
    gone: set[Any] = set(empty) - declared
    # what the caller may give as facts is never emptied by dropped rules
    defined = {sig for hs in heads for sig, _ in hs} - INPUTS - declared - {None}
    alive = [True] * len(rules)
    while True:
        firsts: dict[Any, set[str | None]] = {}
        for hs, a in zip(heads, alive, strict=True):
            for sig, c in hs if a else ():
                firsts.setdefault(sig, set()).add(c)
        out = gone | (defined - firsts.keys())
        now = [
            a and not any(_dead(sig, c, out, defined, firsts) for sig, c in pos)
            for a, pos in zip(alive, positive, strict=True)
        ]
        if now == alive:
            break
        alive = now
    drop = {id(r) for r, a in zip(rules, alive, strict=True) if not a}
    return [s for s in stmts if id(s) not in drop]


def _heads(stmts: Sequence[Any]) -> set[tuple[str, int]]:
    """The predicates some rule of ``stmts`` defines (or an ``#external`` declares)."""
    out: set[Any] = set()
    for s in stmts:
        if s.ast_type == clingo_ast.ASTType.Rule:
            out |= {_signature(a) for a in _atoms(s.head)}
        elif s.ast_type == clingo_ast.ASTType.External:
            out |= {_signature(a) for a in _atoms(s.atom)}
    return out - {None}


def _in_window(literals: list[Any], position: Mapping[Any, int]) -> list[Any] | None:
    """Comparisons ``F > n - sm_window`` for the frame argument F of every atom of
    ``literals`` about one frame (``position``), anonymous ones named first: so that facts of
    frames that left the window are never joined. ``literals`` are changed in place where an
    anonymous variable is named. None when a frame argument cannot be bound so (it is not a
    variable, or an anonymous one of a negative literal)."""
    out: list[Any] = []
    for i, lit in enumerate(literals):
        if lit.ast_type != clingo_ast.ASTType.Literal:
            continue
        atom = lit.atom
        if atom.ast_type != clingo_ast.ASTType.SymbolicAtom:
            continue
        sig = _signature(atom)
        if sig not in position:
            continue
        term = atom.symbol
        if term.ast_type != clingo_ast.ASTType.Function:
            return None
        p = position[sig]
        arg = term.arguments[p]
        if arg.ast_type != clingo_ast.ASTType.Variable:
            return None
        if arg.name == "_":
            if lit.sign != clingo_ast.Sign.NoSign:
                return None
            _in_window.fresh += 1  # type: ignore[attr-defined]
            name = f"SmF{_in_window.fresh}"  # type: ignore[attr-defined]
            args = list(term.arguments)
            args[p] = arg.update(name=name)
            literals[i] = lit.update(atom=atom.update(symbol=term.update(arguments=args)))
        else:
            name = arg.name
        out.append(_window_literal(name))
    return out


_in_window.fresh = 0  # type: ignore[attr-defined]


@cache
def _window_template() -> Any:
    found: list[Any] = []
    clingo_ast.parse_string(
        "sm :- SmX > n - sm_window.",
        lambda st: found.append(st) if st.ast_type == clingo_ast.ASTType.Rule else None,
    )
    return found[0].body[0]


def _window_literal(var: str) -> Any:
    class Rename(clingo_ast.Transformer):
        def visit_Variable(self, v: Any) -> Any:  # noqa: N802
            return v.update(name=var) if v.name == "SmX" else v

    return Rename()(_window_template())


def _windowed(rule: Any, position: Mapping[Any, int]) -> Any | None:
    """``rule`` with its frames kept to the window (see :func:`_in_window`), or None."""
    body = list(rule.body)
    extra = _in_window(body, position)
    if extra is None:
        return None
    for i, lit in enumerate(body):
        if lit.ast_type == clingo_ast.ASTType.Literal and (
            lit.atom.ast_type == clingo_ast.ASTType.BodyAggregate
        ):
            elems = []
            for e in lit.atom.elements:
                cond = list(e.condition)
                more = _in_window(cond, position)
                if more is None:
                    return None
                elems.append(e.update(condition=cond + more))
            body[i] = lit.update(atom=lit.atom.update(elements=elems))
        elif lit.ast_type == clingo_ast.ASTType.ConditionalLiteral or (
            lit.ast_type == clingo_ast.ASTType.Literal
            and lit.atom.ast_type
            not in (
                clingo_ast.ASTType.SymbolicAtom,
                clingo_ast.ASTType.Comparison,
                clingo_ast.ASTType.BooleanConstant,
            )
        ):
            return None  # conditions and other aggregates: not rewritten
    unique = list({str(x): x for x in extra}.values())  # one comparison per variable
    return rule.update(body=body + unique)


def _stream_program(
    stmts: Sequence[Any],
    parts: Sequence[str],
    inputs: Mapping[tuple[str, int], int],
    empty: Collection[tuple[str, int]] = (),
) -> tuple[list[Any], _Layers, bool, list[tuple[str, frozenset[str | None]]]]:
    """The statements of ``base`` and the ``parts`` asked for, rewritten into the three parts
    of the stream solver: ``base``, ``frame(f)`` and ``now(n)`` (see :class:`_Layers`);
    without the rules that ``empty`` predicates keep from ever firing (:func:`_pruned`).
    Also: whether every now-rule keeps its frames to the window, and the details' parts cut
    out of ``now(n)`` with the situations that trigger each (:func:`_details`)."""
    keep: list[Any] = []
    part = "base"
    for s in stmts:
        if s.ast_type == clingo_ast.ASTType.Comment:
            continue
        if s.ast_type == clingo_ast.ASTType.Program:
            part = s.name
            continue
        if part == "base" or part in parts:
            keep.append(s)
    keep = _used(_pruned(_used(keep), empty) if empty else keep)
    layers = _Layers(keep, inputs)
    loc = clingo_ast.Location(
        clingo_ast.Position("<stream>", 1, 1), clingo_ast.Position("<stream>", 1, 1)
    )

    def const(name: str) -> Any:
        return clingo_ast.Function(loc, name, [], 0)

    now_preds = layers.now_preds
    # now/1 as now(N,n), a fact of the answer's own: a released external stays in clingo's
    # domain for the next ground call, where every rule would join the frame before too
    stepped = now_preds | ({_NOW} if _NOW not in layers.derived else set())

    class Tag(clingo_ast.Transformer):
        """Adds the answered frame ``n`` to every atom of a now-layer predicate."""

        def visit_SymbolicAtom(self, atom: Any) -> Any:  # noqa: N802
            sig = _signature(atom)
            if sig not in stepped:
                return atom
            term = atom.symbol
            args = list(term.arguments) if term.ast_type == clingo_ast.ASTType.Function else []
            return atom.update(symbol=clingo_ast.Function(loc, sig[0], [*args, const("n")], 0))

    class Bind(clingo_ast.Transformer):
        def __init__(self, var: str) -> None:
            self.var = var

        def visit_Variable(self, v: Any) -> Any:  # noqa: N802
            return const("f") if v.name == self.var else v

    guard = clingo_ast.Literal(
        loc,
        clingo_ast.Sign.NoSign,
        clingo_ast.SymbolicAtom(clingo_ast.Function(loc, _STEP, [const("n")], 0)),
    )
    base: list[Any] = [clingo_ast.Program(loc, "base", [])]
    frame: list[Any] = [clingo_ast.Program(loc, "frame", [clingo_ast.Id(loc, "f")])]
    now: list[Any] = [
        clingo_ast.Program(loc, "now", [clingo_ast.Id(loc, "n")]),
        clingo_ast.External(
            loc, guard.atom, [], clingo_ast.SymbolicTerm(loc, clingo.Function("false"))
        ),
    ]
    # a now-layer predicate that is an input too (a user's rule adds vehicles): its facts
    # count in every answer
    for name, arity in sorted(now_preds & INPUTS):
        xs = ",".join(f"X{i}" for i in range(arity))
        clingo_ast.parse_string(
            f"{name}({xs}{',' if xs else ''}n) :- {name}{f'({xs})' if xs else ''}, {_STEP}(n).",
            lambda st: now.append(st) if st.ast_type == clingo_ast.ASTType.Rule else None,
        )
    windowed = True  # every now-rule keeps its frames to the window
    now_rules: list[tuple[Any, Any]] = []  # (the rule as written, as given to clingo)
    others: list[Any] = []  # the now statements that are not rules
    for s in keep:
        t = s.ast_type
        if t == clingo_ast.ASTType.Rule:
            k = layers.kind(s)
            if k == "static":
                base.append(s)
            elif k == "frame":
                head = _atoms(s.head)[0]
                sig = _signature(head)
                var = _frame_variable(head, layers.position[sig])  # type: ignore[index]
                frame.append(Bind(var or "")(s))
            else:
                w = _windowed(s, layers.position)
                if w is None:
                    windowed = False
                    w = s
                tagged = Tag()(w)
                now.append(tagged.update(body=[*tagged.body, guard]))
                now_rules.append((s, now[-1]))
        elif t in (clingo_ast.ASTType.ShowSignature, clingo_ast.ASTType.Defined):
            sig = (s.name, s.arity)
            if sig in now_preds:
                now.append(s.update(arity=s.arity + 1))
            elif t == clingo_ast.ASTType.Defined:
                base.append(s)
        elif t == clingo_ast.ASTType.Definition:
            base.append(s)
        else:  # #show terms, #external, #minimize ...: about the answered frame
            now.append(Tag()(s))
            others.append(s)
    consts = {s.name for s in keep if s.ast_type == clingo_ast.ASTType.Definition}
    groups = _details([r for r, _ in now_rules], consts | {"sm_window"}, now_preds, others)
    details: list[tuple[str, frozenset[str | None]]] = []
    if groups:
        later = {i for ix, _ in groups for i in ix}
        moved = {id(now_rules[i][1]) for i in later}
        now = [x for x in now if id(x) not in moved]
        for g, (ix, triggers) in enumerate(groups):
            name = f"{_DETAILS}{g}"
            now.append(clingo_ast.Program(loc, name, [clingo_ast.Id(loc, "n")]))
            now += [now_rules[i][1] for i in ix]
            details.append((name, triggers))
    return base + frame + now, layers, windowed, details


def _details(
    rules: Sequence[Any],
    consts: Collection[str],
    now_preds: Collection[Any],
    others: Sequence[Any],
) -> list[tuple[list[int], frozenset[str | None]]]:
    """The now-rules grounded in a second call, only when ``warn/2`` has an atom for the
    answered frame (:meth:`StreamSolver.answer`): the rules with a plain positive ``warn``
    literal (a warning's details and grades), and every rule that reads or defines what they
    define (so that a predicate is grounded in one call, after what it reads). In groups, by
    predicate and constant first argument: a rule index list and the situations whose warning
    triggers the group (``"*"``: any warning; None: always, a rule without a ``warn``
    literal). Empty when the split cannot be kept sound (``warn/2`` is not a now-predicate or
    is defined by such a rule; an input's copy or a statement other than a rule reads them)."""
    if ("warn", 2) not in now_preds:
        return []
    heads = [{(_signature(a), _first(a, consts)) for a in _atoms(r.head)} for r in rules]
    reads = [{(_signature(a), _first(a, consts)) for a in _atoms(r.body)} for r in rules]
    trigger: list[str | None] = []
    for r in rules:
        found: str | None = None
        for lit in r.body:
            if (
                lit.ast_type == clingo_ast.ASTType.Literal
                and lit.sign == clingo_ast.Sign.NoSign
                and lit.atom.ast_type == clingo_ast.ASTType.SymbolicAtom
                and _signature(lit.atom) == ("warn", 2)
            ):
                found = _first(lit.atom, consts) or "*"
        trigger.append(found)
    later = {i for i, t in enumerate(trigger) if t is not None}
    while True:  # what reads or also defines a predicate of a later rule is later too
        defined = {sig for i in later for sig, _ in heads[i]}
        more = {
            i
            for i in range(len(rules))
            if i not in later and {sig for sig, _ in heads[i] | reads[i]} & defined
        }
        if not more:
            break
        later |= more
    defined = {sig for i in later for sig, _ in heads[i]}
    if not later or ("warn", 2) in defined or defined & INPUTS:
        return []
    if any({_signature(a) for a in _atoms(s)} & defined for s in others):
        return []

    def meet(a: set[Any], b: set[Any]) -> bool:
        """Some atom of ``a`` may be one of ``b`` (same predicate, first arguments agree)."""
        return any(s == t and (c is None or d is None or c == d) for s, c in a for t, d in b)

    # one group per set of rules joined by a predicate (and its constant first argument)
    group = {i: i for i in later}

    def root(i: int) -> int:
        while group[i] != i:
            i = group[i]
        return i

    order = sorted(later)
    for x, i in enumerate(order):
        for j in order[x + 1 :]:
            if meet(heads[i], heads[j] | reads[j]) or meet(heads[j], reads[i]):
                group[root(j)] = root(i)
    out: dict[int, list[int]] = {}
    for i in order:
        out.setdefault(root(i), []).append(i)
    return [(ix, frozenset(trigger[i] for i in ix)) for ix in out.values()]


def _fact(sym: clingo.Symbol) -> Fact:
    """A fact tuple of a symbol (``symbol(_fact(s)) == s``)."""
    return (sym.name, *(_term(a) for a in sym.arguments))


def _term(sym: clingo.Symbol) -> Any:
    if sym.type == clingo.SymbolType.Number:
        return sym.number
    if sym.type == clingo.SymbolType.String:
        return AspString(sym.string)
    if sym.arguments or not sym.name:  # a function term or a tuple
        return (sym.name, *(_term(a) for a in sym.arguments))
    return sym.name


class StreamSolver:
    """situations.lp (with relations.lp and the user's encodings) on one long-lived clingo
    Control, a window of frames at a time.

    The program is split (:class:`_Layers`): rules over static facts are grounded once; rules
    about one frame are grounded once per frame, when it enters the window; the rules that
    join the frames of the window (or read the current one) are grounded once per answered
    frame over what the window holds. Facts are externals: a frame's facts are added when it
    enters (``add_frame``) and released when it leaves (``drop_frame``); facts about the whole
    window (a track's class, the first frame, the anticipations) are switched on and off
    (``set_window``); facts of one answer (the areas now) are released after it, and ``now(N)``
    is given as ``now(N,n)``, the answer's own (a released atom would be joined once more).
    Frames and tracks are numbers the caller chooses, increasing frames (the monitor: frames
    relative to the last restart, tracks by slot, so that a long run makes a bounded set of
    clingo symbols). All changes of a frame go to clingo at once, in ``answer``: one backend
    session, one ground call (and a second for the details of what is warned).

    ``answer(n)`` returns the ``warn/2`` and ``info/4`` atoms of the first answer set, as the
    fresh :class:`SituationSolver` would for the same facts. What a Control holds grows with
    the frames it was given (frames as facts stay in the domains, kept out of the answers by
    the window; clasp keeps every atom): after ``restart_frames`` answers :attr:`due` says so,
    and :meth:`restart` starts a new Control that grounds the window in one call.

    ``absent``: input predicates the caller never gives (the world motion without a camera
    model, lanes without a lanes file). With the static predicates that ``static_facts`` leave
    empty (:attr:`empty`), they rule out the rules that need them, which are not given to
    clingo (clingo instantiates every rule of a part on each ground call, fired or not).
    For the same reason the rules that read a warning (its details and grades, :func:`_details`)
    are grounded in a second call of the answer, only for the situations that have a ``warn``
    atom for it after the first: most frames warn of nothing.
    """

    def __init__(
        self,
        parts: Sequence[str] = _ALL_PARTS,
        constants: Mapping[str, int] | None = None,
        extra_encodings: Sequence[str | PathLike[str]] = (),
        static_facts: Sequence[Fact] = (),
        restart_frames: int = 40,
        window: int | None = None,
        absent: Collection[tuple[str, int]] = (),
    ):
        situation_constants(constants)  # validates
        self._init = (
            tuple(parts),
            dict(constants or {}),
            tuple(str(p) for p in extra_encodings),
            tuple(static_facts),
            int(restart_frames),
            window,
            frozenset(absent),
        )
        self._args = ["--warn=none"] + [f"-c{k}={int(v)}" for k, v in (constants or {}).items()]
        stmts = _shipped()[0] + tuple(s for p in extra_encodings for s in _parse_user_encoding(p))
        self._args.append(f"-csm_window={int(window) if window is not None else 2**30}")
        self._static = tuple(static_facts)
        program, layers, windowed, details = _stream_program(stmts, tuple(parts), FRAME_ARGUMENT)
        self._program, self.layers = program, layers  # _empty_static grounds their base
        try:
            # every rule is instantiated on each ground call, fired or not: those that the
            # static facts or the inputs never given rule out are not given to clingo at all
            empty = self._empty_static() | (set(absent) - _heads(stmts))
            if empty:
                program, layers, windowed, details = _stream_program(
                    stmts, tuple(parts), FRAME_ARGUMENT, empty
                )
        except RuntimeError as exc:
            raise InputError(
                f"situation encodings: {' '.join(str(exc).split())}",
                extra_encodings[0] if len(extra_encodings) == 1 else None,
            ) from None
        self.empty = frozenset(empty)
        self._program, self.layers = program, layers
        # the details' parts and the situations whose warning triggers them (see _details)
        self._details = details
        # frames as facts (the grounder decides the rules about them once, clasp never sees
        # them) when every rule that joins frames keeps them to the window; else externals,
        # released as frames leave
        self.plain = window is not None and windowed
        self._restart = max(1, int(restart_frames))
        self._frames: OrderedDict[int, tuple[clingo.Symbol, ...]] = OrderedDict()
        self._window: set[clingo.Symbol] = set()  # window facts switched on
        # the symbols of recent facts (fact_symbol): shared with the standby solvers
        self._symbols: dict[Fact, clingo.Symbol] = {}
        self.calls = self.restarts = 0
        try:
            self._start()
            self._all_details = True  # every part grounded once, whatever holds
            self.answer(0)  # surface the user's grounding errors now
            self._all_details = False
            self._start()
        except RuntimeError as exc:
            raise InputError(
                f"situation encodings: {' '.join(str(exc).split())}",
                extra_encodings[0] if len(extra_encodings) == 1 else None,
            ) from None
        self.calls = 0

    def _empty_static(self) -> set[tuple[str, int]]:
        """The static predicates (:class:`_Layers`) without an atom once ``base`` is ground
        with the static facts (``image`` with a camera model, ``ego_vehicle`` with profile
        fixed): certain to stay empty for the life of the solver."""
        base = []
        for st in self._program:
            if st.ast_type == clingo_ast.ASTType.Program and st.name != "base":
                break
            base.append(st)
        ctl = asp.control(self._args, base, [symbol(f) for f in self._static])
        ctl.ground([("base", [])])
        atoms = ctl.symbolic_atoms
        return {
            (name, arity)
            for name, arity in self.layers.static
            if not any(True for _ in atoms.by_signature(name, arity))
        }

    def __getstate__(self) -> dict[str, Any]:
        # clingo's Controls, ASTs and symbols do not pickle: the window goes as fact tuples
        return {
            "init": self._init,
            "frames": {f: [_fact(x) for x in syms] for f, syms in self._frames.items()},
            "window": [_fact(x) for x in self._shown],
            "calls": self.calls,
            "restarts": self.restarts,
        }

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__init__(*state["init"])  # type: ignore[misc]
        for f, facts in state["frames"].items():
            self.add_frame(f, facts)
        self.set_window(state["window"])
        self.calls, self.restarts = state["calls"], state["restarts"]

    def _start(self) -> None:
        """A new Control with the program and its static facts; the frames of the window and
        the window facts are given to it again with the next answer."""
        self._ctl = asp.control(self._args, self._program)
        # clingo's cleanup (at the first call after a solve) simplifies every domain and makes
        # the next ground call slower: 15-20 % of a frame on KITTI and the 25-object scene,
        # same answers (DESIGN-NOTES); released atoms stay in the domains either way (clingo
        # cleans only between a solve and the next call), the restarts bound them
        self._ctl.enable_cleanup = False
        self._age = 0
        self._known: set[clingo.Symbol] = set()  # window facts declared (on or off)
        self._current: list[clingo.Symbol] = []  # released before the next answer
        self._parts: list[tuple[str, Sequence[clingo.Symbol]]] = [("base", [])]
        self._add: list[clingo.Symbol] = [symbol(f) for f in self._static]
        self._facts = len(self._add)  # the static facts are facts, the rest externals
        self._frame_adds: list[clingo.Symbol] = []
        self._release: list[clingo.Symbol] = []
        for f, syms in self._frames.items():
            self._frame_adds += syms
            self._parts.append(("frame", [clingo.Number(f)]))
        self._shown = self._window
        self._window = set()

    def add_frame(self, frame: int, facts: Iterable[Fact]) -> None:
        """The facts of a frame entering the window (each holding at ``frame``)."""
        memo = self._symbols
        syms = tuple(fact_symbol(f, memo) for f in facts)
        self._frames[frame] = syms
        self._frame_adds += syms
        self._parts.append(("frame", [clingo.Number(frame)]))

    def drop_frame(self, frame: int) -> None:
        """Retract the facts of a frame leaving the window (facts: the rules do not join them
        any more; externals: released)."""
        syms = self._frames.pop(frame, ())
        if not self.plain:
            self._release += syms

    @property
    def frames(self) -> list[int]:
        """The frames in the window, oldest first."""
        return list(self._frames)

    def set_window(self, facts: Iterable[Fact]) -> None:
        """The facts about the whole window (not tied to one of its frames) that hold now."""
        memo = self._symbols
        self._shown = {fact_symbol(f, memo) for f in facts}

    def answer(self, now: int, current: Iterable[Fact] = ()) -> tuple[clingo.Symbol, ...]:
        """The ``warn/2`` and ``info/4`` atoms for the window's facts, ``now`` the current frame;
        ``current``: facts that hold for this answer only (``now(N)``, the boxes' areas now)."""
        self.calls += 1
        ctl = self._ctl
        n = clingo.Number(now)
        guard = clingo.Function(_STEP, [n])
        on = self._shown
        new = on - self._known
        self._known |= new
        flip = [(s, clingo.TruthValue.True_) for s in on - self._window - new]
        flip += [(s, clingo.TruthValue.False_) for s in self._window - on]
        self._window = set(on)
        release = self._release + self._current
        stepped = _NOW not in self.layers.derived  # now/1 is now(N,n) (see _stream_program)
        self._current = []
        nows = []
        for f in current:
            if stepped and f[0] == "now" and len(f) == 2:
                nows.append(clingo.Function("now", [symbol(f[1]), n]))
            else:
                self._current.append(fact_symbol(f, self._symbols))
        true_ = clingo.TruthValue.True_
        with ctl.backend() as backend:
            atom = backend.add_atom
            self._give(backend, release)
            for s in nows:
                backend.add_rule([atom(s)])
            for s in self._current:
                backend.add_external(atom(s), true_)
            for s in new:
                backend.add_external(atom(s), true_)
            for s, v in flip:
                backend.add_external(atom(s), v)
        ctl.ground([*self._parts, ("now", [n])])
        if self._details:
            self._ground_details(n)
        self._current.append(guard)
        self._add, self._facts, self._release, self._parts = [], 0, [], []
        self._frame_adds = []
        ctl.assign_external(guard, True)
        found: list[clingo.Symbol] = []

        def first(model: clingo.Model) -> bool:
            for s in model.symbols(shown=True):
                args = s.arguments
                if s.name == "warn" and len(args) == 3 and args[2] == n:
                    found.append(clingo.Function("warn", args[:2]))
                elif s.name == "info" and len(args) == 5 and args[4] == n:
                    found.append(clingo.Function("info", args[:4]))
            return False

        if ctl.solve(on_model=first).unsatisfiable and self._init[2]:
            raise ProgramError(_UNSATISFIABLE, ", ".join(self._init[2]))
        self._age += 1
        return tuple(found)

    def _ground_details(self, n: clingo.Symbol) -> None:
        """Ground the details' parts (:func:`_details`) of the situations that have a ``warn``
        atom for ``n`` after the first call: clingo instantiates every rule of a part it is
        asked for, and most frames warn of nothing."""
        warned: set[str] = set()
        for a in self._ctl.symbolic_atoms.by_signature("warn", 3):
            args = a.symbol.arguments
            if args[2] == n:
                warned.add(str(args[0]))
        parts = [
            (name, [n])
            for name, triggers in self._details
            if self._all_details
            or None in triggers
            or (warned and "*" in triggers)
            or not warned.isdisjoint(triggers)
        ]
        if parts:
            self._ctl.ground(parts)

    def _give(self, backend: clingo.Backend, release: Sequence[clingo.Symbol]) -> None:
        """Hand clingo what was added since the last ground call: ``release`` released, the
        static facts, the new frames' facts (facts or externals switched on)."""
        atom = backend.add_atom
        for s in release:
            backend.add_external(atom(s), clingo.TruthValue.Release)
        for s in self._add[: self._facts]:
            backend.add_rule([atom(s)])
        if self.plain:
            for s in self._frame_adds:
                backend.add_rule([atom(s)])
        else:
            true_ = clingo.TruthValue.True_
            for s in self._frame_adds:
                backend.add_external(atom(s), true_)

    def prepare(self) -> None:
        """Give clingo the frames added (and dropped) since the last call and ground their rules
        now, without answering: a standby solver fed a few frames at a time before it takes
        over (:meth:`standby`), so that no single frame grounds a whole window."""
        if not (self._parts or self._frame_adds or self._release):
            return
        release = self._release
        with self._ctl.backend() as backend:
            self._give(backend, release)
        self._ctl.ground(self._parts)
        self._add, self._facts, self._release, self._parts = [], 0, [], []
        self._frame_adds = []

    def standby(self) -> StreamSolver:
        """A solver with this one's program on a new Control and an empty window, to be fed
        (:meth:`add_frame`, :meth:`prepare`) while this one answers, then :meth:`adopt`-ed."""
        other = object.__new__(StreamSolver)  # not copy.copy: that would go through pickling
        other.__dict__.update(self.__dict__)
        other._frames = OrderedDict()
        other._window = set()
        other._start()
        return other

    def adopt(self, standby: StreamSolver) -> None:
        """Continue on ``standby``'s Control and window (fed by the caller): a restart whose
        window was given ahead. ``standby`` is not to be used afterwards."""
        calls, restarts = self.calls, self.restarts + 1
        self.__dict__.update(standby.__dict__)
        self.calls, self.restarts = calls, restarts

    @property
    def age(self) -> int:
        """Answers given on the current Control."""
        return self._age

    @property
    def restart_frames(self) -> int:
        """Answers after which the Control is replaced (:attr:`due`)."""
        return self._restart

    @property
    def due(self) -> bool:
        """Whether the Control has answered ``restart_frames`` times (or declared many window
        facts) and should be replaced (:meth:`restart`)."""
        return self._age >= self._restart or len(self._known) > _SYMBOLS_KEPT

    def restart(self, keep: bool = True) -> None:
        """A new Control; the frames of the window are given again with the next answer
        (``keep``), or forgotten, for the caller to add them again (e.g. renumbered)."""
        self.restarts += 1
        if not keep:
            self._frames.clear()
            self._shown = set()
        self._start()
