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

ASP queries run in a sandbox (:mod:`sensemaking.reasoning.query`); the why-not answers
are :mod:`sensemaking.reasoning.whynot`, the stories :mod:`sensemaking.reasoning.stories`.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import TYPE_CHECKING

from sensemaking.reasoning.query import (
    DEFAULT_MAX_ATOMS,
    DEFAULT_MAX_MEMORY_MB,
    DEFAULT_TIMEOUT_S,
    QueryAnswer,
    QueryError,
    check_query,
    encodings,
    program_facts,
    run_query,
    solve,
)
from sensemaking.reasoning.stories import border_phrase, duration, explain, missing_track, stories
from sensemaking.reasoning.whynot import why
from sensemaking.results import TrackState

if TYPE_CHECKING:  # pragma: no cover
    from sensemaking.reasoning.context import SceneContext
    from sensemaking.scene import Scene

__all__ = [
    "ask",
    "explain",
    "stories",
    "check_query",
    "QueryAnswer",
    "QueryError",
    "NAMED_QUESTIONS",
    "DEFAULT_TIMEOUT_S",
    "DEFAULT_MAX_ATOMS",
    "DEFAULT_MAX_MEMORY_MB",
]

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


# -- named questions ------------------------------------------------------------------------------
def _about(scene: Scene, tracks: list[int]) -> Scene:
    """The part of ``scene`` a question about ``tracks`` needs (all of it when none are named):
    questions.lp relates a track only to its own facts, so the others are left out."""
    return scene.only(tracks) if tracks else scene


def _q_tracks(scene: Scene, args: list[int], context: SceneContext | None) -> QueryAnswer:
    lines = []
    for t in scene.tracks.values():
        counts = {s: int((t.state == s).sum()) for s in TrackState}
        lines.append(
            f"{scene.describe(t.id)}: frames {t.first}-{t.last}, "
            f"visible {counts[TrackState.VISIBLE]}, "
            f"hidden {counts[TrackState.HIDDEN]}, missing {counts[TrackState.MISSING]}"
        )
    return QueryAnswer("tracks", tuple(lines or ["this scene has no tracks"]))


def _q_events(scene: Scene, args: list[int], context: SceneContext | None) -> QueryAnswer:
    if args and args[0] not in scene:
        return QueryAnswer(f"events {args[0]}", (missing_track(scene, args[0]),))
    evs = scene.events_of(args[0]) if args else scene.events
    lines = [f"frame {e.frame}: {e.name}({', '.join(map(str, e.args))})" for e in evs]
    q = "events" + (f" {args[0]}" if args else "")
    return QueryAnswer(
        q,
        tuple(lines or ["no events" + (f" for {scene.describe(args[0])}" if args else "")]),
        atoms=tuple(f"occurs_at({e.name}({','.join(map(str, e.args))}),{e.frame})" for e in evs),
    )


def _q_hidden(scene: Scene, args: list[int], context: SceneContext | None) -> QueryAnswer:
    q = "hidden" + (f" {args[0]}" if args else "")
    if args and args[0] not in scene:
        return QueryAnswer(q, (missing_track(scene, args[0]),))
    facts = program_facts(
        _about(scene, args),
        context,
        boxes=False,
        states=False,
        relations=False,
        motion=False,
        corridor=False,
    )
    models, _, _, _ = solve(facts + encodings("questions.lp") + "\n#show hidden_episode/4.")
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
            f"{duration(scene, b - a + 1)}{after}"
        )
    if not lines:
        lines = [
            f"{scene.describe(args[0])} was never hidden"
            if args
            else "no object was hidden in this scene"
        ]
    return QueryAnswer(
        q, tuple(lines), atoms=tuple(str(s) for s in atoms), models=(tuple(str(s) for s in atoms),)
    )


def _q_reappeared(scene: Scene, args: list[int], context: SceneContext | None) -> QueryAnswer:
    (tid,) = args
    q = f"reappeared {tid}"
    if tid not in scene:
        return QueryAnswer(q, (missing_track(scene, tid),))
    facts = program_facts(
        _about(scene, [tid]), context, boxes=False, relations=False, motion=False, corridor=False
    )
    models, _, _, _ = solve(facts + encodings("questions.lp") + "\n#show reappeared/4.")
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
            f"{duration(scene, f - g)}"
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
    return QueryAnswer(
        q, tuple(lines), atoms=tuple(str(s) for s in atoms), models=(tuple(str(s) for s in atoms),)
    )


def _q_in_front(scene: Scene, args: list[int], context: SceneContext | None) -> QueryAnswer:
    (f,) = args
    q = f"in-front {f}"
    if not len(scene) or f not in set(scene.frame_numbers.tolist()):
        span = f"frames {scene.first_frame}-{scene.last_frame}" if len(scene) else "no frames"
        return QueryAnswer(q, (f"frame {f} is not in this scene ({span})",))
    if scene.image_size is None:
        return QueryAnswer(q, ("this scene has no image size, so the ego corridor is unknown",))
    facts = program_facts(  # in_front relates a frame only to its own facts: that frame's rows
        scene.window(f, f),
        context,
        boxes=True,
        states=False,
        relations=False,
        motion=False,
        corridor=True,
    )
    models, _, _, _ = solve(
        facts
        + encodings("questions.lp")
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
        return QueryAnswer(q, (f"{head} nothing was in front of the ego vehicle",))
    return QueryAnswer(
        q,
        (f"{head}, in front of the ego vehicle:",) + tuple(lines),
        atoms=tuple(str(s) for s in atoms),
        models=(tuple(str(s) for s in atoms),),
    )


def _q_why_ended(scene: Scene, args: list[int], context: SceneContext | None) -> QueryAnswer:
    (tid,) = args
    q = f"why-ended {tid}"
    if tid not in scene:
        return QueryAnswer(q, (missing_track(scene, tid),))
    facts = program_facts(
        _about(scene, [tid]), context, boxes=False, relations=False, motion=False, corridor=False
    )
    models, _, _, _ = solve(
        facts
        + encodings("questions.lp")
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
            f"{d} ended because it left the field of view{border_phrase(scene, t.xyxy[k])} "
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
                f"for {duration(scene, unseen)} "
                f"since frame {last - unseen + 1}"
            )
        else:
            why = (
                f"its detections had been missing for {duration(scene, unseen)} "
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
    return QueryAnswer(
        q, (line,), atoms=tuple(str(s) for s in atoms), models=(tuple(str(s) for s in atoms),)
    )


def _q_story(scene: Scene, args: list[int], context: SceneContext | None) -> QueryAnswer:
    q = "story" + (f" {args[0]}" if args else "")
    return QueryAnswer(q, tuple(explain(scene, args[0] if args else None, context=context)))


def _q_warnings(scene: Scene, args: list[int], context: SceneContext | None) -> QueryAnswer:
    from sensemaking.reasoning.online import SituationMonitor

    if scene.image_size is None:
        return QueryAnswer(
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
    return QueryAnswer("warnings", tuple(lines or ["no safety-critical situation was detected"]))


_HANDLERS: dict[str, Callable[[Scene, list[int], SceneContext | None], QueryAnswer]] = {
    "tracks": _q_tracks,
    "events": _q_events,
    "hidden": _q_hidden,
    "reappeared": _q_reappeared,
    "in-front": _q_in_front,
    "why-ended": _q_why_ended,
    "why": why,
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
) -> QueryAnswer:
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
    return run_query(
        scene,
        query,
        context=context,
        max_models=max_models,
        timeout=timeout,
        max_atoms=max_atoms,
        max_memory_mb=max_memory_mb,
        on_model=on_model,
    )
