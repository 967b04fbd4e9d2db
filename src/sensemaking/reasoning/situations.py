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
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from enum import Enum
from functools import cache, lru_cache
from importlib import resources
from os import PathLike
from pathlib import Path
from typing import Any

import clingo
from clingo import ast as clingo_ast

from sensemaking.errors import InputError
from sensemaking.reasoning.anticipation import AnticipationConfig
from sensemaking.reasoning.facts import Fact, symbol
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
            + [v for k, v in consts.items() if k.endswith("_ms") and k != "he_lead_ms"]
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
            self._solve(())
        except RuntimeError as exc:
            raise InputError(
                f"situation encodings: {' '.join(str(exc).split())}",
                extra_encodings[0] if len(extra_encodings) == 1 else None,
            ) from None

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
        ctl = clingo.Control(self._args)
        with clingo_ast.ProgramBuilder(ctl) as builder:  # parsed once: cheaper than text per call
            for stmt in self._stmts:
                builder.add(stmt)
        if len(self._symbols) > _SYMBOLS_KEPT:
            self._symbols.clear()
        memo = self._symbols
        with ctl.backend() as backend:
            for fact in facts:
                sym = memo.get(fact)
                if sym is None:
                    sym = memo[fact] = symbol(fact)
                backend.add_rule([backend.add_atom(sym)])
        ctl.ground(self._parts)
        found: list[clingo.Symbol] = []

        def first(model: clingo.Model) -> bool:
            found.extend(
                s
                for s in model.symbols(shown=True)
                if (s.name, len(s.arguments)) in (("warn", 2), ("info", 4))
            )
            return False  # the first answer set is the answer

        ctl.solve(on_model=first)
        return tuple(found)
