"""The clingo call pattern, written once: load an encoding, parse it once, build a ``Control``
with its arguments and limits, add facts, ground, and solve within a wall-clock budget.

The rules live in the ``.lp`` encodings; Python only prepares facts and reads answers. Every
caller follows the same steps::

    ctl = asp.control(args, program=asp.parsed(text), facts=symbols)
    ctl.ground([("base", [])])
    solved = asp.solve(ctl, budget_ms=50.0)  # optimisation: None if no model within the budget
    found, satisfiable = asp.models(ctl, first=True)  # enumeration: the shown atoms per model

:func:`encoding` reads a packaged encoding (``importlib.resources``), :func:`parsed` parses a
program text once per process (re-adding its statements is ~3x cheaper than parsing),
:func:`limits` turns budgets into clingo arguments, and :class:`Solved` is what a solve found.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from functools import cache, lru_cache
from importlib import resources

import clingo
from clingo import Symbol, SymbolType
from clingo.ast import AST, ASTType, ProgramBuilder, parse_string

__all__ = [
    "Solved",
    "encoding",
    "parsed",
    "mentioned",
    "constants",
    "parse_messages",
    "limits",
    "control",
    "add_facts",
    "term",
    "forbid",
    "solve",
    "models",
    "quiet_logger",
]

log = logging.getLogger(__name__)

#: clingo's message logger: ``(code, message) -> None``
Logger = Callable[[clingo.MessageCode, str], None]


def quiet_logger(code: clingo.MessageCode, message: str) -> None:
    """clingo's messages (e.g. undefined atoms) go to the debug log, not to stderr."""
    log.debug("clingo: %s", message.strip())


@cache
def encoding(package: str, name: str) -> str:
    """Text of an encoding shipped as package data in ``<package>/encodings/<name>``."""
    return resources.files(package).joinpath("encodings", name).read_text(encoding="utf-8")


def parsed(program: str) -> tuple[AST, ...]:
    """The program text parsed once into AST statements (re-adding them: ~3x cheaper than
    parsing), once per thread: clingo counts the references to an AST node without a lock, so
    two threads adding the same statements to their Controls at once corrupt them (an "invalid
    ast" error, or a crash)."""
    return _parsed(program, threading.get_ident())


@lru_cache(maxsize=16)
def _parsed(program: str, thread: int) -> tuple[AST, ...]:
    statements: list[AST] = []
    parse_string(program, statements.append)
    return tuple(statements)


def parse_messages(program: str) -> list[str] | None:
    """None if the program text parses, else clingo's messages (possibly empty)."""
    messages: list[str] = []
    try:
        parse_string(program, lambda _: None, logger=lambda _c, m: messages.append(m.strip()))
    except RuntimeError:
        return messages
    return None


@lru_cache(maxsize=16)
def mentioned(program: str) -> frozenset[str]:
    """Names of every predicate or function the program mentions (an over-approximation of
    what its rules read: a fact whose name is not here cannot change an answer)."""
    names: set[str] = set()

    def visit(node: object) -> None:
        if isinstance(node, clingo.ast.AST):
            if node.ast_type == ASTType.Function:
                names.add(node.name)
            elif node.ast_type == ASTType.SymbolicTerm and node.symbol.type == SymbolType.Function:
                names.add(node.symbol.name)
            for key in node.child_keys:
                visit(getattr(node, key))
        elif isinstance(node, (list, tuple, clingo.ast.ASTSequence)):
            for child in node:
                visit(child)

    for statement in parsed(program):
        visit(statement)
    return frozenset(names)


@lru_cache(maxsize=8)
def constants(program: str) -> tuple[tuple[str, int], ...]:
    """The ``#const name = value.`` defaults of a program text, in order."""
    return tuple(
        (stmt.name, int(stmt.value.symbol.number))
        for stmt in parsed(program)
        if stmt.ast_type == ASTType.Definition
    )


def limits(max_conflicts: int | None = None, max_models: int | None = None) -> list[str]:
    """clingo arguments for a deterministic work budget per solve (``--solve-limit``, in
    conflicts) and a number of models (``--models``, 0: all); None: clingo's default."""
    args = []
    if max_models is not None:
        args.append(f"--models={max(0, int(max_models))}")
    if max_conflicts is not None:
        args.append(f"--solve-limit={int(max_conflicts)}")
    return args


#: symbols already made, by their plain term: through clingo's Python API a number costs
#: ~1.5 us and a function ~7 us, a lookup ~0.1 us, and facts repeat from frame to frame
#: (components are numbered from 0); bounded, cleared when full
_TERMS: dict[object, Symbol] = {}
_TERMS_KEPT = 1 << 14

#: a plain term: an int (a number), a str (a constant) or ``(name, *args)`` (a function term;
#: name ``""`` a tuple)
Term = int | str | tuple


def term(key: Term) -> Symbol:
    """The clingo symbol of a plain term (``("cand", 0, ("d", 2), 700)`` is
    ``cand(0,d(2),700)``), made once while it stays in a bounded cache. A str is a constant
    (never a quoted string: give those as ``clingo.String``)."""
    sym = _TERMS.get(key)
    if sym is None:
        if isinstance(key, tuple):
            sym = clingo.Function(key[0], [term(a) for a in key[1:]])
        elif isinstance(key, str):
            sym = clingo.Function(key)
        else:
            sym = clingo.Number(key)
        if len(_TERMS) >= _TERMS_KEPT:
            _TERMS.clear()
        _TERMS[key] = sym
    return sym


