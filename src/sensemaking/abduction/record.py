"""The abduction problems behind a scene's events, kept to ask them again ("why not ...?").

A scene (``sensemaking track --scene``) stores, for every event of its log, the facts of the
part of the frame (:class:`~sensemaking.abduction.problem.Component`) from which the tracker
abduced it, with the encoding's constants and work budget. Solving those facts again gives the
tracker's answer (the solver is deterministic); solving them with the event forbidden gives the
next-best explanation and its cost (:meth:`AbductionSolver.alternatives_facts`). Python reads
clingo's answers and costs; the rules stay in ``tracking.lp``.

Only runs of the packaged encoding are recorded: the scene file then names no program, only
integer constants, so asking a scene from elsewhere runs no code of its own.

JSON (the scene's ``"abduction"`` entry)::

    {"encoding": "tracking.lp", "constants": {"cost_hides": 50, ...}, "max_conflicts": 100000,
     "problems": [{"frame": 12,
                   "tracks": [3, 7],        # local track i is track id tracks[i]
                   "dets": [-1, 9],         # local detection j started track dets[j] (or -1)
                   "facts": ["track(0)", "active(0)", "cand(1,d(0),800)", ...]}]}
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import clingo
from clingo import Symbol, SymbolType

from sensemaking.abduction.solver import (
    AbductionSolver,
    Alternatives,
    Det,
    Ref,
    load_encoding,
)
from sensemaking.errors import InputError
from sensemaking.results import Event, FrameAbduction
from sensemaking.vocabulary import REVIVE_EVENTS, START_EVENTS

__all__ = [
    "ProblemRecord",
    "AbductionRecord",
    "problems_of_frame",
    "problem_from_json",
    "recorded_constants",
    "keep_named",
    "named_here",
    "START_EVENTS",
]

PACKAGED = "tracking.lp"
_NAME = re.compile(r"[a-z_][A-Za-z0-9_]*")
# the facts the tracker writes, nested once (``cand(2,d(2),600)``): a strict subset of what
# clingo parses as a ground atom named by _NAME, checked in one regex call; anything else is
# left to clingo's parser
_ID = r"(?!not(?![A-Za-z0-9_]))[a-z][A-Za-z0-9_]*"
_ATOMIC = rf"(?:{_ID}|0|-?[1-9][0-9]{{0,8}})"
_ARG = rf"(?:{_ID}\({_ATOMIC}(?:,{_ATOMIC})*\)|{_ATOMIC})"
_PLAIN_FACT = re.compile(rf"{_ID}(?:\({_ARG}(?:,{_ARG})*\))?")


@dataclass(frozen=True)
class ProblemRecord:
    """One component of one frame: its facts (local terms) and what its numbers name.

    Attributes:
        frame: the frame number.
        tracks: local track ``i`` is track id ``tracks[i]`` (its own tracks, then occluders
            outside it that its ``hidden_by`` facts name).
        n_tracks: how many of ``tracks`` are the component's own.
        dets: local detection ``j`` started track id ``dets[j]``, or -1.
        facts: the facts as clingo terms (text).
    """

    frame: int
    tracks: tuple[int, ...]
    n_tracks: int
    dets: tuple[int, ...]
    facts: tuple[str, ...]

    def local(self, track_id: int) -> Ref | None:
        """The local name of a track: its number, ``Det(j)`` if it started here, else None."""
        if track_id in self.tracks:
            return self.tracks.index(track_id)
        if track_id in self.dets:
            return Det(self.dets.index(track_id))
        return None

    def owns(self, track_id: int) -> bool:
        """The track is one of the component's own tracks, started here, or an ended track
        that may be revived here (``gone/2``)."""
        return (
            track_id in self.tracks[: self.n_tracks]
            or track_id in self.dets
            or self.revives(track_id)
        )

    def revives(self, track_id: int) -> bool:
        """The track is an ended track that may be revived here (a ``gone/2`` fact)."""
        if track_id not in self.tracks[self.n_tracks :]:
            return False
        prefix = f"gone({self.tracks.index(track_id)},"
        return any(f.startswith(prefix) for f in self.facts)

    def global_ref(self, x: Ref) -> Ref:
        """A local name as a track id (a detection that started no track stays ``Det``)."""
        if isinstance(x, Det):
            tid = self.dets[x.row] if 0 <= x.row < len(self.dets) else -1
            return tid if tid >= 0 else x
        if isinstance(x, int) and 0 <= x < len(self.tracks):
            return self.tracks[x]
        return x

    def symbols(self, where: str | None = None) -> list[Symbol]:
        """The facts as clingo symbols; raises InputError on one that is not a plain fact."""
        out = []
        for i, text in enumerate(self.facts):
            try:
                sym = clingo.parse_term(text, logger=_quiet)
            except RuntimeError:
                sym = None
            if sym is None or sym.type != SymbolType.Function or not _NAME.fullmatch(sym.name):
                raise InputError(
                    f"malformed scene: abduction problem of frame {self.frame}: fact {i} "
                    f"{text[:60]!r} is not a ground atom",
                    where,
                )
            out.append(sym)
        return out

    def check(self, where: str | None = None) -> None:
        """Raise :meth:`symbols`' InputError if a fact is not a ground atom, without making the
        symbols (the facts the tracker writes pass a regular expression; others are parsed)."""
        if not all(_PLAIN_FACT.fullmatch(text) for text in self.facts):
            self.symbols(where)

    def to_json(self) -> dict[str, Any]:
        return {
            "frame": self.frame,
            "tracks": list(self.tracks),
            "own": self.n_tracks,
            "dets": list(self.dets),
            "facts": list(self.facts),
        }


@dataclass
class AbductionRecord:
    """The encoding's constants and work budget, and the problems recorded (see module doc)."""

    constants: dict[str, int]
    max_conflicts: int | None
    problems: list[ProblemRecord] = field(default_factory=list)

    def solver(self) -> AbductionSolver:
        """The packaged encoding with the recorded constants and budget."""
        return AbductionSolver(constants=self.constants, max_conflicts=self.max_conflicts)

    def problem_of(self, event: Event) -> ProblemRecord | None:
        """The recorded problem the event was abduced from: for the start of a track, the one
        where its detection started it (at or before the event's frame); otherwise the one of
        the event's frame that holds its subject."""
        subject = event.args[0] if event.args else None
        if not isinstance(subject, int):
            return None
        if event.name in START_EVENTS:
            found = [p for p in self.problems if p.frame <= event.frame and subject in p.dets]
            return found[-1] if found else None
        if event.name in REVIVE_EVENTS:  # reported when confirmed again, like a start
            found = [p for p in self.problems if p.frame <= event.frame and p.revives(subject)]
            return found[-1] if found else None
        return next((p for p in self.problems if p.frame == event.frame and p.owns(subject)), None)

    def alternatives(
        self, event: Event, k: int = 3, where: str | None = None
    ) -> tuple[ProblemRecord, Alternatives] | None:
        """The event's next-best explanations (:meth:`AbductionSolver.alternatives_facts`) in
        track ids; None when no problem of the event was recorded."""
        problem = self.problem_of(event)
        if problem is None:
            return None
        local: list[Ref] = []
        for a in event.args:
            ref = problem.local(a) if isinstance(a, int) else a
            if ref is None:
                return None
            local.append(ref)
        found = self.solver().alternatives_facts(
            problem.symbols(where), (event.name, tuple(local)), k
        )
        return problem, found

    def to_json(self) -> dict[str, Any]:
        return {
            "encoding": PACKAGED,
            "constants": dict(sorted(self.constants.items())),
            "max_conflicts": self.max_conflicts,
            "problems": [p.to_json() for p in self.problems],
        }

    @classmethod
    def from_json(cls, record: Any, where: str | None = None) -> AbductionRecord:
        """Read and check the ``"abduction"`` entry: every fact must parse as a ground atom."""
        bad = partial(_malformed, where=where)
        if not isinstance(record, Mapping):
            raise bad("must be an object")
        if record.get("encoding", PACKAGED) != PACKAGED:
            raise bad(f"only the packaged encoding is read, got {record.get('encoding')!r}")
        constants = record.get("constants", {})
        if not isinstance(constants, Mapping) or not all(
            isinstance(k, str) and _NAME.fullmatch(k) and _is_int(v) and abs(v) < 2**31
            for k, v in constants.items()
        ):
            raise bad("'constants' must map names to integers")
        budget = record.get("max_conflicts")
        if budget is not None and not (_is_int(budget) and 0 < budget < 2**31):
            raise bad("'max_conflicts' must be null or a positive integer")
        raw = record.get("problems", [])
        if not isinstance(raw, list):
            raise bad("'problems' must be a list")
        problems = [
            # a ProblemRecord: read and checked already, as the scene file was parsed
            p if isinstance(p, ProblemRecord) else problem_from_json(p, i, where)
            for i, p in enumerate(raw)
        ]
        return cls({str(k): int(v) for k, v in constants.items()}, budget, problems)


