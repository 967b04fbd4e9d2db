"""Helpers of the ROS 2 tests: bags written from detection files with rosbags, and the tracks
of an output MCAP read back with the mcap library."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from sensemaking.detections import Detections
from sensemaking.io.stream import iter_detection_frames


def bag_from_text(
    text: Path,
    fmt: str,
    bag: Path,
    *,
    first: int,
    last: int,
    fps: float,
    image_size: tuple[int, int],
    class_name: str | None = None,
    storage: str = "mcap",
) -> Path:
    """A bag with one Detection2DArray per frame ``first..last`` (empty ones too, as a detector
    publishes) from a MOTChallenge or KITTI detection file; returns the bag folder."""
    from sensemaking.ros.convert import write_detection_bag

    got = dict(iter_detection_frames(text, fmt, class_name))
    frames = [(f, got.get(f, Detections.empty())) for f in range(first, last + 1)]
    return write_detection_bag(
        bag,
        frames,
        fps=fps,
        image_size=image_size,
        camera=(721.5, 721.5, 609.6, 172.9),
        storage=storage,
    )


def mcap_file(bag: Path) -> Path:
    """The one .mcap file of a bag folder."""
    (found,) = sorted(bag.glob("*.mcap"))
    return found


def read_channels(path: Path) -> dict[str, list[tuple[int, dict]]]:
    """Topic -> [(log time ns, JSON message)] of an output MCAP (its JSON channels), in log-time
    order; asserts every channel has a schema."""
    from mcap.reader import make_reader

    out: dict[str, list[tuple[int, dict]]] = {}
    with open(path, "rb") as handle:
        reader = make_reader(handle)
        summary = reader.get_summary()
        assert summary is not None
        for ch in summary.channels.values():
            assert ch.schema_id in summary.schemas, ch.topic
            out.setdefault(ch.topic, [])
        for _schema, channel, message in reader.iter_messages(log_time_order=True):
            if channel.message_encoding == "json":
                out[channel.topic].append((message.log_time, json.loads(message.data)))
    return out


def track_rows(path: Path, *, visible_only: bool) -> np.ndarray:
    """(frame, id, x1, y1, x2, y2) of every track of an output MCAP, sorted by frame and id."""
    rows = [
        (m["frame"], t["id"], t["x1"], t["y1"], t["x2"], t["y2"])
        for _, m in read_channels(path)["/sensemaking/tracks"]
        for t in m["tracks"]
        if not visible_only or t["state"] == "visible"
    ]
    arr = np.array(rows, dtype=np.float64).reshape(-1, 6)
    return arr[np.lexsort((arr[:, 1], arr[:, 0]))]


def result_rows(res: Detections) -> np.ndarray:
    """The same of a results file read back."""
    arr = np.column_stack([res.frame, res.tracker_id, res.xyxy]).astype(np.float64)
    return arr[np.lexsort((arr[:, 1], arr[:, 0]))]
