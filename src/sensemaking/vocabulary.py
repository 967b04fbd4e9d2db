"""The event vocabulary: every built-in event's name, arity and phrase, in one table.

The encodings abduce these events (``occurs(hides_behind(T,O))`` in tracking.lp); the tracker
reports them, the records carry them (:mod:`sensemaking.records`), and the demo, the captions
of the renderer and the answers of ``ask why`` say them with the same phrase::

    EVENTS["hides_behind"].sentence(["cyclist #2", "car #1"])  # 'cyclist #2 hides behind car #1'

An event of a user's encoding is not in the table: it is shown as ``name(args)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

__all__ = [
    "EventKind",
    "EVENTS",
    "EVENT_NAMES",
    "START_EVENTS",
    "REVIVE_EVENTS",
    "event_sentence",
]


@dataclass(frozen=True)
class EventKind:
    """One built-in event.

    Attributes:
        name: its ASP name. arity: its number of arguments (track ids; the first is the
            subject, a second is the other object).
        predicate: what it says about its subject, ``{1}`` standing for the other object
            (``"hides behind {1}"``).
    """

    name: str
    arity: int
    predicate: str

    def sentence(self, names: Sequence[str]) -> str:
        """The event in words about its named arguments (``names[0]`` the subject)."""
        return f"{names[0]} {self.predicate.format(*names)}"


#: the built-in events, by name
EVENTS: dict[str, EventKind] = {
    e.name: e
    for e in (
        EventKind("enters_fov", 1, "enters the field of view"),
        EventKind("leaves_fov", 1, "leaves the field of view"),
        EventKind("hides_behind", 2, "hides behind {1}"),
        # a late hiding (the track was already unobserved): weaker evidence, said apart
        EventKind("may_hide_behind", 2, "may be hiding behind {1}"),
        EventKind("unhides_from_behind", 2, "reappears from behind {1}"),
        EventKind("missing_detections", 1, "is not detected (missing detections)"),
        # detections resume after missing detections
        EventKind("reappears", 1, "is detected again"),
        # a track starts without entering the field of view (e.g. first frame)
        EventKind("starts", 1, "is in view"),
        # a track ends without leaving the field of view (lost)
        EventKind("ends", 1, "is lost"),
        # a track that left the field of view is found again (revive_s): it left and came back
        EventKind("reenters_fov", 1, "re-enters the field of view"),
        # a lost track is found again (revive_s)
        EventKind("returns", 1, "is found again after it was lost"),
    )
}

#: the abducible events, with their arity
EVENT_NAMES: dict[str, int] = {name: e.arity for name, e in EVENTS.items()}

#: the events that start a track: a tentative track's is reported when it is confirmed, but was
#: abduced at the frame its first detection started it
START_EVENTS: tuple[str, ...] = ("starts", "enters_fov")

#: the events that revive an ended track (``revive_s``): reported, like a start, when the revived
#: track is confirmed again, abduced at the frame its detection revived it
REVIVE_EVENTS: tuple[str, ...] = ("reenters_fov", "returns")


def event_sentence(name: str, names: Sequence[str]) -> str:
    """An event in words about its named arguments; an event not in :data:`EVENTS`, or with
    fewer arguments than its arity, as ``name(args)``."""
    kind = EVENTS.get(name)
    if kind is None or len(names) < kind.arity or not names:
        return f"{name}({', '.join(names)})"
    return kind.sentence(names)
