"""How sure each hiding is: ``confidence.lp`` solved over the hidings a frame's optimum chose.

The confidence is reported, never optimised, so it stays out of the frame's problem: the cover
shares and depth orders it reads would enlarge every frame's ground program, the slot
Controls' universes and the answer cache's keys (MOT17-04: 1.3x the time, 1.4x the memory;
docs/DESIGN-NOTES.md). After the frame is solved, each hiding event of the answer becomes a
handful of facts (the hiding, whether it is late, its occluder's cover share and depth order)
and ``confidence.lp`` says its confidence. A hiding's confidence depends on those facts only,
so the answer for each distinct set of them is remembered: a sequence runs the program a few
dozen times at most, and a cached frame answer gets the confidence a solved one gets.
"""

from __future__ import annotations

from collections.abc import Mapping

from clingo import Function, Number, Symbol, SymbolType

from sensemaking import asp
from sensemaking.abduction.problem import FrameProblem
from sensemaking.abduction.solver import Answer, Det, Ref, grounded, load_encoding

__all__ = ["HideConfidence", "HIDE_EVENTS", "CONFIDENCE_CONSTANTS"]

#: the events that say a hiding (tracking.lp's said_hide/3): ``name(T, O)``
HIDE_EVENTS = frozenset({"hides_behind", "may_hide_behind"})
#: the tracker's parameters that are constants of ``confidence.lp``
CONFIDENCE_CONSTANTS = ("late_confidence", "depth_clear", "depth_confidence")

#: one hiding in canonical form: event name, late, ``(share, depth)`` per covering detection
_Hiding = tuple[str, bool, tuple[tuple[int, int], ...]]
_T, _O = Number(1), Number(2)  # the hidden track and its occluder in the canonical facts


class HideConfidence:
    """The confidence (0..1000) of the hidings of a frame's answer, by ``confidence.lp``.

    Args:
        constants: values of the program's ``#const`` (e.g. ``{"late_confidence": 500}``).
        program: the rules (default: the packaged ``confidence.lp``); they read the facts
            documented there and show ``confidence(E,C)``.
    """

    def __init__(self, constants: Mapping[str, int] | None = None, program: str | None = None):
        self.program = program if program is not None else load_encoding("confidence.lp")
        #: the program's texts (one), as the sandbox's check of a user's program reads them
        self.texts = (self.program,)
        #: ground atoms one hiding's program may have (set for a user's program)
        self.max_atoms: int | None = None
        consts = {k: int(v) for k, v in (constants or {}).items()}
        self.options = ["--warn=none"] + [f"-c{k}={v}" for k, v in sorted(consts.items())]
        self._memo: dict[_Hiding, int | None] = {}
        #: clingo calls made (distinct hidings met)
        self.calls = 0

    def levels(
        self, problem: FrameProblem, answer: Answer
    ) -> dict[tuple[str, tuple[Ref, ...]], int]:
        """``(event name, args) -> confidence`` of each hiding event of ``answer`` (the frame's
        terms: track ids, :class:`Det` rows), read off ``problem``'s cover pairs."""
        hidings = [(n, a) for n, a in answer.events if n in HIDE_EVENTS and len(a) == 2]
        if not hidings:
            return {}
        index = {t: i for i, t in enumerate(problem.track_id.tolist())}
        late = set(answer.ignore_trk)
        cover: dict[tuple[int, int], list[tuple[int, int]]] = {}
        rows = zip(
            problem.covers.tolist(),
            problem.cover_shares().tolist(),
            problem.cover_depths().tolist(),
            strict=True,
        )
        for (d, t), share, depth in rows:
            cover.setdefault((d, t), []).append((share, depth))
        out: dict[tuple[str, tuple[Ref, ...]], int] = {}
        for name, (hidden, occluder) in hidings:
            row = _observed_as(occluder, answer)
            t = index.get(hidden) if isinstance(hidden, int) else None
            if row is None or t is None:
                continue
            level = self.level(name, hidden in late, tuple(sorted(cover.get((row, t), ()))))
            if level is not None:
                out[(name, (hidden, occluder))] = level
        return out

    def level(self, name: str, late: bool, covers: tuple[tuple[int, int], ...]) -> int | None:
        """The confidence of one hiding said by the event ``name``: ``late`` (the track was
        already unobserved), ``covers`` the ``(share, depth)`` of its occluder's detection
        (per mille); None where the program shows none."""
        key = (name, late, covers)
        if key not in self._memo:
            self._memo[key] = self._solve(key)
        return self._memo[key]

    def _solve(self, hiding: _Hiding) -> int | None:
        name, late, covers = hiding
        facts: list[Symbol] = [
            Function("hide", [_T, _O]),
            Function("said_hide", [Function(name, [_T, _O]), _T, _O]),
        ]
        if late:
            facts.append(Function("late_hide", [_T, _O]))
        for share, depth in covers:
            facts.append(Function("occluder_share", [_T, _O, Number(share)]))
            facts.append(Function("occluder_depth", [_T, _O, Number(depth)]))
        ctl = grounded(self.options, self.program, facts, "the confidence rules", self.max_atoms)
        found, _ = asp.models(ctl, first=True)
        self.calls += 1
        for atom in found[0] if found else ():
            args = atom.arguments
            if atom.name == "confidence" and len(args) == 2 and args[1].type == SymbolType.Number:
                return int(args[1].number)
        return None


def _observed_as(occluder: Ref, answer: Answer) -> int | None:
    """The detection row the occluder is seen as this frame: a track's match (a revived
    track's too: ``resume``), or the detection that starts it."""
    if isinstance(occluder, Det):
        return occluder.row
    if isinstance(occluder, int):
        found = answer.assign.get(occluder)
        return answer.resume.get(occluder) if found is None else found
    return None
