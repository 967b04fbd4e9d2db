"""Question answering over a recorded scene, in ASP, and the scene's story in sentences.

``ask(scene, query)`` takes either ASP text (rules over the predicates of ``scene.lp`` and
``relations.lp``, with ``#show``; without ``#show`` the predicates the query defines are shown)
or a named question:

==================== ===========================================================
``tracks``           every track: class, frames, how long visible / hidden / missing
``events [T]``       the event log (of track T)
``hidden [T]``       which objects were hidden, by what, from when to when
``reappeared T``     when track T became visible again, and after what
``in-front F``       what was in front of the ego vehicle (in the corridor) at frame F
``why-ended T``      why track T ended
``why T [F]``        why track T's events (at frame F) were chosen: the next-best explanations
                     of the encoding, with their costs ("why not ...?")
``story [T]``        each track's story in sentences (same as :func:`explain`)
``warnings``         safety-critical situations, replaying the scene through the monitor
==================== ===========================================================

A query clingo cannot parse or ground raises :class:`QueryError` with clingo's message and the
position in the query (``query:LINE:COLUMN``); questions about tracks or frames that are not in
the scene get an answer that says so.

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
import numpy as np
from clingo import ast as clingo_ast

from sensemaking.errors import SensemakingError
from sensemaking.results import TrackState, Visibility
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
    from sensemaking.scene import Scene, Track

__all__ = [
    "ask",
    "explain",
    "stories",
    "check_query",
    "Answer",
    "QueryError",
    "NAMED_QUESTIONS",
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

#: named questions -> usage line
NAMED_QUESTIONS: dict[str, str] = {
    "tracks": "tracks -- every track with its class, frames and states",
    "events": "events [TRACK] -- the event log, or the events of one track",
    "hidden": "hidden [TRACK] -- which objects were hidden, by what, from when to when",
    "reappeared": "reappeared TRACK -- when the track became visible again, and after what",
    "in-front": "in-front FRAME -- what was in front of the ego vehicle at that frame",
    "why-ended": "why-ended TRACK -- why the track ended",
    "why": "why TRACK [FRAME] -- the explanation of the track's events (at FRAME) against the "
    "next-best ones, with their costs",
    "story": "story [TRACK] -- each track's story in sentences",
    "warnings": "warnings -- safety-critical situations over the scene",
}
_ARGS = {
    "tracks": (0, 0),
    "events": (0, 1),
    "hidden": (0, 1),
    "reappeared": (1, 1),
    "in-front": (1, 1),
    "why-ended": (1, 1),
    "why": (1, 2),
    "story": (0, 1),
    "warnings": (0, 0),
}
_ALIASES = {
    "in_front": "in-front",
    "infront": "in-front",
    "why_ended": "why-ended",
    "ended": "why-ended",
    "why-not": "why",
    "why_not": "why",
    "alternatives": "why",
    "explain": "story",
    "reappear": "reappeared",
    "hidden_by": "hidden",
}


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
class Answer:
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


def _encodings(*names: str) -> str:
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


def _solve(
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

    ctl = clingo.Control([f"--models={max(0, int(max_models))}"], logger=logger, message_limit=20)
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
    models: list[list[clingo.Symbol]] = []

    def found(m: clingo.Model) -> None:
        atoms = sorted(m.symbols(shown=True))
        models.append(atoms)
        if on_model is not None:
            on_model(atoms)

    res = ctl.solve(on_model=found)
    notes = [m for c, m in messages if "query:" in m]
    return models, bool(res.satisfiable), notes, shows


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
        _, sat, notes, shows = _solve(
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


def _facts(scene: Scene, context: SceneContext | None, **kw: Any) -> str:
    return scene.to_facts(context=context, **kw)


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
    facts = _facts(
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
    return facts + _encodings(*names) if names else facts


# -- formatting helpers ---------------------------------------------------------------------------
def _dur(scene: Scene, frames: int) -> str:
    return f"{frames} frame{'s' if frames != 1 else ''} ({scene.seconds(frames):.1f} s)"


def _missing_track(scene: Scene, track_id: int) -> str:
    ids = list(scene.tracks)
    listing = ", ".join(map(str, ids[:20])) + (", ..." if len(ids) > 20 else "")
    return f"track {track_id} does not appear in this scene" + (
        f" (tracks: {listing})" if ids else " (it has no tracks)"
    )


def _where(scene: Scene, box: Any, context: SceneContext | None = None) -> str:
    """Coarse place of a box in the image: left / right / in front of the ego vehicle."""
    if scene.image_size is None:
        return f"at x={(box[0] + box[2]) / 2:.0f}, y={box[3]:.0f} px"
    from sensemaking.reasoning.context import Corridor

    corr = context.corridor if context is not None else Corridor()
    w = scene.image_size[0]
    cx = (box[0] + box[2]) / 2
    if corr.contains_boxes(np.asarray(box, dtype=np.float64), scene.image_size)[0]:
        place = "in front of the ego vehicle"
    else:
        place = "on the left" if cx < w / 3 else "on the right" if cx > 2 * w / 3 else "ahead"
    return f"{place} (x={cx:.0f}, y={box[3]:.0f} px)"


def _border(scene: Scene, box: Any, margin: float = 15.0) -> str:
    if scene.image_size is None:
        return ""
    w, h = scene.image_size
    sides = [
        ("left", box[0] <= margin),
        ("right", box[2] >= w - margin),
        ("top", box[1] <= margin),
        ("bottom", box[3] >= h - margin),
    ]
    hit = [s for s, ok in sides if ok]
    return f" at the {' and '.join(hit)} border" if hit else ""


# -- named questions ------------------------------------------------------------------------------
def _q_tracks(scene: Scene, args: list[int], context: SceneContext | None) -> Answer:
    lines = []
    for t in scene.tracks.values():
        counts = {s: int((t.state == s).sum()) for s in TrackState}
        lines.append(
            f"{scene.describe(t.id)}: frames {t.first}-{t.last}, "
            f"visible {counts[TrackState.VISIBLE]}, "
            f"hidden {counts[TrackState.HIDDEN]}, missing {counts[TrackState.MISSING]}"
        )
    return Answer("tracks", tuple(lines or ["this scene has no tracks"]))


def _q_events(scene: Scene, args: list[int], context: SceneContext | None) -> Answer:
    if args and args[0] not in scene:
        return Answer(f"events {args[0]}", (_missing_track(scene, args[0]),))
    evs = scene.events_of(args[0]) if args else scene.events
    lines = [f"frame {e.frame}: {e.name}({', '.join(map(str, e.args))})" for e in evs]
    q = "events" + (f" {args[0]}" if args else "")
    return Answer(
        q,
        tuple(lines or ["no events" + (f" for {scene.describe(args[0])}" if args else "")]),
        atoms=tuple(f"occurs_at({e.name}({','.join(map(str, e.args))}),{e.frame})" for e in evs),
    )


def _q_hidden(scene: Scene, args: list[int], context: SceneContext | None) -> Answer:
    q = "hidden" + (f" {args[0]}" if args else "")
    if args and args[0] not in scene:
        return Answer(q, (_missing_track(scene, args[0]),))
    facts = _facts(
        scene, context, boxes=False, states=False, relations=False, motion=False, corridor=False
    )
    models, _, _, _ = _solve(facts + _encodings("questions.lp") + "\n#show hidden_episode/4.")
    atoms = [
        s for s in (models[0] if models else []) if not args or s.arguments[0].number == args[0]
    ]
    lines = []
    for s in sorted(atoms, key=lambda s: (s.arguments[2].number, s.arguments[0].number)):
        t, o, a, b = (x.number for x in s.arguments)
        track = scene.tracks[t]
        k = track.index(b)
        after = ""
        if k is not None and k + 1 < len(track) and track.frames[k + 1] == b + 1:
            nxt = TrackState(int(track.state[k + 1]))
            after = (
                f"; it reappeared at frame {b + 1}"
                if nxt == TrackState.VISIBLE
                else "; then its detections were missing"
                if nxt == TrackState.MISSING
                else ""
            )
        elif b == scene.last_frame:
            after = "; still hidden at the end of the scene"
        elif b == track.last:
            after = "; the track ended while hidden"
        lines.append(
            f"{scene.describe(t)} was hidden by {scene.describe(o)} from frame {a} to frame {b}, "
            f"{_dur(scene, b - a + 1)}{after}"
        )
    if not lines:
        lines = [
            f"{scene.describe(args[0])} was never hidden"
            if args
            else "no object was hidden in this scene"
        ]
    return Answer(
        q, tuple(lines), atoms=tuple(str(s) for s in atoms), models=(tuple(str(s) for s in atoms),)
    )


def _q_reappeared(scene: Scene, args: list[int], context: SceneContext | None) -> Answer:
    (tid,) = args
    q = f"reappeared {tid}"
    if tid not in scene:
        return Answer(q, (_missing_track(scene, tid),))
    facts = _facts(scene, context, boxes=False, relations=False, motion=False, corridor=False)
    models, _, _, _ = _solve(facts + _encodings("questions.lp") + "\n#show reappeared/4.")
    atoms = [s for s in (models[0] if models else []) if s.arguments[0].number == tid]
    atoms.sort(key=lambda s: s.arguments[1].number)
    lines = []
    for s in atoms:
        f, g = s.arguments[1].number, s.arguments[2].number
        cause = s.arguments[3]
        how = (
            f"from behind {scene.describe(cause.arguments[0].number)}"
            if cause.name == "hidden_by"
            else "after missing detections"
        )
        lines.append(
            f"{scene.describe(tid)} reappeared at frame {f} {how}, unseen since frame {g}: "
            f"{_dur(scene, f - g)}"
        )
    if not lines:
        t = scene.tracks[tid]
        unseen = t.state != TrackState.VISIBLE
        if unseen.any():
            g = int(t.frames[unseen][0])
            lines = [
                f"{scene.describe(tid)} did not reappear: unseen from frame {g} "
                f"until its last frame {t.last}"
            ]
        else:
            lines = [
                f"{scene.describe(tid)} never disappeared: visible whenever tracked "
                f"(frames {t.first}-{t.last})"
            ]
    return Answer(
        q, tuple(lines), atoms=tuple(str(s) for s in atoms), models=(tuple(str(s) for s in atoms),)
    )


def _q_in_front(scene: Scene, args: list[int], context: SceneContext | None) -> Answer:
    (f,) = args
    q = f"in-front {f}"
    if not len(scene) or f not in set(scene.frame_numbers.tolist()):
        span = f"frames {scene.first_frame}-{scene.last_frame}" if len(scene) else "no frames"
        return Answer(q, (f"frame {f} is not in this scene ({span})",))
    if scene.image_size is None:
        return Answer(q, ("this scene has no image size, so the ego corridor is unknown",))
    facts = _facts(
        scene, context, boxes=True, states=False, relations=False, motion=False, corridor=True
    )
    models, _, _, _ = _solve(
        facts
        + _encodings("questions.lp")
        + f"\n#show.\n#show in_front(F,T,Y) : in_front(F,T,Y), F = {f}."
    )
    atoms = sorted(models[0] if models else [], key=lambda s: -s.arguments[2].number)
    lines = []
    for rank, s in enumerate(atoms):
        t, y = s.arguments[1].number, s.arguments[2].number
        track = scene.tracks[t]
        st = TrackState(int(track.state[track.index(f)]))
        extra = "nearest, " if rank == 0 and len(atoms) > 1 else ""
        if st == TrackState.HIDDEN:
            extra += f"hidden behind {scene.describe(int(track.occluder[track.index(f)]))}, "
        elif st == TrackState.MISSING:
            extra += "not detected (predicted position), "
        lines.append(f"{scene.describe(t)}: {extra}bottom at y={y} px")
    head = f"at frame {f} ({scene.seconds(f - (scene.first_frame or 0)):.1f} s into the scene)"
    if not lines:
        return Answer(q, (f"{head} nothing was in front of the ego vehicle",))
    return Answer(
        q,
        (f"{head}, in front of the ego vehicle:",) + tuple(lines),
        atoms=tuple(str(s) for s in atoms),
        models=(tuple(str(s) for s in atoms),),
    )


def _q_why_ended(scene: Scene, args: list[int], context: SceneContext | None) -> Answer:
    (tid,) = args
    q = f"why-ended {tid}"
    if tid not in scene:
        return Answer(q, (_missing_track(scene, tid),))
    facts = _facts(scene, context, boxes=False, relations=False, motion=False, corridor=False)
    models, _, _, _ = _solve(
        facts
        + _encodings("questions.lp")
        + f"\n#show.\n#show ended(T,L,R) : ended(T,L,R), T = {tid}.\n"
        + f"#show final_state(T,S) : final_state(T,S), T = {tid}."
    )
    atoms = models[0] if models else []
    ended = next(s for s in atoms if s.name == "ended")
    last, reason = ended.arguments[1].number, ended.arguments[2].name
    t = scene.tracks[tid]
    k = len(t) - 1
    st = TrackState(int(t.state[k]))
    d = scene.describe(tid)
    if reason == "left_fov":
        ev = next(e for e in scene.events_of(tid) if e.name == "leaves_fov")
        line = (
            f"{d} ended because it left the field of view{_border(scene, t.xyxy[k])} "
            f"(event at frame {ev.frame}; last tracked at frame {last})"
        )
    elif reason == "lost":
        ev = next(e for e in scene.events_of(tid) if e.name == "ends")
        unseen = int(t.hidden_frames[k])
        if st == TrackState.VISIBLE or not unseen:
            why = f"it was last seen at frame {last}"
        elif st == TrackState.HIDDEN:
            why = (
                f"it had been hidden behind {scene.describe(int(t.occluder[k]))} "
                f"for {_dur(scene, unseen)} "
                f"since frame {last - unseen + 1}"
            )
        else:
            why = (
                f"its detections had been missing for {_dur(scene, unseen)} "
                f"since frame {last - unseen + 1}"
            )
        line = (
            f"{d} was lost at frame {ev.frame}: {why}, "
            "and the tracker could no longer explain its absence"
        )
    elif reason == "scene_end":
        line = (
            f"{d} did not end: it was still tracked ({st.name.lower()}) "
            f"at the last frame of the scene ({last})"
        )
    else:
        line = (
            f"{d} was last tracked at frame {last} ({st.name.lower()}); no event explains its end"
        )
    return Answer(
        q, (line,), atoms=tuple(str(s) for s in atoms), models=(tuple(str(s) for s in atoms),)
    )


#: how many alternatives ``why`` names per event
WHY_ALTERNATIVES = 3

#: an event or action of the encoding, as a phrase about its subject (``{o}``: the other object)
_PHRASES = {
    "enters_fov": "enters the field of view",
    "starts": "appears inside the view",
    "leaves_fov": "leaves the field of view",
    "ends": "ends, unexplained (lost)",
    "hides_behind": "hides behind {o}",
    "unhides_from_behind": "comes out from behind {o}",
    "missing_detections": "is not detected (missing detections)",
    "reappears": "is detected again (reappears)",
    "assign": "is matched to {o}",
    "resume": "is matched again to {o}",
    "start": "starts a new track",
    "ignore_det": "is ignored (a detection explained by no track)",
    "ignore_trk": "stays unseen",
    "halt": "stops being seen",
    "end": "ends",
}
#: actions that an event of the same subject says more precisely
_IMPLIED = {"start", "end", "halt", "ignore_trk"}


class _Namer:
    """Names the objects of a recorded problem (or of the event log, ``record`` None) in words.

    A detection is named by what it was in the chosen answer: the track it started, or the
    detection of the track it continued, or an ignored one."""

    def __init__(self, scene: Scene, record: Any = None, chosen: Any = None):
        self.scene, self.record = scene, record
        self.of_track: dict[int, int] = {}  # local detection -> local track it went to
        if chosen is not None:
            self.of_track = {d: t for t, d in {**chosen.assign, **chosen.resume}.items()}

    def name(self, x: Any) -> str:
        from sensemaking.abduction.solver import Det

        ref = x if self.record is None else self.record.global_ref(x)
        if isinstance(ref, Det):
            t = self.of_track.get(ref.row)
            return "an ignored detection" if t is None else f"the detection of {self.name(t)}"
        return self.scene.describe(ref) if isinstance(ref, int) else str(ref)

    def phrase(self, name: str, args: tuple[Any, ...], subject: Any = None) -> str:
        """An event or action as a phrase about its subject (its first argument, or
        ``subject`` when that is the detection of an ``assign``/``resume``)."""
        if name in ("assign", "resume") and len(args) == 2 and args[1] == subject:
            return f"is the detection of {self.name(args[0])}"
        text = _PHRASES.get(name)
        if text is None:
            return f"{name}({', '.join(self.name(a) for a in args)})"
        return text.format(o=self.name(args[1]) if len(args) > 1 else "")

    def phrases(self, atoms: tuple[tuple[str, tuple], ...], subject: Any) -> str:
        """What an alternative holds about the subject (actions an event implies, such as
        ``end`` beside ``leaves_fov``, left out)."""
        from sensemaking.results import EVENT_NAMES

        events = [a for a in atoms if a[0] in EVENT_NAMES or a[0] not in _PHRASES]
        shown = [a for a in atoms if a in events or (a[0] not in _IMPLIED or not events)]
        return " and ".join(self.phrase(n, a, subject) for n, a in shown) or "nothing"

    def elsewhere(self, chosen: Any, other: Any, subject: Any) -> str:
        """Events of other objects that the alternative holds and the chosen answer does not."""
        new = [
            (n, a)
            for n, a in other.events
            if (n, a) not in chosen.events and a and a[0] != subject and n in _PHRASES
        ]
        said = [f"{self.name(a[0])} {self.phrase(n, a)}" for n, a in new]
        return f", while {' and '.join(said)}" if said else ""


def _atom_text(name: str, args: tuple[Any, ...]) -> str:
    from sensemaking.abduction.solver import Det

    def fmt(x: Any) -> str:
        return f"d({x.row})" if isinstance(x, Det) else str(x)

    return f"{name}({','.join(map(fmt, args))})"


def _q_why(scene: Scene, args: list[int], context: SceneContext | None) -> Answer:
    """The chosen explanation of each event of a track (at a frame) and the next-best ones,
    from the abduction problem the scene recorded (solved again, with the event forbidden)."""
    tid = args[0]
    q = "why " + " ".join(map(str, args))
    if tid not in scene:
        raise QueryError(_missing_track(scene, tid))
    t = scene.tracks[tid]
    d = scene.describe(tid)
    own = [e for e in scene.events if e.args and e.args[0] == tid]
    lo = min([t.first] + [e.frame for e in own])
    hi = max([t.last] + [e.frame for e in own])
    if len(args) == 2:
        frame = args[1]
        if not lo <= frame <= hi:
            raise QueryError(f"frame {frame} is out of range: {d} is in frames {lo}-{hi}")
        own = [e for e in own if e.frame == frame]
    if scene.abduction is None:
        raise QueryError(
            "this scene does not record the abduction problems behind its events (written "
            "before they were recorded, or with a user's encoding): run `sensemaking track "
            "--scene` again"
        )
    if not own:
        at = f" at frame {args[1]}" if len(args) == 2 else ""
        frames = sorted({e.frame for e in scene.events_of(tid) if e.args[0] == tid})
        listing = ", ".join(map(str, frames)) if frames else "none"
        return Answer(q, (f"{d} has no event{at} (frames with its events: {listing})",))
    lines: list[str] = []
    atoms: list[str] = []
    for ev in own:
        found = scene.abduction.alternatives(ev, WHY_ALTERNATIVES)
        said = f"At frame {ev.frame}, {d} {_Namer(scene).phrase(ev.name, ev.args)}"
        if found is None:
            lines.append(f"{said}: the scene holds no abduction problem for this event.")
            continue
        record, alts = found
        chosen, subject = alts.chosen, alts.event[1][0]
        if chosen is None or not alts.holds:
            lines.append(
                f"{said}: solving its recorded problem again does not give this event "
                "(the solver's budget ended the search differently)."
            )
            continue
        where = f" (abduced at frame {record.frame}, when its detection started the track)"
        said += where if record.frame != ev.frame else ""
        if not alts.alternatives:
            lines.append(f"{said} (cost {chosen.cost}): nothing else explains it.")
            continue
        namer = _Namer(scene, record, chosen)
        rather = "; ".join(
            f"{namer.phrases(a.instead or a.about, subject)}"
            f"{namer.elsewhere(chosen, a.answer, subject)} "
            f"(cost {a.cost}, {a.delta:+d})"
            for a in alts.alternatives
        )
        lines.append(f"{said} (cost {chosen.cost}) rather than: {rather}.")
        atoms.append(f"chosen({_atom_text(ev.name, ev.args)},{ev.frame},{chosen.cost})")
        for rank, a in enumerate(alts.alternatives, 1):
            for name, refs in a.instead or a.about:
                ids = tuple(record.global_ref(x) for x in refs)
                atoms.append(
                    f"alternative({tid},{ev.frame},{rank},{_atom_text(name, ids)},"
                    f"{a.cost},{a.delta})"
                )
    return Answer(q, tuple(lines), atoms=tuple(atoms), models=(tuple(atoms),))


def _q_story(scene: Scene, args: list[int], context: SceneContext | None) -> Answer:
    q = "story" + (f" {args[0]}" if args else "")
    return Answer(q, tuple(explain(scene, args[0] if args else None, context=context)))


def _q_warnings(scene: Scene, args: list[int], context: SceneContext | None) -> Answer:
    from sensemaking.reasoning.online import SituationMonitor

    if scene.image_size is None:
        return Answer(
            "warnings", ("this scene has no image size, so situations cannot be checked",)
        )
    from sensemaking.reasoning.egomotion import CameraModel

    camera = scene.metadata.get("camera")  # recorded with a camera model: motion on the road
    mon = SituationMonitor(
        context=context,
        fps=scene.fps,
        image_size=scene.image_size,
        camera=None if camera is None else CameraModel.from_json(camera),
    )
    warnings = mon.run(scene.frame_results())
    lines = [str(w) for w in warnings]
    return Answer("warnings", tuple(lines or ["no safety-critical situation was detected"]))


_HANDLERS: dict[str, Callable[[Scene, list[int], SceneContext | None], Answer]] = {
    "tracks": _q_tracks,
    "events": _q_events,
    "hidden": _q_hidden,
    "reappeared": _q_reappeared,
    "in-front": _q_in_front,
    "why-ended": _q_why_ended,
    "why": _q_why,
    "story": _q_story,
    "warnings": _q_warnings,
}


def _named(query: str) -> tuple[str, list[int]] | None:
    """``(name, integer args)`` when ``query`` is a named question; raises QueryError on misuse."""
    words = query.split()
    if not words or re.search(r"[().:#]", query):
        return None
    name = _ALIASES.get(words[0].lower(), words[0].lower())
    if name not in NAMED_QUESTIONS:
        return None
    lo, hi = _ARGS[name]
    try:
        args = [int(w) for w in words[1:]]
    except ValueError:
        raise QueryError(f"usage: {NAMED_QUESTIONS[name]}") from None
    if not lo <= len(args) <= hi:
        raise QueryError(f"usage: {NAMED_QUESTIONS[name]}")
    return name, args


def ask(
    scene: Scene,
    query: str,
    *,
    context: SceneContext | None = None,
    max_models: int = 1,
    timeout: float | None = DEFAULT_TIMEOUT_S,
    max_atoms: int | None = DEFAULT_MAX_ATOMS,
    max_memory_mb: int | None = DEFAULT_MAX_MEMORY_MB,
    on_model: Callable[[tuple[str, ...]], None] | None = None,
) -> Answer:
    """Answer a named question or an ASP query about ``scene``.

    Args:
        scene: the :class:`~sensemaking.scene.Scene`.
        query: a named question (see :data:`NAMED_QUESTIONS`) or ASP rules over the predicates of
            ``scene.lp`` / ``relations.lp``, with ``#show`` (without: the predicates the
            rules define are shown; a query of constraints only answers yes or no).
        context: corridor and lanes (default corridor, no lanes).
        max_models: answer sets to compute for an ASP query (0: all).
        timeout: seconds for grounding + solving an ASP query (None: no limit).
        max_atoms: ground atoms an ASP query may produce (None: no limit).
        max_memory_mb: memory for an ASP query beyond what the process uses (None: no limit).
        on_model: called with each answer set's shown atoms as it is found (ASP queries).

    Raises:
        QueryError: the ASP cannot be parsed or grounded (message with ``query:LINE:COLUMN``),
            or a named question has wrong arguments, or the query uses a directive outside the
            allow-list, or it exceeds a limit.
    """
    for name, value in (
        ("timeout", timeout),
        ("max_atoms", max_atoms),
        ("max_memory_mb", max_memory_mb),
    ):
        if value is not None and not (value > 0 and value == value and value != float("inf")):
            raise QueryError(f"{name} must be a positive number or None, got {value!r}")
    if not query or not query.strip():
        raise QueryError(
            "empty query: give ASP rules with #show, or one of: " + ", ".join(NAMED_QUESTIONS)
        )
    named = _named(query)
    if named is not None:
        return _HANDLERS[named[0]](scene, named[1], context)
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
    return Answer(
        query,
        lines,
        atoms=shown[0] if shown else (),
        models=shown,
        satisfiable=sat,
        notes=tuple(notes),
    )


# -- stories --------------------------------------------------------------------------------------
def _motion_summary(scene: Scene, t: Track) -> str | None:
    from sensemaking.reasoning.egomotion import world_story

    world = world_story(scene, t.id)  # over the road, when recorded with a camera model
    if world is not None:
        return world
    vis = t.visible_mask()
    if vis.sum() < 2:
        return None
    f = t.frames[vis]
    b = t.xyxy[vis]
    dt = scene.seconds(int(f[-1] - f[0]))
    if dt <= 0:
        return None
    vx = ((b[-1, 0] + b[-1, 2]) - (b[0, 0] + b[0, 2])) / 2 / dt
    h0, h1 = b[0, 3] - b[0, 1], b[-1, 3] - b[-1, 1]
    ratio = h1 / h0 if h0 > 0 else 1.0
    parts = []
    if abs(vx) >= 20.0:
        parts.append(f"moves {'right' if vx > 0 else 'left'} at about {abs(vx):.0f} px/s")
    if ratio >= 1.15 and b[-1, 3] > b[0, 3]:
        parts.append("comes closer")
    elif ratio <= 1 / 1.15 and b[-1, 3] < b[0, 3]:
        parts.append("moves away")
    if not parts:
        return "It stays roughly in place in the image."
    return "It " + " and ".join(parts) + "."


def _story(scene: Scene, t: Track, context: SceneContext | None) -> list[str]:
    d = scene.describe(t.id)
    evs = scene.events_of(t.id)
    own = [e for e in evs if e.args and e.args[0] == t.id]
    first = f"{d[0].upper()}{d[1:]}"
    where = _where(scene, t.xyxy[0], context)
    start = next((e for e in own if e.name in ("enters_fov", "starts")), None)
    if start is not None and start.name == "enters_fov":
        out = [
            f"{first} enters the field of view at frame {start.frame}"
            f"{_border(scene, t.xyxy[0])}, {where}."
        ]
    elif t.first == scene.first_frame:
        out = [f"{first} is in view from the first frame ({t.first}), {where}."]
    else:
        out = [f"{first} appears at frame {t.first}, {where}."]
    m = _motion_summary(scene, t)
    if m:
        out.append(m)
    hidden = {(f.args[1], f.start): f for f in scene.fluent_intervals("hidden_by", t.id)}
    gap_from: int | None = None
    for e in evs:
        if e.name == "hides_behind" and e.args[0] == t.id:
            out.append(f"At frame {e.frame} it hides behind {scene.describe(int(e.args[1]))}.")
        elif e.name == "hides_behind" and len(e.args) > 1 and e.args[1] == t.id:
            out.append(f"At frame {e.frame} it hides {scene.describe(int(e.args[0]))} from view.")
        elif e.name == "unhides_from_behind" and e.args[0] == t.id:
            ep = max(
                (iv for (o, s), iv in hidden.items() if o == e.args[1] and s < e.frame),
                key=lambda iv: iv.start,
                default=None,
            )
            took = f" after {_dur(scene, e.frame - ep.start)}" if ep else ""
            out.append(
                f"At frame {e.frame} it comes out from behind "
                f"{scene.describe(int(e.args[1]))}{took}."
            )
        elif e.name == "unhides_from_behind" and len(e.args) > 1 and e.args[1] == t.id:
            out.append(
                f"At frame {e.frame} {scene.describe(int(e.args[0]))} comes out from behind it."
            )
        elif e.name == "missing_detections" and e.args[0] == t.id:
            gap_from = e.frame
            out.append(f"From frame {e.frame} its detections are missing.")
        elif e.name == "reappears" and e.args[0] == t.id:
            took = (
                f" after {_dur(scene, e.frame - gap_from)}"
                if gap_from is not None and gap_from < e.frame
                else ""
            )
            out.append(f"At frame {e.frame} it is detected again{took}.")
            gap_from = None
    k = len(t) - 1
    leave = next((e for e in own if e.name == "leaves_fov"), None)
    end = next((e for e in own if e.name == "ends"), None)
    if leave is not None:
        out.append(
            f"At frame {leave.frame} it leaves the field of view{_border(scene, t.xyxy[k])}."
        )
    elif end is not None:
        unseen = int(t.hidden_frames[k])
        why = f" unseen for {_dur(scene, unseen)}," if unseen else ""
        out.append(
            f"At frame {end.frame} the track ends:{why} its absence could no longer be explained."
        )
    elif t.last == scene.last_frame:
        st = TrackState(int(t.state[k]))
        now = {
            TrackState.VISIBLE: "visible",
            TrackState.MISSING: "with missing detections",
            TrackState.HIDDEN: f"hidden behind {scene.describe(int(t.occluder[k]))}",
        }[st]
        vis = Visibility(int(t.visibility[k]))
        if st == TrackState.VISIBLE and vis == Visibility.PARTIALLY_OCCLUDED:
            now += ", partially occluded"
        out.append(f"It is still tracked at the end of the scene (frame {t.last}), {now}.")
    else:
        out.append(f"It was last tracked at frame {t.last}.")
    return out


def stories(scene: Scene, *, context: SceneContext | None = None) -> dict[int, list[str]]:
    """Each track's story (track id -> sentences), tracks in order of appearance."""
    order = sorted(scene.tracks.values(), key=lambda t: (t.first, t.id))
    return {t.id: _story(scene, t, context) for t in order}


def explain(
    scene: Scene, track_id: int | None = None, *, context: SceneContext | None = None
) -> list[str]:
    """The story of one track (or of every track, in order of appearance) as sentences.

    A track that is not in the scene gets the one sentence saying so.
    """
    if track_id is not None:
        if track_id not in scene:
            return [_missing_track(scene, track_id)]
        return _story(scene, scene.tracks[int(track_id)], context)
    out: list[str] = []
    for sentences in stories(scene, context=context).values():
        out.extend(sentences)
    return out or ["this scene has no tracks"]
