"""The event and warning records: the one place their JSON layout is written and read.

An **event record** is one line of ``track --events`` and one entry of a scene's ``"events"``::

    {"frame": 12, "event": "hides_behind", "args": [7, 3], "confidence": 0.85}

(``confidence``, 0..1, only on events whose encoding states one: ``hides_behind`` and
``may_hide_behind``.)

A **warning record** (:func:`warning_record`) is ``{"frame", "situation", "objects", "message",
"details"}``; the warnings file of ``track --warnings`` is a stream of episodes, two records
each: a **start record** (:func:`start_record`: ``record``, ``episode``, ``severity``,
``lane_position`` and, where the situation states one, ``confidence`` (0..1) before the warning
record's keys) when the situation starts to hold, and an
**end record** (:func:`end_record`) once it has stopped holding or the input ended::

    {"record": "start", "episode": 3, "severity": 3, "lane_position": "ego", "frame": 120,
     "situation": "HIDDEN_ENTITY", "objects": [7, 2], "message": "...", "details": {...}}
    {"record": "end", "episode": 3, "frame": 137, "situation": "HIDDEN_ENTITY",
     "objects": [7, 2], "start_frame": 120, "last_frame": 134, "frames": 15, "reason": "cleared"}

Files of these records are JSON lines (:func:`json_line` writes one); :func:`read_events` and
:func:`read_warnings` read them with one rule, an :class:`~sensemaking.errors.InputError` naming
the file and line for a bad record.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping
from os import PathLike
from pathlib import Path
from typing import Any, Protocol

from sensemaking.errors import TOO_DEEP, InputError
from sensemaking.io.text import load_json, read_input_text
from sensemaking.results import Event
from sensemaking.vocabulary import EVENT_NAMES

__all__ = [
    "event_record",
    "event_from_record",
    "warning_record",
    "warning_fields",
    "start_record",
    "end_record",
    "json_line",
    "read_json_lines",
    "read_events",
    "read_warnings",
    "warning_starts",
    "judged_warnings",
]


class WarningLike(Protocol):
    """What a warning record is made of
    (:class:`~sensemaking.reasoning.situations.SituationWarning`)."""

    @property
    def frame(self) -> int: ...
    @property
    def situation(self) -> str: ...
    @property
    def objects(self) -> tuple[int, ...]: ...
    @property
    def message(self) -> str: ...
    @property
    def details(self) -> dict[str, Any]: ...


class WarningEndLike(Protocol):
    """What an end record is made of (:class:`~sensemaking.reasoning.online.WarningEnd`)."""

    @property
    def frame(self) -> int: ...
    @property
    def situation(self) -> str: ...
    @property
    def objects(self) -> tuple[int, ...]: ...
    @property
    def episode(self) -> int: ...
    @property
    def start_frame(self) -> int: ...
    @property
    def last_frame(self) -> int: ...
    @property
    def reason(self) -> str: ...


# -- events -------------------------------------------------------------------------------------
def event_record(e: Event) -> dict[str, Any]:
    """The record ``{"frame": ..., "event": ..., "args": [...]}`` of an event, with
    ``"confidence"`` (0..1) where the encoding states one (the hiding events)."""
    out: dict[str, Any] = {
        "frame": int(e.frame),
        "event": e.name,
        "args": [a if isinstance(a, str) else int(a) for a in e.args],
    }
    if e.confidence is not None:
        out["confidence"] = round(float(e.confidence), 3)
    return out


def event_from_record(record: Mapping[str, Any]) -> Event:
    """The event of a record (inverse of :func:`event_record`). Raises KeyError, TypeError or
    ValueError on a malformed record."""
    level = record.get("confidence")
    return Event(
        int(record["frame"]),
        str(record["event"]),
        tuple(a if isinstance(a, str) else int(a) for a in record["args"]),
        None if level is None else float(level),
    )


# -- warnings -----------------------------------------------------------------------------------
def warning_record(w: WarningLike) -> dict[str, Any]:
    """The record ``{"frame", "situation", "objects", "message", "details"}`` of a warning."""
    return {
        "frame": int(w.frame),
        "situation": w.situation,
        "objects": [int(o) for o in w.objects],
        "message": w.message,
        "details": w.details,
    }


def warning_fields(
    record: Mapping[str, Any],
) -> tuple[int, str, tuple[int, ...], str, dict[str, Any]]:
    """``(frame, situation, objects, message, details)`` of a warning record (inverse of
    :func:`warning_record`)."""
    return (
        int(record["frame"]),
        str(record["situation"]),
        tuple(int(o) for o in record["objects"]),
        str(record["message"]),
        dict(record.get("details") or {}),
    )


def start_record(w: WarningLike) -> dict[str, Any]:
    """The start record of a warning episode: the warning's record with ``record``,
    ``episode``, ``severity``, ``lane_position`` and ``confidence`` (only where its details
    have one) from its details at its top."""
    d = w.details
    return {
        "record": "start",
        "episode": d.get("episode"),
        "severity": d.get("severity"),
        "lane_position": d.get("lane_position", "unknown"),
        # how sure the warning is, 0..1, where its situation says (HIDDEN_ENTITY: its hiding)
        **({"confidence": d["confidence"]} if "confidence" in d else {}),
        **warning_record(w),
    }


def end_record(e: WarningEndLike) -> dict[str, Any]:
    """The end record of a warning episode."""
    return {
        "record": "end",
        "episode": e.episode,
        "frame": e.frame,
        "situation": e.situation,
        "objects": list(e.objects),
        "start_frame": e.start_frame,
        "last_frame": e.last_frame,
        "frames": e.last_frame - e.start_frame + 1,
        "reason": e.reason,
    }


# -- files --------------------------------------------------------------------------------------
def json_line(record: Mapping[str, Any]) -> str:
    """One line of a JSON-lines file of records."""
    return json.dumps(record) + "\n"


def read_json_lines(path: str | PathLike[str]) -> list[dict[str, Any]]:
    """Records of a JSON-lines file, each with its line number as ``_line`` (blank lines
    skipped). Raises :class:`~sensemaking.errors.InputError` naming the file and line."""
    p = Path(path)
    try:
        text = read_input_text(p)
    except FileNotFoundError:
        raise InputError("no such file", p) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read: {exc}", p) from None
    out = []
    for lineno, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        try:
            record = load_json(line)
        except json.JSONDecodeError as exc:
            raise InputError(f"not JSON: {exc.msg}", p, lineno) from None
        except RecursionError:
            raise InputError(TOO_DEEP, p, lineno) from None
        if not isinstance(record, dict):
            raise InputError("expected a JSON object per line", p, lineno)
        out.append({**record, "_line": lineno})
    return out


def read_events(path: str | PathLike[str]) -> list[Event]:
    """The event log of ``track --events``. Raises :class:`~sensemaking.errors.InputError`
    naming the file and line of a malformed record, or of a built-in event with the wrong
    number of arguments."""
    out = []
    for r in read_json_lines(path):
        try:
            ev = event_from_record(r)
        except (KeyError, TypeError, ValueError, OverflowError):  # 1e400 reads as inf
            raise InputError(
                'expected {"frame": int, "event": name, "args": [track ids]}', path, r["_line"]
            ) from None
        if ev.name in EVENT_NAMES and len(ev.args) != EVENT_NAMES[ev.name]:
            raise InputError(
                f"{ev.name} takes {EVENT_NAMES[ev.name]} argument(s), got {len(ev.args)}",
                path,
                r["_line"],
            )
        out.append(ev)
    return out


def read_warnings(path: str | PathLike[str]) -> list[dict[str, Any]]:
    """The records of ``track --warnings``, start and end records alike. Every record needs an
    integer ``frame``, a list of integer track ids as ``objects`` and, if present, an object as
    ``details``. Raises
    :class:`~sensemaking.errors.InputError` naming the file and line."""
    out = []
    for r in read_json_lines(path):
        objs = r.get("objects")
        ok = (
            isinstance(r.get("frame"), int)
            and isinstance(objs, list)
            and all(isinstance(o, int) for o in objs)
            and isinstance(r.get("details", {}), dict)
        )
        if not ok:
            raise InputError(
                'expected {"frame": int, "situation": name, "objects": [track ids], '
                '"details": {...}}',
                path,
                r["_line"],
            )
        out.append({k: v for k, v in r.items() if k != "_line"})
    return out


def warning_starts(records: Iterable[Mapping[str, Any]]) -> list[Mapping[str, Any]]:
    """The records that issue a warning, in the order given: the end records of episodes left
    out (a warning is drawn and judged where it starts)."""
    return [w for w in records if w.get("record") != "end"]


def judged_warnings(records: Iterable[Mapping[str, Any]]) -> list[Mapping[str, Any]]:
    """The warning records the evaluator judges: :func:`warning_starts` with objects (a record
    without objects is a notice that a situation was not checked, no warning)."""
    return [w for w in warning_starts(records) if w.get("objects")]