def control(
    args: Sequence[str],
    program: Iterable[AST] = (),
    facts: Iterable[Symbol] | None = None,
    *,
    logger: Logger = quiet_logger,
    message_limit: int = 20,
) -> clingo.Control:
    """A fresh ``Control`` with ``args`` (clingo command-line options), the parsed ``program``
    statements (:func:`parsed`) and ``facts`` (ground atoms, through the backend) added; not
    ground yet."""
    ctl = clingo.Control(list(args), logger=logger, message_limit=message_limit)
    statements = list(program)
    if statements:
        with ProgramBuilder(ctl) as builder:
            for statement in statements:
                builder.add(statement)
    if facts is not None:
        add_facts(ctl, facts)
    return ctl


def add_facts(ctl: clingo.Control, facts: Iterable[Symbol]) -> None:
    """Add ground atoms as facts through the backend (no parsing, no grounding of rules)."""
    with ctl.backend() as backend:
        for fact in facts:
            backend.add_rule([backend.add_atom(fact)])


def forbid(ctl: clingo.Control, conjunctions: Iterable[Iterable[Symbol]]) -> None:
    """Integrity constraints ``:- a1, ..., an.`` over ground atoms of a ground ``Control``; a
    conjunction with an atom the ground program lacks can never hold and needs none."""
    rules = []
    for conjunction in conjunctions:
        lits = []
        for sym in conjunction:
            atom = ctl.symbolic_atoms[sym]
            if atom is None:
                break
            lits.append(atom.literal)
        else:
            rules.append(lits)
    if rules:
        with ctl.backend() as backend:
            for lits in rules:
                backend.add_rule([], lits)


class Unsatisfiable(Exception):
    """A program with no answer set at all (proved, not cut by a budget)."""


@dataclass
class Solved:
    """What one solve found: the shown atoms of its last (best) model, that model's cost on the
    main objective (tie-break levels, priority < 0, are not a cost), whether the search was
    exhausted (the model is optimal), whether the wall-clock budget cut it, and the
    milliseconds since ``started``."""

    symbols: list[Symbol]
    cost: int
    exhausted: bool
    timed_out: bool
    ms: float


def solve(
    ctl: clingo.Control,
    budget_ms: float | None = None,
    *,
    assumptions: Sequence[int] = (),
    started: float | None = None,
    refuse_unsat: bool = False,
) -> Solved | None:
    """Solve a ground ``Control`` and keep its last model; None if it found none (within the
    budget, or the program is unsatisfiable). ``budget_ms`` is wall-clock milliseconds counted
    from ``started`` (a ``time.perf_counter()`` value; default: now), so that grounding spent
    before the call counts as well; past it the search is cancelled and the best model so far
    is kept. ``assumptions``: program literals that must hold. ``refuse_unsat``: raise
    :class:`Unsatisfiable` when the program is proved to have no answer set."""
    t0 = time.perf_counter() if started is None else started
    best: list[Symbol] = []
    info: dict[str, int] = {}

    def on_model(model: clingo.Model) -> None:
        best[:] = model.symbols(shown=True)
        levels = zip(model.cost, model.priority, strict=True)
        info["cost"] = sum(c for c, p in levels if p >= 0)

    timed_out = False
    if budget_ms is None:
        # the last model only: an optimisation reports ~2 models a solve, and reading a
        # model's symbols into Python costs more than clasp's search on small programs
        result = ctl.solve(assumptions=list(assumptions), on_last=on_model)
    else:
        remaining = budget_ms / 1000.0 - (time.perf_counter() - t0)
        with ctl.solve(assumptions=list(assumptions), on_model=on_model, async_=True) as handle:
            if not handle.wait(max(remaining, 0.0)):
                handle.cancel()
                timed_out = True
            result = handle.get()
    ms = (time.perf_counter() - t0) * 1000.0
    if "cost" not in info:
        if refuse_unsat and result.unsatisfiable and not timed_out:
            raise Unsatisfiable()
        log.debug("no model within the budget (%.1f ms, timed out: %s)", ms, timed_out)
        return None
    return Solved(best, info["cost"], bool(result.exhausted), timed_out, ms)


def models(
    ctl: clingo.Control,
    *,
    first: bool = False,
    on_model: Callable[[list[Symbol]], None] | None = None,
) -> tuple[list[list[Symbol]], bool]:
    """Enumerate a ground ``Control``'s models (as many as its ``--models`` argument allows;
    only the first with ``first``): the shown atoms of each, sorted, and whether the program
    is satisfiable. ``on_model`` sees each model's atoms as it is found."""
    found: list[list[Symbol]] = []

    def each(model: clingo.Model) -> bool:
        atoms = sorted(model.symbols(shown=True))
        found.append(atoms)
        if on_model is not None:
            on_model(atoms)
        return not first

    result = ctl.solve(on_model=each)
    return found, bool(result.satisfiable)
