"""Colours, fonts and wording shared by the renderer and the HTML report.

Every colour lives in one fixed 256-entry palette so plain-canvas frames can be drawn directly in
Pillow's palette mode ("P") and written to GIF without quantisation. Track colours are stable:
track id ``k`` always gets ``track_colours()[k % N_TRACK_COLOURS]``, the same in every frame,
every run, the video and the report.
"""

from __future__ import annotations

import colorsys
from collections.abc import Mapping, Sequence
from functools import lru_cache
from typing import Any

from sensemaking.classes import class_name
from sensemaking.vocabulary import EVENTS

RGB = tuple[int, int, int]

# fixed palette slots --------------------------------------------------------------------------
BACKGROUND = 0  #: plain canvas
STRIP = 1  #: caption strip background
TEXT = 2  #: main text (light)
TEXT_DIM = 3  #: secondary text
BLACK = 4
WARNING = 5  #: warnings (red)
EVENT = 6  #: event captions (amber)
GRID = 7  #: faint guide lines on the plain canvas
WHITE = 8
N_TRACK_COLOURS = 24
TRACK0 = 16  #: first track colour slot

_FIXED: dict[int, RGB] = {
    BACKGROUND: (36, 40, 47),
    STRIP: (17, 19, 23),
    TEXT: (236, 238, 242),
    TEXT_DIM: (150, 156, 166),
    BLACK: (0, 0, 0),
    WARNING: (235, 64, 64),
    EVENT: (255, 196, 70),
    GRID: (52, 57, 66),
    WHITE: (255, 255, 255),
}

#: colours of the track states, by ``TrackState`` value: visible, hidden, missing
STATE_COLOURS: dict[int, str] = {0: "#2e9e5b", 1: "#e8871e", 2: "#8a93a3"}
STATE_NAMES: dict[int, str] = {0: "visible", 1: "hidden", 2: "missing"}


@lru_cache(maxsize=1)
def track_colours() -> tuple[RGB, ...]:
    """The track colours: golden-ratio steps around the hue circle, so neighbouring ids differ."""
    out = []
    for k in range(N_TRACK_COLOURS):
        hue = (k * 0.6180339887498949 + 0.05) % 1.0
        sat = 0.72 if k % 2 == 0 else 0.55
        val = 0.98 if k % 3 else 0.85
        r, g, b = colorsys.hsv_to_rgb(hue, sat, val)
        out.append((round(r * 255), round(g * 255), round(b * 255)))
    return tuple(out)


@lru_cache(maxsize=1)
def palette() -> list[RGB]:
    """The 256 palette colours (RGB) used by every drawing."""
    pal: list[RGB] = [(0, 0, 0)] * 256
    for slot, rgb in _FIXED.items():
        pal[slot] = rgb
    for k, rgb in enumerate(track_colours()):
        pal[TRACK0 + k] = rgb
    return pal


@lru_cache(maxsize=1)
def palette_bytes() -> bytes:
    """The palette flattened for ``Image.putpalette`` (768 bytes)."""
    return bytes(c for rgb in palette() for c in rgb)


def track_slot(track_id: int) -> int:
    """Palette slot of a track's colour (stable per id)."""
    return TRACK0 + int(track_id) % N_TRACK_COLOURS


def track_rgb(track_id: int) -> RGB:
    """RGB colour of a track (stable per id)."""
    return track_colours()[int(track_id) % N_TRACK_COLOURS]


def hex_colour(rgb: RGB) -> str:
    """``#rrggbb`` of an RGB triple."""
    return "#{:02x}{:02x}{:02x}".format(*rgb)


def ink_on(rgb: RGB) -> int:
    """Palette slot of the text colour readable on a background ``rgb`` (black or white)."""
    r, g, b = rgb
    return BLACK if 0.299 * r + 0.587 * g + 0.114 * b > 150 else WHITE


# fonts ----------------------------------------------------------------------------------------
@lru_cache(maxsize=8)
def font(size: int) -> Any:
    """Pillow's bundled default font at ``size`` px (a bitmap font on old Pillow)."""
    from sensemaking.errors import require

    image_font = require("PIL.ImageFont", "viz")
    try:
        return image_font.load_default(size=size)
    except TypeError:  # Pillow < 10.1: no sizes
        return image_font.load_default()


# wording --------------------------------------------------------------------------------------
def track_label(track_id: int, class_id: int | None) -> str:
    """``#5 cyclist`` (or ``#5`` when the class is unknown)."""
    if class_id is None or int(class_id) == 0:
        return f"#{int(track_id)}"
    return f"#{int(track_id)} {class_name(int(class_id)).replace('_', ' ')}"


def track_caption(track_id: int, class_id: int | None, state: int, occluder: int = -1) -> str:
    """The chip on a box: ``#5 cyclist``, ``#5 cyclist hidden behind #2``, ``#5 car missing``."""
    label = track_label(track_id, class_id)
    if state == 1:  # TrackState.HIDDEN
        return label + (
            f" hidden behind #{int(occluder)}"
            if occluder is not None and occluder >= 0
            else " hidden"
        )
    if state == 2:  # TrackState.MISSING
        return label + " missing"
    return label


def event_sentence(
    name: str, args: Sequence[int | str], classes: Mapping[int, int] | None = None
) -> str:
    """An event in words (:mod:`sensemaking.vocabulary`), e.g. ``#5 cyclist hides behind #2
    car``; unknown names verbatim.
    ``args`` are track ids, or constants (a user's encoding), which are shown as they are."""
    classes = classes or {}
    labels = [a if isinstance(a, str) else track_label(a, classes.get(int(a))) for a in args]
    kind = EVENTS.get(name)
    if kind is None or len(labels) < kind.arity:
        return f"{name}({', '.join(map(str, args))})"
    return kind.sentence(labels)


def warning_sentence(warning: Any) -> str:
    """One line for a warning: ``HIDDEN_ENTITY: message`` (message or objects when empty)."""
    situation = str(_get(warning, "situation", "warning")).upper()
    message = str(_get(warning, "message", "") or "")
    if not message:
        objs = _get(warning, "objects", ()) or ()
        message = ", ".join(f"#{o}" if isinstance(o, (int,)) else str(o) for o in objs)
    return f"{situation}: {message}" if message else situation


def is_note(warning: Any) -> bool:
    """True for a note that a situation could not be checked (``details["skipped"]``), not a
    warning."""
    details = _get(warning, "details", None) or {}
    return bool(isinstance(details, Mapping) and details.get("skipped"))


def _get(obj: Any, name: str, default: Any = None) -> Any:
    """Attribute or mapping key ``name`` of ``obj`` (warnings may come as objects or dicts)."""
    if isinstance(obj, Mapping):
        return obj.get(name, default)
    return getattr(obj, name, default)
