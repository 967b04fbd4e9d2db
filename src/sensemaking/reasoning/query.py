"""The sandboxed runner of ASP queries over a recorded scene (``ask(scene, "<rules>")``).

ASP queries are untrusted text, so they are checked (:func:`check_query`) and run under limits:

* Allowed: rules, constraints, choice rules, aggregates (``#count``, ``#sum``, ``#sum+``,
  ``#min``, ``#max``), ``#show``, ``#minimize`` / ``#maximize``, comments, and the constants
  ``#inf``, ``#sup``, ``#true``, ``#false``. Refused before clingo sees the text (anywhere in it,
  comments and strings included: clingo's parser opens an ``#include`` while parsing), and so is a
  query that does not parse (:func:`sensemaking.sandbox.check_program`): every other
  directive (``#include``, which would read files; ``#script``, which runs code; ``#external``,
  ``#const``, ``#program``, ``#project``, ``#heuristic``, ``#edge``, ``#theory``, ``#defined``)
  and ``@``-terms (calls into script functions).
* Grounding and solving run in a child process (where ``fork`` exists) with a time limit
  (``timeout`` seconds), a memory limit (``max_memory_mb``) and a limit on the number of ground
  atoms (``max_atoms``, checked once grounding is done; the memory limit bounds it while
  grounding); past one the child is killed and :class:`QueryError` says which limit. Ctrl-C
  stops it at once. Answer sets are passed on as they are found (``on_model``).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import clingo
from clingo import ast as clingo_ast

from sensemaking import asp
from sensemaking.errors import SensemakingError
from sensemaking.reasoning.facts import scene_facts_text
from sensemaking.sandbox import (
    DEFAULT_MAX_ATOMS,
    DEFAULT_MAX_MEMORY_MB,
    DEFAULT_TIMEOUT_S,
    QUERY_DIRECTIVES,
    LimitError,
    Limits,
    check_atoms,
    check_program,
    run_limited,
)

if TYPE_CHECKING:  # pragma: no cover
    from sensemaking.reasoning.context import SceneContext
    from sensemaking.scene import Scene

__all__ = [
    "run_query",
    "check_query",
    "QueryAnswer",
    "QueryError",
    "DEFAULT_TIMEOUT_S",
    "DEFAULT_MAX_ATOMS",
    "DEFAULT_MAX_MEMORY_MB",
]

#: the directives a query may use (see the module docstring)
ALLOWED_DIRECTIVES = QUERY_DIRECTIVES
_FORBIDDEN_NODES = frozenset(
    {
        "Script",
        "External",
        "Definition",
        "ProjectAtom",
        "ProjectSignature",
        "Heuristic",
        "Edge",
        "TheoryDefinition",
        "TheoryAtom",
        "Defined",
    }
)


class QueryError(SensemakingError):
    """A query that clingo cannot parse or ground, or a named question used wrongly.

    Attributes:
        messages: clingo's messages, locations written ``query:LINE:COLUMN``.
        line, column: 1-based position of the first error in the query, when known.
    """

    def __init__(
        self,
        message: str,
        messages: list[str] | None = None,
        line: int | None = None,
        column: int | None = None,
    ):
        super().__init__(message)
        self.messages = list(messages or [])
        self.line = line
        self.column = column

    def __reduce__(self) -> tuple[Any, ...]:  # crosses the pipe from the limited child
        return (QueryError, (self.args[0], self.messages, self.line, self.column))


@dataclass(frozen=True)
class QueryAnswer:
    """The answer to one question.

    Attributes:
        question: the query as asked.
        lines: the answer in readable lines.
        atoms: shown atoms of the first answer set, sorted (ASP queries and named questions).
        models: shown atoms of each answer set found (up to ``max_models``).
        satisfiable: False when the query's constraints rule out every answer set.
        notes: clingo's informational messages about the query (e.g. an atom no rule defines).
    """

    question: str
    lines: tuple[str, ...]
    atoms: tuple[str, ...] = ()
    models: tuple[tuple[str, ...], ...] = ()
    satisfiable: bool = True
    notes: tuple[str, ...] = field(default=())

    def __str__(self) -> str:
        return "\n".join(self.lines)

    def to_json(self) -> dict[str, Any]:
        return {
            "question": self.question,
            "lines": list(self.lines),
            "atoms": list(self.atoms),
            "models": [list(m) for m in self.models],
            "satisfiable": self.satisfiable,
            "notes": list(self.notes),
        }


# -- running clingo -------------------------------------------------------------------------------
_LOC = re.compile(r"query:(\d+):(\d+)")


def encodings(*names: str) -> str:
    from sensemaking.reasoning.situations import encoding_text

    return "\n".join(encoding_text(n) for n in names)


def _show_signatures(stmts: list[Any]) -> tuple[bool, set[tuple[str, int]]]:
    """(the query has #show statements, the predicates its rule heads define)."""
    has_show = False
    heads: set[tuple[str, int]] = set()

    def atom(node: Any) -> None:
        t = node.ast_type
        A = clingo_ast.ASTType
        if t == A.Literal:
            atom(node.atom)
        elif t == A.SymbolicAtom:
            atom(node.symbol)
        elif t == A.Function:
            heads.add((node.name, len(node.arguments)))
        elif t == A.SymbolicTerm and node.symbol.type == clingo.SymbolType.Function:
            heads.add((node.symbol.name, len(node.symbol.arguments)))
        elif t == A.ConditionalLiteral:
            atom(node.literal)
        elif t in (A.Disjunction, A.Aggregate):
            for e in node.elements:
                atom(e)
        elif t == A.HeadAggregate:
            for e in node.elements:
                atom(e.condition)

    for s in stmts:
        if s.ast_type in (clingo_ast.ASTType.ShowSignature, clingo_ast.ASTType.ShowTerm):
            has_show = True
        elif s.ast_type == clingo_ast.ASTType.Rule:
            atom(s.head)
    return has_show, {h for h in heads if h[0]}


def check_query(query: str) -> None:
    """Refuse a query that reaches outside the scene or does not parse (see the module
    docstring): raises :class:`QueryError` naming the first forbidden directive or term, or
    clingo's syntax error, with its line. Runs before clingo grounds anything."""

    stmts = check_program(
        query, "query", allowed=QUERY_DIRECTIVES, allow_at=False, error=_query_error
    )
    _check_ast(stmts)


def _query_error(msg: str, line: int | None, col: int | None) -> QueryError:
    return QueryError(msg if "not allowed" in msg else "invalid query: " + msg, [msg], line, col)


def _check_ast(stmts: list[Any]) -> None:
    """The same allow-list on the parsed statements (a second line of defence)."""

    def walk(node: Any) -> None:
        name = str(node.ast_type).rsplit(".", 1)[-1]
        if name in _FORBIDDEN_NODES or (name == "Function" and getattr(node, "external", False)):
            raise QueryError(f"query: {name} is not allowed in a query")
        if name == "Program" and node.name != "base":
            raise QueryError("query: #program is not allowed in a query")
        for key in node.child_keys:
            child = getattr(node, key)
            if child is None:
                continue
            if isinstance(child, clingo_ast.AST):
                walk(child)
            else:
                for c in child:
                    walk(c)

    for s in stmts:
        walk(s)


def solve(
    program: str,
    query: str | None = None,
    max_models: int = 1,
    *,
    max_atoms: int | None = None,
    on_model: Callable[[list[clingo.Symbol]], None] | None = None,
) -> tuple[list[list[clingo.Symbol]], bool, list[str], bool]:
    """Ground ``program`` (trusted: encodings and facts) plus the user's ``query``; return the
    shown atoms of up to ``max_models`` models, satisfiability, notes about the query and
    whether the query shows anything (False: constraints only)."""
    messages: list[tuple[clingo.MessageCode, str]] = []

    def logger(code: clingo.MessageCode, msg: str) -> None:
        messages.append((code, msg.replace("<string>", "query").rstrip()))

    def fail(default: str) -> QueryError:
        errs = (
            [m for c, m in messages if "query:" in m and "error" in m]
            or [m for _, m in messages]
            or [default]
        )
        first = _LOC.search(errs[0])
        line, col = (int(first.group(1)), int(first.group(2))) if first else (None, None)
        return QueryError("invalid query: " + "\n".join(errs), errs, line, col)

    ctl = asp.control(asp.limits(max_models=max_models), logger=logger)
    ctl.add("base", [], program)
    shows = True
    if query is not None:
        stmts: list[Any] = []
        try:
            clingo_ast.parse_string(query, stmts.append, logger=logger, message_limit=20)
        except RuntimeError:
            raise fail("syntax error") from None
        _check_ast(stmts)
        has_show, heads = _show_signatures(stmts)
        with clingo_ast.ProgramBuilder(ctl) as builder:
            for s in stmts:
                builder.add(s)
            if not has_show:
                for name, arity in sorted(heads):
                    clingo_ast.parse_string(f"#show {name}/{arity}.", builder.add)
                if not heads:
                    clingo_ast.parse_string("#show.", builder.add)
                    shows = False
    try:
        ctl.ground([("base", [])])
    except RuntimeError:
        raise fail("grounding failed") from None
    try:
        check_atoms(len(ctl.symbolic_atoms), max_atoms, "the query")
    except LimitError as exc:
        raise QueryError(str(exc)) from None
    models, satisfiable = asp.models(ctl, on_model=on_model)
    notes = [m for c, m in messages if "query:" in m]
    return models, satisfiable, notes, shows


def _solve_limited(
    program: str,
    query: str,
    max_models: int,
    *,
    timeout: float | None,
    max_atoms: int | None,
    max_memory_mb: int | None,
    on_model: Callable[[tuple[str, ...]], None] | None = None,
) -> tuple[list[tuple[str, ...]], bool, list[str], bool]:
    """:func:`_solve` of an untrusted query in a child process under the limits
    (:func:`sensemaking.sandbox.run_limited`); models as tuples of atom strings, passed to
    ``on_model`` as they arrive."""
    models: list[tuple[str, ...]] = []

    def got(atoms: Any) -> None:
        t = tuple(str(a) for a in atoms)
        models.append(t)
        if on_model is not None:
            on_model(t)

    def work(send: Callable[[Any], None]) -> tuple[bool, list[str], bool]:
        _, sat, notes, shows = solve(
            program,
            query,
            max_models,
            max_atoms=max_atoms,
            on_model=lambda atoms: send([str(a) for a in atoms]),
        )
        return sat, notes, shows

    sat, notes, shows = run_limited(
        work,
        Limits(timeout, max_atoms, max_memory_mb),
        what="the query",
        on_item=got,
        fail=QueryError,
    )
    return models, bool(sat), list(notes), bool(shows)


def program_facts(scene: Scene, context: SceneContext | None, **kw: Any) -> str:
    return scene_facts_text(scene, context=context, **kw)


#: derived predicates -> the input predicates they are built from (scene.lp, relations.lp)
_REACH = {
    "closer": "ra",
    "side_by_side": "ra",
    "touching": "ra",
    "ra": "ra",
    "live": "state",
    "holds_at": "holds_during",
    "box": "box",
    "motion": "motion",
    "in_corridor": "in_corridor",
}


def _program_for(scene: Scene, query: str, context: SceneContext | None) -> str:
    """Scene facts and views for an ASP query. Only what the query can reach is built: a query
    can use a predicate only by naming it, so fact groups (boxes, relations, motion, corridor)
    and the event-calculus view are left out when the query names none of their predicates."""
    words = set(re.findall(r"[a-z_][A-Za-z0-9_']*", query))
    need = {_REACH[w] for w in words if w in _REACH}
    facts = program_facts(
        scene,
        context,
        boxes="box" in need,
        relations="ra" in need,
        motion="motion" in need,
        corridor="in_corridor" in need,
    )
    names = ["relations.lp"] if "ra" in need else []
    if need & {"state", "holds_during"}:
        names.append("scene.lp")
    return facts + encodings(*names) if names else facts


def run_query(
    scene: Scene,
    query: str,
    *,
    context: SceneContext | None = None,
    max_models: int = 1,
    timeout: float | None = DEFAULT_TIMEOUT_S,
    max_atoms: int | None = DEFAULT_MAX_ATOMS,
    max_memory_mb: int | None = DEFAULT_MAX_MEMORY_MB,
    on_model: Callable[[tuple[str, ...]], None] | None = None,
) -> QueryAnswer:
    """Answer ASP rules over the scene under the limits (arguments as
    :func:`~sensemaking.reasoning.questions.ask`). Raises :class:`QueryError`."""
    check_query(query)
    program = _program_for(scene, query, context)
    models, sat, notes, shows = _solve_limited(
        program,
        query,
        max_models,
        timeout=timeout,
        max_atoms=max_atoms,
        max_memory_mb=max_memory_mb,
        on_model=on_model,
    )
    shown = tuple(models)
    if not sat:
        lines: tuple[str, ...] = (
            "no answer: the query's constraints rule out every answer set (UNSATISFIABLE)",
        )
    elif len(shown) == 1:
        empty = (
            "none: no shown atom holds"
            if shows
            else "yes: the scene satisfies the query's constraints"
        )
        lines = shown[0] or (empty,)
    else:
        lines = tuple(f"answer {i + 1}: {' '.join(m)}" for i, m in enumerate(shown))
    return QueryAnswer(
        query,
        lines,
        atoms=shown[0] if shown else (),
        models=shown,
        satisfiable=sat,
        notes=tuple(notes),
    )
