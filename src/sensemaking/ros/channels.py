"""The channels written to MCAP and served live: what a frame's result becomes, as JSON
messages with JSON schemas (Foxglove draws ``foxglove.*`` schemas by name; the
``sensemaking.*`` ones are exact records for programs). Needs no dependency.

========================== ========================== =========================================
topic                      schema                     one message per
========================== ========================== =========================================
/sensemaking/tracks        sensemaking.Tracks         stepped frame: every live track (visible,
                                                      hidden and missing at predicted boxes)
/sensemaking/annotations   foxglove.ImageAnnotations  stepped frame: boxes, ids, events, warnings
/sensemaking/events        sensemaking.Event          event (the ``--events`` JSON-lines record)
/sensemaking/warnings      sensemaking.Warning        warning start or end (``--warnings`` record)
/sensemaking/log           foxglove.Log               event (INFO) and warning (WARNING / end);
                                                      at the end each track's story (INFO)
/sensemaking/stories       sensemaking.Story          track, at the end of the run: its story
                                                      (the text of ``sensemaking explain``)
========================== ========================== =========================================

Every message is stamped with its frame's time (the input's header stamp); a story with its
track's last frame's time.
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from sensemaking.classes import class_name
from sensemaking.records import end_record, event_record, start_record
from sensemaking.results import FrameResult, TrackState

__all__ = [
    "Channel",
    "CHANNELS",
    "encode_frame",
    "encode_ends",
    "RunStories",
    "STATE_NAMES",
]

STATE_NAMES = {int(s): s.name.lower() for s in TrackState}

_TIME = {
    "type": "object",
    "title": "time",
    "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}},
}
_POINT = {"type": "object", "properties": {"x": {"type": "number"}, "y": {"type": "number"}}}
_COLOR = {
    "type": "object",
    "properties": {k: {"type": "number"} for k in ("r", "g", "b", "a")},
}
_NUM, _INT, _STR = {"type": "number"}, {"type": "integer"}, {"type": "string"}

TRACKS_SCHEMA = {
    "title": "sensemaking.Tracks",
    "description": "Every live track of a frame: boxes in pixels (x1, y1, x2, y2)",
    "type": "object",
    "properties": {
        "timestamp": _TIME,
        "frame": _INT,
        "tracks": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {
                    "id": _INT,
                    "class_id": _INT,
                    "class": _STR,
                    "state": {"type": "string", "enum": list(STATE_NAMES.values())},
                    "x1": _NUM,
                    "y1": _NUM,
                    "x2": _NUM,
                    "y2": _NUM,
                    "confidence": _NUM,
                    "occluder": _INT,
                    "hidden_frames": _INT,
                },
            },
        },
    },
}
EVENT_SCHEMA = {
    "title": "sensemaking.Event",
    "description": "An abduced event, as a record of `sensemaking track --events`",
    "type": "object",
    "properties": {
        "timestamp": _TIME,
        "frame": _INT,
        "event": _STR,
        "args": {"type": "array", "items": {"type": ["integer", "string"]}},
    },
}
WARNING_SCHEMA = {
    "title": "sensemaking.Warning",
    "description": "A warning episode's start or end, as a record of `sensemaking track "
    "--warnings` (docs/SITUATIONS.md)",
    "type": "object",
    "properties": {
        "timestamp": _TIME,
        "record": {"type": "string", "enum": ["start", "end"]},
        "episode": _INT,
        "frame": _INT,
        "situation": _STR,
        "objects": {"type": "array", "items": _INT},
        "message": _STR,
    },
}
STORY_SCHEMA = {
    "title": "sensemaking.Story",
    "description": "A track's story at the end of the run: the text `sensemaking explain "
    "--track ID` prints for the run's scene, and its sentences",
    "type": "object",
    "properties": {
        "timestamp": _TIME,
        "track": _INT,
        "class_id": _INT,
        "class": _STR,
        "first_frame": _INT,
        "last_frame": _INT,
        "text": _STR,
        "sentences": {"type": "array", "items": _STR},
    },
}
LOG_SCHEMA = {
    "title": "foxglove.Log",
    "type": "object",
    "properties": {
        "timestamp": _TIME,
        "level": {"type": "integer", "description": "1 debug, 2 info, 3 warning, 4 error"},
        "message": _STR,
        "name": _STR,
        "file": _STR,
        "line": _INT,
    },
}
ANNOTATIONS_SCHEMA = {
    "title": "foxglove.ImageAnnotations",
    "type": "object",
    "properties": {
        "circles": {"type": "array", "items": {"type": "object"}},
        "points": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {
                    "timestamp": _TIME,
                    "type": {"type": "integer", "description": "2 = LINE_LOOP"},
                    "points": {"type": "array", "items": _POINT},
                    "outline_color": _COLOR,
                    "outline_colors": {"type": "array", "items": _COLOR},
                    "fill_color": _COLOR,
                    "thickness": _NUM,
                },
            },
        },
        "texts": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {
                    "timestamp": _TIME,
                    "position": _POINT,
                    "text": _STR,
                    "font_size": _NUM,
                    "text_color": _COLOR,
                    "background_color": _COLOR,
                },
            },
        },
    },
}


@dataclass(frozen=True)
class Channel:
    """A channel: ``topic``, ``schema_name`` and its JSON schema (messages are JSON)."""

    topic: str
    schema_name: str
    schema: dict[str, Any]

    def schema_bytes(self) -> bytes:
        return json.dumps(self.schema, separators=(",", ":")).encode()


TRACKS = Channel("/sensemaking/tracks", "sensemaking.Tracks", TRACKS_SCHEMA)
ANNOTATIONS = Channel("/sensemaking/annotations", "foxglove.ImageAnnotations", ANNOTATIONS_SCHEMA)
EVENTS = Channel("/sensemaking/events", "sensemaking.Event", EVENT_SCHEMA)
WARNINGS = Channel("/sensemaking/warnings", "sensemaking.Warning", WARNING_SCHEMA)
LOG = Channel("/sensemaking/log", "foxglove.Log", LOG_SCHEMA)
STORIES = Channel("/sensemaking/stories", "sensemaking.Story", STORY_SCHEMA)
CHANNELS = (TRACKS, ANNOTATIONS, EVENTS, WARNINGS, LOG, STORIES)

LOG_INFO, LOG_WARNING = 2, 3
_LINE_LOOP = 2
_WHITE = {"r": 1.0, "g": 1.0, "b": 1.0, "a": 1.0}
_SHADE = {"r": 0.0, "g": 0.0, "b": 0.0, "a": 0.6}
_WARN = {"r": 1.0, "g": 0.25, "b": 0.1, "a": 1.0}
_NONE = {"r": 0.0, "g": 0.0, "b": 0.0, "a": 0.0}


def _color(track_id: int, alpha: float) -> dict[str, float]:
    """A steady colour per id (golden-ratio hues), for telling tracks apart."""
    import colorsys

    r, g, b = colorsys.hsv_to_rgb((track_id * 0.618033988749895) % 1.0, 0.8, 1.0)
    return {"r": round(r, 3), "g": round(g, 3), "b": round(b, 3), "a": alpha}


def _dump(obj: Any) -> bytes:
    return json.dumps(obj, separators=(",", ":")).encode()


def _time(ns: int) -> dict[str, int]:
    sec, nsec = divmod(int(ns), 1_000_000_000)
    return {"sec": sec, "nsec": nsec}


@functools.lru_cache(maxsize=4096)
def _colors(track_id: int) -> tuple[str, str]:
    """(colour JSON of a visible box, of a hidden one) of a track id."""
    return json.dumps(_color(track_id, 1.0)), json.dumps(_color(track_id, 0.5))


@functools.lru_cache(maxsize=256)
def _class_json(cid: int) -> str:
    return json.dumps(class_name(cid))


_SHADE_JSON = json.dumps(_SHADE)
_NONE_JSON = json.dumps(_NONE)


def encode_frame(
    result: FrameResult, warnings: Sequence[Any], t_ns: int
) -> list[tuple[Channel, bytes]]:
    """The messages of one stepped frame at time ``t_ns``: its tracks, annotations, events
    (each also a log line) and warning starts (``warnings`` with objects, as the warnings file
    keeps them). The per-track JSON is assembled from cached pieces (json.dumps of nested
    dicts cost as much as the tracking of a frame)."""
    stamp = _time(t_ns)
    ts = f'{{"sec":{stamp["sec"]},"nsec":{stamp["nsec"]}}}'
    tr = result.tracks
    n = len(tr)
    state = tr.data.get("state", np.zeros(n, dtype=np.int64)).tolist()
    occluder = tr.data.get("occluder", np.full(n, -1, dtype=np.int64)).tolist()
    hidden = tr.data.get("hidden_frames", np.zeros(n, dtype=np.int64)).tolist()
    ids = tr.tracker_id.tolist()
    boxes = tr.xyxy.tolist()
    classes = tr.class_id.tolist()
    conf = tr.confidence.tolist()
    rows, points, texts = [], [], []
    where = {}
    for i in range(n):
        tid, st = ids[i], int(state[i])
        x1, y1, x2, y2 = map(repr, boxes[i])  # each number formatted once, used thrice
        name = STATE_NAMES.get(st, str(st))
        c = repr(conf[i]) if math.isfinite(conf[i]) else "null"
        rows.append(
            f'{{"id":{tid},"class_id":{classes[i]},"class":{_class_json(classes[i])},'
            f'"state":"{name}","x1":{x1},"y1":{y1},"x2":{x2},"y2":{y2},'
            f'"confidence":{c},"occluder":{occluder[i]},"hidden_frames":{hidden[i]}}}'
        )
        seen = st == int(TrackState.VISIBLE)
        where[tid] = (boxes[i][0], boxes[i][3])
        solid, faint = _colors(tid)
        points.append(
            f'{{"timestamp":{ts},"type":{_LINE_LOOP},"points":[{{"x":{x1},"y":{y1}}},'
            f'{{"x":{x2},"y":{y1}}},{{"x":{x2},"y":{y2}}},{{"x":{x1},"y":{y2}}}],'
            f'"outline_color":{solid if seen else faint},"outline_colors":[],'
            f'"fill_color":{_NONE_JSON},"thickness":{"2.0" if seen else "1.0"}}}'
        )
        label = f"{tid} {class_name(classes[i])}" + ("" if seen else f" ({name})")
        texts.append(_text_json(ts, boxes[i][0], boxes[i][1], label, solid))
    body = ",".join(rows)
    out: list[tuple[Channel, bytes]] = [
        (TRACKS, f'{{"timestamp":{ts},"frame":{result.frame},"tracks":[{body}]}}'.encode())
    ]
    line = 0  # the top-left lines: warnings, then events of tracks not in the frame
    for w in warnings:
        if not getattr(w, "objects", None):
            continue  # a situation that could not be checked: a notice, not a warning
        record = start_record(w)
        out.append((WARNINGS, _dump({"timestamp": stamp, **record})))
        text = f"{record.get('situation')}: {record.get('message', '')}"
        out.append((LOG, _log(stamp, LOG_WARNING, text, "sensemaking.warnings")))
        texts.append(_text_json(ts, 8.0, 8.0 + 18.0 * line, "WARNING " + text, _WARN_JSON))
        line += 1
    for ev in result.events:
        record = event_record(ev)
        out.append((EVENTS, _dump({"timestamp": stamp, **record})))
        out.append((LOG, _log(stamp, LOG_INFO, str(ev), "sensemaking.events")))
        first = next((a for a in ev.args if not isinstance(a, str)), None)
        text = f"{ev.name}({','.join(map(str, ev.args))})"
        if first in where:  # under the track's box
            x, y = where[first]
            texts.append(_text_json(ts, x, y + 4.0, text, _WHITE_JSON))
        else:
            texts.append(_text_json(ts, 8.0, 8.0 + 18.0 * line, text, _WHITE_JSON))
            line += 1
    drawn = f'{{"circles":[],"points":[{",".join(points)}],"texts":[{",".join(texts)}]}}'
    out.append((ANNOTATIONS, drawn.encode()))
    return out


_WHITE_JSON = json.dumps(_WHITE)
_WARN_JSON = json.dumps(_WARN)


def _text_json(ts: str, x: float, y: float, text: str, color: str) -> str:
    return (
        f'{{"timestamp":{ts},"position":{{"x":{x!r},"y":{y!r}}},"text":{json.dumps(text)},'
        f'"font_size":12.0,"text_color":{color},"background_color":{_SHADE_JSON}}}'
    )


def encode_ends(ends: Sequence[Any], t_ns: int) -> list[tuple[Channel, bytes]]:
    """The end records of warning episodes (each also a log line) at time ``t_ns``."""
    stamp = _time(t_ns)
    out: list[tuple[Channel, bytes]] = []
    for e in ends:
        record = end_record(e)
        out.append((WARNINGS, _dump({"timestamp": stamp, **record})))
        text = f"{record['situation']} over ({record.get('reason', '')})"
        out.append((LOG, _log(stamp, LOG_INFO, text, "sensemaking.warnings")))
    return out


def _log(stamp: dict[str, int], level: int, message: str, name: str) -> bytes:
    """A ``foxglove.Log`` message."""
    return _dump(
        {
            "timestamp": stamp,
            "level": level,
            "message": message,
            "name": name,
            "file": "",
            "line": 0,
        }
    )


class RunStories:
    """The story of each track of a run, told once at its end with
    :mod:`sensemaking.reasoning.stories` from the scene its :attr:`recorder` kept (give it to
    the pipeline as ``recorder``). Shared by the MCAP file and the live view.

    Args:
        fps: frames per second. image_size: ``(width, height)`` pixels or None.
        camera: the camera model's JSON as ``--scene`` stores it (the motion over the road).

    Memory: the recorder's columns, about 75 bytes a track box, as a ``--scene`` file read
    back for ``explain`` holds them.
    """

    def __init__(
        self,
        fps: float,
        image_size: tuple[int, int] | None = None,
        camera: dict[str, Any] | None = None,
    ):
        from sensemaking.scene import SceneRecorder

        meta = {"camera": camera} if camera is not None else None
        self.recorder = SceneRecorder(fps, image_size, meta, problems=False)
        self._told: list[tuple[Any, list[str]]] | None = None

    def told(self) -> list[tuple[Any, list[str]]]:
        """(track, sentences) of every track, in order of appearance (computed once)."""
        if self._told is None:
            from sensemaking.reasoning.stories import stories

            scene = self.recorder.scene()
            self._told = [(scene.tracks[k], v) for k, v in stories(scene).items()]
        return self._told

    def encode(self, time_of: Any) -> list[tuple[int, list[tuple[Channel, bytes]]]]:
        """(time ns of the track's last frame, its story and log line) per track."""
        out = []
        for t, sentences in self.told():
            t_ns = int(time_of(int(t.last)))
            stamp = _time(t_ns)
            text = " ".join(sentences)
            story = {
                "timestamp": stamp,
                "track": int(t.id),
                "class_id": int(t.class_id),
                "class": class_name(int(t.class_id)),
                "first_frame": int(t.first),
                "last_frame": int(t.last),
                "text": text,
                "sentences": sentences,
            }
            log = _log(stamp, LOG_INFO, text, "sensemaking.stories")
            out.append((t_ns, [(STORIES, _dump(story)), (LOG, log)]))
        return out
