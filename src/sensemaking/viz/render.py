"""Draw a tracker run onto its frames: boxes, ids, classes, hidden objects, trails and captions.

* Visible tracks: a solid box in the track's colour (stable per id) with a ``#id class`` chip.
* Hidden tracks: a dashed box at the predicted position, chip ``#id class hidden behind #k``.
* Missing tracks (not detected, nothing hides them): a dotted box, chip ``#id class missing``.
* Trails: the centres of the last ``trail`` frames of every live track.
* Objects named by an active warning get a red frame; while a hidden object is hidden, the box
  where a HIDDEN_ENTITY warning anticipates it to reappear is drawn dotted in red.
* A caption strip below the picture: frame number and counts, then the warnings and events of the
  last ``hold`` frames (newest first).

Frames come from an image folder, a video, or a plain canvas of the sequence's size. Plain-canvas
frames are drawn in palette mode (one fixed palette, see :mod:`._style`), which makes GIF output
need no quantisation. Drawing a KITTI frame takes about 0.7 ms (text is pasted from cached
masks); GIF frames store only the rectangle that changed (see ``benchmarks/render_speed.py``).
"""

from __future__ import annotations

import logging
import os
import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sensemaking.errors import InputError, require
from sensemaking.results import TrackState
from sensemaking.viz import _style as st
from sensemaking.viz._run import Run, as_run
from sensemaking.viz._style import _get

