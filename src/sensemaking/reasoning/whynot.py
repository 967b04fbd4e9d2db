"""Why-not answers: why a track's events were chosen, against the next-best explanations of the
encoding with their costs (``ask(scene, "why T [F]")``)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from sensemaking.reasoning.query import QueryAnswer, QueryError
from sensemaking.reasoning.stories import missing_track
from sensemaking.vocabulary import EVENTS

if TYPE_CHECKING:  # pragma: no cover
    from sensemaking.reasoning.context import SceneContext
    from sensemaking.scene import Scene

__all__ = ["why", "WHY_ALTERNATIVES"]


#: how many alternatives ``why`` names per event
WHY_ALTERNATIVES = 3

#: an action of the encoding, as a phrase about its subject (``{1}``: the other object)
_ACTIONS = {
    "assign": "is matched to {1}",
    "resume": "is matched again to {1}",
    "start": "starts a new track",
    "ignore_det": "is ignored (a detection explained by no track)",
    "ignore_trk": "stays unseen",
    "halt": "stops being seen",
    "end": "ends",
}
#: an event (:mod:`sensemaking.vocabulary`) or action, as a phrase about its subject
_PHRASES = {**{name: e.predicate for name, e in EVENTS.items()}, **_ACTIONS}
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
        return text.format("", self.name(args[1]) if len(args) > 1 else "")

    def phrases(self, atoms: tuple[tuple[str, tuple], ...], subject: Any) -> str:
        """What an alternative holds about the subject (actions an event implies, such as
        ``end`` beside ``leaves_fov``, left out)."""
        events = [a for a in atoms if a[0] in EVENTS or a[0] not in _PHRASES]
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


def why(scene: Scene, args: list[int], context: SceneContext | None) -> QueryAnswer:
    """The chosen explanation of each event of a track (at a frame) and the next-best ones,
    from the abduction problem the scene recorded (solved again, with the event forbidden)."""
    tid = args[0]
    q = "why " + " ".join(map(str, args))
    if tid not in scene:
        raise QueryError(missing_track(scene, tid))
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
        return QueryAnswer(q, (f"{d} has no event{at} (frames with its events: {listing})",))
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
    return QueryAnswer(q, tuple(lines), atoms=tuple(atoms), models=(tuple(atoms),))