def _malformed(problem: str, where: str | None) -> InputError:
    """The error of an ``"abduction"`` entry that is not as written by the tracker."""
    return InputError(f"malformed scene: abduction: {problem}", where)


def problem_from_json(p: Any, i: int, where: str | None = None) -> ProblemRecord:
    """Entry ``i`` of the ``"problems"`` list, checked: every fact must parse as a ground atom.
    Raises InputError naming ``where``."""
    bad = partial(_malformed, where=where)
    if not isinstance(p, Mapping):
        raise bad(f"problems[{i}] must be an object")
    tracks, dets, facts = p.get("tracks"), p.get("dets"), p.get("facts")
    frame, own = p.get("frame"), p.get("own")
    if not (
        isinstance(frame, int)
        and _is_int(frame)
        and _int_list(tracks)
        and _int_list(dets)
        and isinstance(own, int)
        and isinstance(tracks, list)
        and isinstance(dets, list)
        and 0 <= own <= len(tracks)
        and isinstance(facts, list)
        and all(isinstance(x, str) for x in facts)
    ):
        raise bad(f"problems[{i}] must have frame, tracks, own, dets and facts")
    problem = ProblemRecord(int(frame), tuple(tracks), int(own), tuple(dets), tuple(facts))
    problem.check(where)  # every fact a ground atom, checked while the file is known
    return problem


