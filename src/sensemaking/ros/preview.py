"""A picture of one frame of an output MCAP's ``/sensemaking/annotations``, drawn as a viewer
draws ``foxglove.ImageAnnotations`` (line loops and labels) on a dark canvas of the image's size:
what the file shows without Foxglove at hand. Needs the extras ``ros`` and ``viz`` (Pillow).

    python -m sensemaking.ros.preview run.mcap frame.png [--frame N]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from sensemaking.errors import InputError, require
from sensemaking.ros import require_ros

__all__ = ["render_annotations"]


def _rgba(color: dict[str, float]) -> tuple[int, int, int, int]:
    return tuple(int(round(255 * float(color.get(k, 0.0)))) for k in "rgba")  # type: ignore[return-value]


def render_annotations(mcap: Path, out: Path, frame: int | None = None) -> int:
    """Draw the annotations of ``frame`` (the tracks message's frame number; None: the frame
    with the most tracks) into the PNG ``out``; returns the frame drawn."""
    reader_mod = require_ros("mcap.reader")
    image_mod = require("PIL.Image", "viz")
    draw_mod = require("PIL.ImageDraw", "viz")
    from sensemaking.viz._style import font

    with open(mcap, "rb") as handle:
        reader = reader_mod.make_reader(handle)
        meta = {m.name: m.metadata for m in reader.iter_metadata()}.get("sensemaking", {})
        size = meta.get("image_size") or "1242x375"
        width, height = (int(v) for v in size.split("x"))
        frames: dict[int, tuple[int, int]] = {}  # frame -> (log time, tracks)
        for _, _channel, message in reader.iter_messages(topics=["/sensemaking/tracks"]):
            m = json.loads(message.data)
            frames[int(m["frame"])] = (message.log_time, len(m["tracks"]))
        if not frames:
            raise InputError("no /sensemaking/tracks messages", mcap)
        if frame is None:
            frame = max(frames, key=lambda f: (frames[f][1], -f))
        if frame not in frames:
            raise InputError(f"no frame {frame} in the file", mcap)
        when = frames[frame][0]
        drawn: Any = None
        for _, _channel, message in reader.iter_messages(topics=["/sensemaking/annotations"]):
            if message.log_time == when:
                drawn = json.loads(message.data)
                break
    image = image_mod.new("RGB", (width, height), (28, 30, 36))
    pen = draw_mod.Draw(image, "RGBA")
    small = font(12)
    for p in (drawn or {}).get("points", []):
        xy = [(q["x"], q["y"]) for q in p["points"]]
        pen.line([*xy, xy[0]], fill=_rgba(p["outline_color"]), width=int(p["thickness"]))
    for t in (drawn or {}).get("texts", []):
        x, y = t["position"]["x"], t["position"]["y"]
        box = pen.textbbox((x, y), t["text"], font=small)
        pen.rectangle(box, fill=_rgba(t["background_color"]))
        pen.text((x, y), t["text"], fill=_rgba(t["text_color"]), font=small)
    out.parent.mkdir(parents=True, exist_ok=True)
    image.save(out)
    return frame


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("mcap", type=Path)
    ap.add_argument("png", type=Path)
    ap.add_argument("--frame", type=int, default=None)
    args = ap.parse_args(argv)
    try:
        frame = render_annotations(args.mcap, args.png, args.frame)
    except (InputError, ImportError, OSError) as exc:
        print(f"preview: error: {exc}", file=sys.stderr)
        return 2
    print(f"{args.png}: frame {frame}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