__all__ = ["RenderOptions", "FrameDrawer", "render_scene", "render_frame", "default_scale"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class RenderOptions:
    """How frames are drawn.

    Attributes:
        trail: frames of past centres drawn behind each track (0: none).
        hold: frames a caption stays in the strip (None: one second at the run's fps, >= 5).
        caption_lines: caption lines below the header line (the strip's height is fixed).
        font_size: caption and chip text height, px of the output (not scaled).
        line_width: box outline width, px of the output.
        grid: draw faint guide lines every 100 source px on a plain canvas.
    """

    trail: int = 12
    hold: int | None = None
    caption_lines: int = 3
    font_size: int = 12
    line_width: int = 2
    grid: bool = True


def default_scale(width: int, with_images: bool) -> float:
    """Output / source size: at most 640 px wide on a plain canvas, 1280 px over images, <= 1."""
    return min(1.0, (1280.0 if with_images else 640.0) / max(int(width), 1))


def _even(n: int) -> int:
    return n + (n % 2)


_TOKENS = re.compile(r"\d| +|[^\d ]+")
_THRESHOLD = [255 if v >= 110 else 0 for v in range(256)]


class _Text:
    """Text drawn from cached masks of its words and digits (Pillow's text drawing is slow).

    Each word or digit is rendered once, and each line is composed from them once; a per-frame
    string (a frame number) costs a few small pastes instead of a font rendering.
    """

    def __init__(self, size: int, mode: str):
        self.font = st.font(size)
        self.mode = mode  # "1" (crisp, palette canvases) or "L" (anti-aliased, RGB)
        self.cache: dict[str, tuple[Any, int]] = {}
        self.lines: dict[str, tuple[Any, int]] = {}
        self.seen: set[str] = set()
        bbox = self.font.getbbox("Ag#(")
        self.height = int(bbox[3]) + 1
        self.space = max(int(round(self.font.getlength(" "))), 2)

    def token(self, text: str) -> tuple[Any, int]:
        """(mask, advance in px) of one word or digit."""
        got = self.cache.get(text)
        if got is None:
            image, draw = _pil()
            advance = int(round(self.font.getlength(text)))
            right = int(self.font.getbbox(text)[2])
            m = image.new("L", (max(right, advance, 1), self.height))
            draw.Draw(m).text((0, 0), text, fill=255, font=self.font)
            if self.mode == "1":
                m = m.point(_THRESHOLD).convert("1")
            if len(self.cache) > 8192:
                self.cache.clear()
            got = self.cache[text] = (m, advance)
        return got

    def line(self, text: str) -> tuple[Any, int]:
        """(mask, width in px) of a whole line, composed from its tokens and cached."""
        got = self.lines.get(text)
        if got is None:
            image, _ = _pil()
            parts, x = [], 0
            for tok in _TOKENS.findall(text):
                if tok[0] == " ":
                    x += self.space * len(tok)
                    continue
                m, adv = self.token(tok)
                parts.append((m, x))
                x += adv
            width = max(x, max((px + m.size[0] for m, px in parts), default=0))
            mask = image.new("L", (max(width, 1), self.height), 0)
            for m, px in parts:  # max of overlapping glyph edges
                box = (px, 0, px + m.size[0], self.height)
                mask.paste(_chops().lighter(mask.crop(box), m.convert("L")), box)
            if self.mode == "1":
                mask = mask.convert("1")
            if len(self.lines) > 4096:
                self.lines.clear()
            got = self.lines[text] = (mask, x)
        return got

    def width(self, text: str) -> int:
        """Advance of ``text`` in px, as :meth:`draw` lays it out."""
        got = self.lines.get(text)
        if got is not None:
            return got[1]
        w = 0
        for tok in _TOKENS.findall(text):
            w += self.space * len(tok) if tok[0] == " " else self.token(tok)[1]
        return w

    def draw(self, im: Any, text: str, x: int, y: int, ink: Any) -> int:
        """Paste ``text`` at ``(x, y)`` (top left) in ``ink``; returns the x after it.

        A line seen for the first time is pasted token by token (per-frame strings such as frame
        numbers never repeat); from its second use on, it is composed once and pasted whole.
        """
        if text in self.lines or text in self.seen:
            mask, width = self.line(text)
            im.paste(ink, (x, y), mask)
            return x + width
        if len(self.seen) > 4096:
            self.seen.clear()
        self.seen.add(text)
        for tok in _TOKENS.findall(text):
            if tok[0] == " ":
                x += self.space * len(tok)
                continue
            m, adv = self.token(tok)
            im.paste(ink, (x, y), m)
            x += adv
        return x


def _chops() -> Any:
    return require("PIL.ImageChops", "viz")


def _pil() -> tuple[Any, Any]:
    return require("PIL.Image", "viz"), require("PIL.ImageDraw", "viz")


class FrameDrawer:
    """Draws any frame of a run (random access), onto a plain canvas or a given picture.

    Args:
        run: the run to draw.
        scale: output px per source px (None: :func:`default_scale`).
        options: drawing options.
        with_images: True when frames will be drawn over pictures (RGB output); False: palette.
        size: source image size ``(width, height)`` px (default: the run's).
    """

    def __init__(
        self,
        run: Run,
        scale: float | None = None,
        options: RenderOptions | None = None,
        with_images: bool = False,
        size: tuple[int, int] | None = None,
    ):
        self.run = run
        self.options = options or RenderOptions()
        self.src_size = size or run.size()
        self.scale = float(scale) if scale else default_scale(self.src_size[0], with_images)
        self.mode = "RGB" if with_images else "P"
        o = self.options
        self.text = _Text(o.font_size, "L" if with_images else "1")
        self.line_h = self.text.height + 3
        self.image_size = (
            max(int(round(self.src_size[0] * self.scale)), 16),
            max(int(round(self.src_size[1] * self.scale)), 16),
        )
        self.strip_h = self.line_h * (1 + o.caption_lines) + 8
        self.size = (_even(self.image_size[0]), _even(self.image_size[1] + self.strip_h))
        fps = run.fps or 10.0
        self.hold = o.hold if o.hold is not None else max(int(round(fps)), 5)
        self._pal = st.palette()
        self._blank: Any = None
        self._centres: dict[int, dict[int, tuple[float, float]]] = {}
        self._warn_by_frame: dict[int, list[Any]] = {}
        self._expected: list[tuple[int, int, int, list[float]]] = []  # (from, to, track, box)
        for w in run.warnings:
            if not st.is_note(w):
                self._warn_by_frame.setdefault(int(_get(w, "frame", -1)), []).append(w)
                self._expected.extend(_anticipation(w))
        self._classes = run.classes

    # colours -------------------------------------------------------------------------------------
    def ink(self, slot: int) -> Any:
        """A palette slot as this canvas' ink (the slot itself in palette mode, RGB otherwise)."""
        return slot if self.mode == "P" else self._pal[slot]

    # canvas --------------------------------------------------------------------------------------
    def blank(self) -> Any:
        """A fresh canvas: plain background (with guide lines) above an empty caption strip."""
        if self._blank is None:
            image, draw = _pil()
            if self.mode == "P":
                im = image.new("P", self.size, st.BACKGROUND)
                im.putpalette(st.palette_bytes())
            else:
                im = image.new("RGB", self.size, self._pal[st.BACKGROUND])
            d = draw.Draw(im)
            w, h = self.image_size
            if self.options.grid:
                step = 100 * self.scale
                for k in range(1, int(self.src_size[0] // 100) + 1):
                    d.line((k * step, 0, k * step, h - 1), fill=self.ink(st.GRID))
                for k in range(1, int(self.src_size[1] // 100) + 1):
                    d.line((0, k * step, w - 1, k * step), fill=self.ink(st.GRID))
            d.rectangle((0, h, self.size[0], self.size[1]), fill=self.ink(st.STRIP))
            self._blank = im
        return self._blank.copy()

    def _canvas(self, picture: Any) -> Any:
        if picture is None:
            return self.blank()
        image, _ = _pil()
        im = self.blank()
        if self.mode == "P":
            raise ValueError("this drawer draws on a plain canvas (with_images=False)")
        if picture.size != self.image_size:
            picture = picture.resize(self.image_size, image.Resampling.BILINEAR)
        im.paste(picture.convert("RGB"), (0, 0))
        return im

    # data ----------------------------------------------------------------------------------------
    def _centres_at(self, frame: int) -> dict[int, tuple[float, float]]:
        c = self._centres.get(frame)
        if c is None:
            r = self.run.by_frame.get(frame)
            c = {}
            if r is not None and len(r.tracks):
                xy = r.tracks.xyxy * self.scale
                cx, cy = (xy[:, 0] + xy[:, 2]) / 2, (xy[:, 1] + xy[:, 3]) / 2
                assert r.tracks.tracker_id is not None  # Detections fills every column
                c = dict(
                    zip(
                        r.tracks.tracker_id.tolist(),
                        zip(cx.tolist(), cy.tolist(), strict=True),
                        strict=True,
                    )
                )
            if len(self._centres) > 4 * max(self.options.trail, 1) + 64:
                self._centres.clear()
            self._centres[frame] = c
        return c

    # drawing -------------------------------------------------------------------------------------
    def draw(self, frame: int, picture: Any = None) -> Any:
        """The drawn frame as a Pillow image (``size`` px; mode "P" or "RGB")."""
        _, draw = _pil()
        im = self._canvas(picture)
        d = draw.Draw(im)
        r = self.run.by_frame.get(frame)
        warned = self._warned_objects(frame)
        if r is not None and len(r.tracks):
            assert r.tracks.tracker_id is not None
            self._draw_trails(d, frame, r.tracks.tracker_id.tolist())
            self._draw_expected(im, d, frame, r)
            self._draw_tracks(im, d, r.tracks, warned)
        self._draw_strip(im, d, frame, r)
        return im

    def _warned_objects(self, frame: int) -> set[int]:
        out: set[int] = set()
        for f in range(frame - self.hold + 1, frame + 1):
            for w in self._warn_by_frame.get(f, ()):
                for o in _get(w, "objects", ()) or ():
                    if isinstance(o, (int, np.integer)):
                        out.add(int(o))
        return out

    def _draw_trails(self, d: Any, frame: int, ids: list[int]) -> None:
        n = self.options.trail
        if n <= 0:
            return
        past = [self._centres_at(f) for f in range(frame - n, frame + 1)]
        for tid in ids:
            pts = [c[tid] for c in past if tid in c]
            if len(pts) >= 2:
                d.line(pts, fill=self.ink(st.track_slot(tid)), width=1)

    def _draw_tracks(self, im: Any, d: Any, tracks: Any, warned: set[int]) -> None:
        s = self.scale
        lw = self.options.line_width
        states = tracks.data.get("state")
        occluders = tracks.data.get("occluder")
        n = len(tracks)
        states = (
            np.zeros(n, dtype=np.int64) if states is None else np.asarray(states).astype(np.int64)
        )
        occluders = np.full(n, -1) if occluders is None else np.asarray(occluders).astype(np.int64)
        boxes = tracks.xyxy * s
        # hidden / missing first, so visible boxes are drawn on top
        order = np.argsort(states == TrackState.VISIBLE, kind="stable")
        w, h = self.image_size
        for i in order.tolist():
            tid = int(tracks.tracker_id[i])
            slot = st.track_slot(tid)
            x1, y1, x2, y2 = boxes[i].tolist()
            if x2 < 0 or y2 < 0 or x1 > w or y1 > h:
                continue
            state = int(states[i])
            label = st.track_caption(tid, self._classes.get(tid), state, int(occluders[i]))
            if state == TrackState.VISIBLE:
                d.rectangle((x1, y1, x2, y2), outline=self.ink(slot), width=lw)
            elif state == TrackState.HIDDEN:
                _dashed_rect(d, (x1, y1, x2, y2), self.ink(slot), lw, dash=7, gap=5, bounds=(w, h))
            else:
                _dashed_rect(
                    d,
                    (x1, y1, x2, y2),
                    self.ink(slot),
                    max(lw - 1, 1),
                    dash=2,
                    gap=4,
                    bounds=(w, h),
                )
            if tid in warned:
                d.rectangle(
                    (x1 - lw - 2, y1 - lw - 2, x2 + lw + 2, y2 + lw + 2),
                    outline=self.ink(st.WARNING),
                    width=lw,
                )
            if state == TrackState.VISIBLE:
                self._chip(im, d, label, x1, y1, y2, slot, solid=True)
            else:  # below the box: the occluder's chip is usually above
                self._chip(im, d, label, x1, y1, y2, slot, solid=False)

    def _draw_expected(self, im: Any, d: Any, frame: int, r: Any) -> None:
        """Where a hidden object is expected to reappear (HIDDEN_ENTITY warning), while hidden."""
        if not self._expected:
            return
        states = r.tracks.data.get("state")
        if states is None:
            return
        hidden = set(r.tracks.tracker_id[np.asarray(states) != TrackState.VISIBLE].tolist())
        for start, end, tid, box in self._expected:
            if start <= frame <= end and tid in hidden:
                x1, y1, x2, y2 = (v * self.scale for v in box)
                _dashed_rect(
                    d,
                    (x1, y1, x2, y2),
                    self.ink(st.WARNING),
                    1,
                    dash=3,
                    gap=3,
                    bounds=self.image_size,
                )
                self._chip(
                    im,
                    d,
                    f"#{tid} may reappear here (frame {end})",
                    x1,
                    y1,
                    y1 - 1,
                    st.WARNING,
                    solid=False,
                    above=True,
                )

    def _chip(
        self,
        im: Any,
        d: Any,
        text: str,
        x: float,
        y1: float,
        y2: float,
        slot: int,
        solid: bool,
        above: bool | None = None,
    ) -> None:
        """A label above the box, filled in the track colour (visible), or below it, outlined."""
        tw, th = self.text.width(text), self.text.height
        w, h = self.image_size
        cx = int(min(max(x, 0), max(w - tw - 4, 0)))
        if solid if above is None else above:
            cy = int(y1) - th - 2
            if cy < 0:
                cy = int(max(y1, 0)) + 2
        else:
            cy = int(y2) + 2
            if cy + th + 1 > h:
                cy = int(min(y2, h)) - th - 3
        box = (cx, cy, cx + tw + 3, cy + th + 1)
        if solid:
            d.rectangle(box, fill=self.ink(slot))
            self.text.draw(im, text, cx + 2, cy + 1, self.ink(st.ink_on(self._pal[slot])))
        else:
            d.rectangle(box, fill=self.ink(st.STRIP), outline=self.ink(slot))
            self.text.draw(im, text, cx + 2, cy + 1, self.ink(slot))

    def _text(self, im: Any, text: str, x: int, y: int, slot: int) -> int:
        return self.text.draw(im, text, x, y, self.ink(slot))

    def _draw_strip(self, im: Any, d: Any, frame: int, r: Any) -> None:
        w, h = self.image_size
        y = h + 4
        x = 6
        x = self._text(im, f"frame {frame}", x, y, st.TEXT)
        if r is not None and len(r.tracks):
            states = r.tracks.data.get("state")
            states = (
                np.zeros(len(r.tracks), dtype=np.int64) if states is None else np.asarray(states)
            )
            nv = int(np.sum(states == TrackState.VISIBLE))
            nh = int(np.sum(states == TrackState.HIDDEN))
            nm = int(np.sum(states == TrackState.MISSING))
            summary = f"   {len(r.tracks)} tracks: {nv} visible, {nh} hidden, {nm} missing"
        else:
            summary = "   no tracks"
        x = self._text(im, summary, x, y, st.TEXT_DIM)
        if self.run.name:
            self._text(
                im, self.run.name, max(w - self.text.width(self.run.name) - 6, x), y, st.TEXT_DIM
            )
        lines = self._captions(frame)
        n = self.options.caption_lines
        if len(lines) > n:
            extra = len(lines) - (n - 1)
            lines = lines[: n - 1] + [(f"... and {extra} more", st.TEXT_DIM, None)]
        for k, (text, slot, tag) in enumerate(lines):
            yy = y + self.line_h * (k + 1)
            xx = 6
            if tag is not None:
                xx = self._text(im, tag, xx, yy, slot) + 6
            text = self._fit(text, w - xx - 6)
            self._text(im, text, xx, yy, slot if tag is None or slot != st.WARNING else st.TEXT)

    def _fit(self, text: str, width: int) -> str:
        """``text``, cut at a word and ended with "..." when it is wider than ``width`` px."""
        if self.text.width(text) <= width:
            return text
        words = text.split(" ")
        lo, hi = 0, len(words)  # the longest prefix of words that fits, by bisection
        while lo < hi:
            mid = (lo + hi + 1) // 2
            if self.text.width(" ".join(words[:mid]) + " ...") <= width:
                lo = mid
            else:
                hi = mid - 1
        return " ".join(words[:lo]) + " ..." if lo else "..."

    def _captions(self, frame: int) -> list[tuple[str, int, str | None]]:
        """(text, colour slot, tag) of the warnings then events of the last ``hold`` frames."""
        warn: list[tuple[str, int, str | None]] = []
        events: list[tuple[str, int, str | None]] = []
        for f in range(frame, frame - self.hold, -1):
            for wobj in self._warn_by_frame.get(f, ()):
                warn.append((st.warning_sentence(wobj), st.WARNING, "WARNING"))
            r = self.run.by_frame.get(f)
            if r is None:
                continue
            for e in r.events:
                slot = st.EVENT if f == frame else st.TEXT_DIM
                events.append((st.event_sentence(e.name, e.args, self._classes), slot, f"[{f}]"))
        return warn + events


def _anticipation(warning: Any) -> list[tuple[int, int, int, list[float]]]:
    """(from frame, to frame, track, box px) of a warning's anticipated reappearance, if any."""
    details = _get(warning, "details", None) or {}
    a = details.get("anticipation") if isinstance(details, dict) else None
    if not isinstance(a, dict):
        return []
    try:
        box = [float(v) for v in a["box"]]
        return [
            (
                int(_get(warning, "frame", a.get("frame", 0))),
                int(a["reappear_frame"]),
                int(a["track"]),
                box,
            )
        ]
    except (KeyError, TypeError, ValueError):
        return []


def _dashed_rect(
    d: Any,
    box: tuple[float, float, float, float],
    ink: Any,
    width: int,
    dash: int,
    gap: int,
    bounds: tuple[int, int] | None = None,
) -> None:
    """A dashed rectangle; with ``bounds = (w, h)`` only the parts inside the image are drawn
    (dashes keep their phase, so a clipped edge looks the same)."""
    x1, y1, x2, y2 = box
    step = dash + gap
    bw, bh = bounds if bounds is not None else (float("inf"), float("inf"))
    m = width + 1

    def run(lo: float, hi: float, limit: float) -> range:
        # indices k of the dashes lo + k * step that overlap [-m, limit + m]
        first = max(0, int((-m - lo - dash) // step))
        last = (
            int((min(hi, limit + m) - lo) // step)
            if limit != float("inf")
            else int((hi - lo) // step)
        )
        return range(first, last + 1)

    for y in (y1, y2):
        if -m <= y <= bh + m:
            for k in run(x1, x2, bw):
                a = x1 + k * step
                if a < x2:
                    d.line((a, y, min(a + dash, x2), y), fill=ink, width=width)
    for x in (x1, x2):
        if -m <= x <= bw + m:
            for k in run(y1, y2, bh):
                a = y1 + k * step
                if a < y2:
                    d.line((x, a, x, min(a + dash, y2)), fill=ink, width=width)


# public API ------------------------------------------------------------------------------------
def _source(
    images: str | os.PathLike[str] | None,
    video: str | os.PathLike[str] | None,
    first_frame: int | None,
    run: Run,
) -> Any:
    from sensemaking.viz._media import ImageFolder, VideoFrames

    if images is not None and video is not None:
        raise InputError("give images or a video, not both")
    if images is not None:
        return ImageFolder(images, first_frame)
    if video is not None:
        return VideoFrames(video, run.first_frame if first_frame is None else first_frame)
    return None


def render_scene(
    scene: Any,
    output: str | os.PathLike[str],
    images: str | os.PathLike[str] | None = None,
    fps: float | None = None,
    *,
    video: str | os.PathLike[str] | None = None,
    scale: float | None = None,
    frames: Iterable[int] | None = None,
    first_frame: int | None = None,
    warnings: Iterable[Any] | str | None = "auto",
    options: RenderOptions | None = None,
    progress: Callable[[int], None] | None = None,
) -> Path:
    """Draw a run onto its frames and write a video, a GIF or a folder of PNGs.

    Args:
        scene: a Scene, the path of a scene JSON, a list of FrameResult, or a :class:`Run`.
        output: ``*.mp4`` / ``*.mkv`` / ``*.mov`` / ``*.avi`` / ``*.webm`` (ffmpeg), ``*.gif``,
            or a folder (one ``<frame:06d>.png`` per frame); the kind follows the path.
        images: folder of the sequence's images (sorted names; integer names are frame numbers).
        fps: frames per second of the output (default: the run's, else 10).
        video: a video of the sequence instead of ``images`` (video frame 0 = ``first_frame``).
        scale: output px per source px (default :func:`default_scale`).
        frames: only these frame numbers (default: every frame from the first result to the last).
        first_frame: frame number of the first image / video frame when names do not say it
            (default: the run's first frame).
        warnings: warnings to caption; ``"auto"`` replays the situation monitor over the run
            (see :func:`~sensemaking.viz._run.as_run`), None: no warnings.
        options: drawing options (:class:`RenderOptions`).
        progress: called with 1 after each written frame.
    Returns:
        The output path. Nothing is left at ``output`` when writing fails.
    """
    from sensemaking.viz._media import open_writer, output_kind

    run = as_run(scene, warnings=warnings)
    output_kind(output)  # fail on a bad suffix before any work
    source = _source(images, video, first_frame, run)
    try:
        size = source.size if source is not None else None
        if (
            size is not None
            and run.width
            and run.height
            and tuple(size) != (run.width, run.height)
        ):
            log.warning(
                "the pictures are %dx%d px but the scene's boxes are for %dx%d px images",
                size[0],
                size[1],
                run.width,
                run.height,
            )
        drawer = FrameDrawer(
            run, scale=scale, options=options, with_images=source is not None, size=size
        )
        rate = float(fps or run.fps or 10.0)
        todo: Sequence[int] = list(frames) if frames is not None else run.frames
        if not len(todo):
            raise InputError("nothing to render: the scene has no frames")
        with open_writer(output, drawer.size, rate) as writer:
            for f in todo:
                picture = source.get(f, drawer.image_size) if source is not None else None
                writer.write(drawer.draw(f, picture), f)
                if progress is not None:
                    progress(1)
    finally:
        close = getattr(source, "close", None)
        if close is not None:
            close()
    return Path(output)


def render_frame(
    scene: Any,
    frame: int,
    *,
    images: str | os.PathLike[str] | None = None,
    scale: float | None = None,
    warnings: Iterable[Any] | str | None = "auto",
    options: RenderOptions | None = None,
    first_frame: int | None = None,
) -> Any:
    """One drawn frame as an RGB Pillow image (e.g. for ``docs/demo-frame.png``)."""
    run = as_run(scene, warnings=warnings)
    source = _source(images, None, first_frame, run)
    drawer = FrameDrawer(
        run,
        scale=scale,
        options=options,
        with_images=source is not None,
        size=None if source is None else source.size,
    )
    picture = source.get(frame, drawer.image_size) if source is not None else None
    return drawer.draw(frame, picture).convert("RGB")