def problems_of_frame(
    frame: int, abduction: FrameAbduction, events: Sequence[Event]
) -> list[ProblemRecord]:
    """The components of a frame worth recording: those holding the subject of one of
    ``events`` (this frame's, in track ids) or a detection that started (or revived) a track.
    Empty when the frame was not solved by the packaged encoding."""
    solver = abduction.solver
    if solver.program != load_encoding():
        return []
    subjects = {e.args[0] for e in events if e.args and isinstance(e.args[0], int)}
    started = abduction.new_tracks
    out = []
    for component, track_ids, det_rows in abduction.problem.components():
        own = len(component.tracks)
        dets = tuple(started.get(r, -1) for r in det_rows)
        if not (any(d >= 0 for d in dets) or subjects.intersection(track_ids[:own])):
            continue
        out.append(
            ProblemRecord(
                frame=int(frame),
                tracks=tuple(track_ids),
                n_tracks=own,
                dets=dets,
                facts=tuple(str(s) for s in component.facts(solver.uses)),
            )
        )
    return out


def recorded_constants(solver: AbductionSolver) -> tuple[dict[str, int], int | None]:
    """The constants and ``max_conflicts`` of a solver, as a record stores them."""
    budget = None
    for option in solver.options:
        if option.startswith("--solve-limit="):
            budget = int(option.split("=", 1)[1].split(",")[0])
    return dict(solver.constants), budget


def named_here(problem: ProblemRecord, events: Iterable[Event]) -> bool:
    """One of the problem's own tracks (or ended tracks it revives) is the subject of one of
    ``events`` of its frame."""
    own = set(problem.tracks[: problem.n_tracks])
    subjects = {e.args[0] for e in events if e.frame == problem.frame and e.args}
    return any(isinstance(t, int) and (t in own or problem.revives(t)) for t in subjects)


def keep_named(
    problems: Iterable[ProblemRecord], events: Iterable[Event], tracks: Iterable[int]
) -> list[ProblemRecord]:
    """The problems some event needs: its frame's, holding its subject, or where one of the
    scene's tracks started (a tentative track dropped unconfirmed needs none)."""
    kept_tracks = set(tracks)
    by_frame: dict[int, list[Event]] = {}
    for e in events:
        by_frame.setdefault(e.frame, []).append(e)
    return [
        p
        for p in problems
        if any(d in kept_tracks for d in p.dets if d >= 0)
        or named_here(p, by_frame.get(p.frame, ()))
    ]


def _quiet(code: clingo.MessageCode, message: str) -> None:
    """clingo's parser messages: the InputError says what is wrong (nothing on stderr)."""


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _int_list(v: Any) -> bool:
    return isinstance(v, list) and all(_is_int(x) and -1 <= x < 2**53 for x in v)
