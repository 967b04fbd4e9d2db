"""ASP facts as clingo symbols, and answers read back as Python values.

Facts are written as plain tuples ``(name, arg, ...)`` -- cheap to build, hash and compare, so a
caller can key a cache on them -- and turned into clingo symbols only when clingo needs them:
an ``int`` is a number, a ``str`` a constant (an ASP identifier such as ``visible``), an
:class:`AspString` a quoted string, a tuple a function term ``name(args...)``.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

import clingo
import numpy as np

from sensemaking import asp
from sensemaking.reasoning.context import SceneContext, asp_name
from sensemaking.reasoning.relations import (
    MotionThresholds,
    RelationConfig,
    motion_facts,
    pair_front,
    pair_relations,
    relation_facts,
    track_motion,
)
from sensemaking.results import STATE_NAMES

if TYPE_CHECKING:  # pragma: no cover
    from sensemaking.scene import Scene

__all__ = [
    "AspString",
    "Fact",
    "symbol",
    "fact_symbol",
    "value",
    "scene_facts",
    "scene_facts_text",
    "facts_text",
]

#: one fact or term: ``(name, arg, ...)``
Fact = tuple[Any, ...]


class AspString(str):
    """A string given to clingo as a quoted ASP string (``"lane 1"``), not a constant."""

    __slots__ = ()


def symbol(term: Any) -> clingo.Symbol:
    """The clingo symbol of an int, a constant (str), an :class:`AspString` or a tuple
    ``(name, arg, ...)`` (a function term; ``("", a, b)`` is the tuple ``(a,b)``)."""
    kind = type(term)
    if kind is int or kind is str:  # numbers and constants repeat: made once (asp.term)
        return asp.term(term)
    if kind is tuple:
        return clingo.Function(term[0], [symbol(a) for a in term[1:]])
    if isinstance(term, AspString):
        return clingo.String(term)
    if isinstance(term, tuple):
        return clingo.Function(term[0], [symbol(a) for a in term[1:]])
    if isinstance(term, str):
        return clingo.Function(term)
    if isinstance(term, int) and not isinstance(term, bool):
        return clingo.Number(term)
    raise TypeError(f"no ASP term for {term!r} ({type(term).__name__})")


#: the argument types of a fact whose symbol may be kept by its tuple: an AspString equals the
#: str of its text, so a fact holding one must not share a key with the fact of the constant
_PLAIN = frozenset({int, str})
#: fact symbols a cache keeps (about 200 bytes each with its tuple) before it starts afresh
FACT_SYMBOLS_KEPT = 1 << 15


def fact_symbol(
    fact: Fact, cache: dict[Fact, clingo.Symbol], kept: int = FACT_SYMBOLS_KEPT
) -> clingo.Symbol:
    """``symbol(fact)``, taken from ``cache`` or made and kept there (cleared when it holds
    ``kept``) when the fact's arguments are ints and constants: a function symbol costs ~4 us
    through clingo's Python API, a lookup ~0.1 us, and a stream's facts recur (frames relative
    to a base, tracks by slot)."""
    if not _PLAIN.issuperset(map(type, fact)):
        return symbol(fact)
    sym = cache.get(fact)
    if sym is None:
        if len(cache) >= kept:
            cache.clear()
        sym = cache[fact] = symbol(fact)
    return sym


def value(sym: clingo.Symbol) -> Any:
    """A number as int, a string as str, a constant by its name, any other term as its text."""
    if sym.type == clingo.SymbolType.Number:
        return sym.number
    if sym.type == clingo.SymbolType.String:
        return sym.string
    if sym.type == clingo.SymbolType.Function and not sym.arguments and sym.name:
        return sym.name
    return str(sym)


def scene_facts(
    scene: Scene,
    *,
    boxes: bool = True,
    states: bool = True,
    relations: bool = True,
    motion: bool = True,
    corridor: bool = True,
    context: SceneContext | None = None,
    relation_config: RelationConfig | None = None,
    motion_thresholds: MotionThresholds | None = None,
) -> list[Fact]:
    """A :class:`~sensemaking.scene.Scene` as facts (predicates documented in
    ``reasoning/encodings/scene.lp``).

    Args:
        boxes: ``box/6`` per track and frame (pixels, rounded).
        states: ``state/3`` per track and frame.
        relations: ``ra/5`` rectangle relations of near pairs per frame, and ``front/3``,
            their depth order (``relations.pair_front``, as the tracker's occlusion facts).
        motion: ``motion/3`` qualitative motion of visible boxes.
        corridor: ``in_corridor/2`` (needs ``image_size``; uses ``context.corridor``).
        context: :class:`~sensemaking.reasoning.context.SceneContext` (corridor, lanes);
            default: the default corridor, no lanes.
        relation_config, motion_thresholds: see :mod:`sensemaking.reasoning.relations`.
    """
    states_names = STATE_NAMES
    ctx = context or SceneContext()
    out: list[Fact] = []
    fr = scene.frame_numbers.tolist()
    if fr:
        out.append(("scene_frames", fr[0], fr[-1]))
        out += [("frame", f) for f in fr]
    out.append(("fps", int(round(scene.fps))))
    if scene.image_size is not None:
        out.append(("image", int(scene.image_size[0]), int(scene.image_size[1])))
    for t in scene.tracks.values():
        out += [
            ("track", t.id, asp_name(t.class_name)),
            ("first_frame", t.id, t.first),
            ("last_frame", t.id, t.last),
        ]
    if boxes:
        for t in scene.tracks.values():
            out += [
                ("box", t.id, f, *b)
                for f, b in zip(
                    t.frames.tolist(), np.rint(t.xyxy).astype(np.int64).tolist(), strict=True
                )
            ]
    if states:
        for t in scene.tracks.values():
            out += [
                ("state", t.id, f, states_names[s])
                for f, s in zip(t.frames.tolist(), t.state.tolist(), strict=True)
            ]
    out += [("occurs_at", (e.name, *e.args), e.frame) for e in scene.events]
    out += [
        ("holds_during", (fl.fluent, *fl.args), fl.value, fl.start, fl.end) for fl in scene.fluents
    ]
    if relations or (corridor and scene.image_size is not None):
        ts = list(scene.tracks.values())
        frames = np.concatenate([t.frames for t in ts]) if ts else np.zeros(0, np.int64)
        tracks = (
            np.concatenate([np.full(len(t), t.id, dtype=np.int64) for t in ts]) if ts else frames
        )
        xyxy = np.concatenate([t.xyxy for t in ts]) if ts else np.zeros((0, 4))
        if corridor and scene.image_size is not None and frames.size:
            inside = ctx.corridor.contains_boxes(xyxy, scene.image_size)
            out += [
                ("in_corridor", t, f)
                for t, f in zip(tracks[inside].tolist(), frames[inside].tolist(), strict=True)
            ]
        if relations and frames.size:
            rc = relation_config or RelationConfig()
            order = np.argsort(frames, kind="stable")
            for chunk in np.split(order, np.flatnonzero(np.diff(frames[order])) + 1):
                if chunk.size >= 2:
                    pairs, codes = pair_relations(xyxy[chunk], rc)
                    front = pair_front(xyxy[chunk], pairs, image_size=scene.image_size, config=rc)
                    out += relation_facts(
                        int(frames[chunk[0]]), tracks[chunk], pairs, codes, front
                    )
    if motion:
        mt = motion_thresholds or MotionThresholds()
        for t in scene.tracks.values():
            vis = t.visible_mask()
            got, kinds, _ = track_motion(t.frames[vis], t.xyxy[vis], scene.fps, mt)
            for f, k in zip(got.tolist(), kinds, strict=True):
                out += motion_facts(f, np.array([t.id]), k[None, :])
    return out


def scene_facts_text(scene: Scene, **kw: Any) -> str:
    """The scene's facts (:func:`scene_facts`, same options) as program text, one a line."""
    return facts_text(scene_facts(scene, **kw))


def facts_text(facts: Iterable[Fact]) -> str:
    """Facts as program text, one a line, each written by clingo from its symbol."""
    return "".join(f"{symbol(f)}.\n" for f in facts)
