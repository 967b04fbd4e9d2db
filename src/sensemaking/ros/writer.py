"""An MCAP file of a run: a :class:`~sensemaking.sinks.Sink` writing the channels of
:mod:`sensemaking.ros.channels` frame by frame (and, with ``--passthrough``, the input bag's own
messages as they are read), into a temporary file renamed into place at the end, where the
story of each track is written too (from :class:`~sensemaking.ros.channels.RunStories`).

Memory: the writer's current chunk (1 MiB before compression) and its index; the stories need
the run's scene (the recorder of ``RunStories``: about 75 bytes a track box).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from sensemaking.io.atomic import PartFile
from sensemaking.results import FrameResult
from sensemaking.ros import require_ros
from sensemaking.ros.channels import CHANNELS, Channel, RunStories, encode_ends, encode_frame

__all__ = ["McapSink"]


class McapSink:
    """Tracks, events and warnings of a run as an MCAP file (JSON messages, JSON schemas).

    Args:
        path: the ``.mcap`` file. time_of: frame -> time in ns (the input's timeline).
        metadata: strings stored as the file's
            ``sensemaking`` metadata record (source, rate, image size).
        stories: the run's stories, written at the end (None: the channel stays empty).
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        time_of: Callable[[int], int],
        metadata: Mapping[str, str] | None = None,
        stories: RunStories | None = None,
    ):
        writer_mod = require_ros("mcap.writer")
        self.path = Path(path)
        self.time_of = time_of
        self.stories = stories
        self.boxes = 0
        self.ids: set[int] = set()
        self.messages = 0
        self._file = PartFile(self.path, "wb")
        try:
            self._writer: Any = writer_mod.Writer(self._file.handle)
            self._writer.start(profile="", library="sensemaking")
            self._channels: dict[str, int] = {}
            for ch in CHANNELS:
                self._channels[ch.topic] = self._register(ch)
            if metadata:
                self._writer.add_metadata("sensemaking", {k: str(v) for k, v in metadata.items()})
        except BaseException:
            self._file.discard()
            raise
        self._passthrough: dict[int, int] = {}  # input connection id -> output channel id

    def _register(self, ch: Channel) -> int:
        schema = self._writer.register_schema(
            name=ch.schema_name, encoding="jsonschema", data=ch.schema_bytes()
        )
        return int(self._writer.register_channel(ch.topic, "json", schema))

    def _put(self, items: list[tuple[Channel, bytes]], t_ns: int) -> None:
        for ch, data in items:
            self._writer.add_message(self._channels[ch.topic], t_ns, data, t_ns)
        self.messages += len(items)

    def frame(self, result: FrameResult, warnings: list[Any]) -> None:
        f = int(result.frame)
        t = self.time_of(f)
        self._put(encode_frame(result, warnings, t), t)
        if len(result.tracks):
            self.boxes += len(result.tracks)
            self.ids.update(result.tracks.tracker_id.tolist())

    def end_warnings(self, ends: list[Any]) -> None:
        """End records of warning episodes, at their frames' times."""
        for e in ends:
            t = self.time_of(int(e.frame))
            self._put(encode_ends([e], t), t)

    def skip(self, first: int, last: int) -> None:
        pass

    def passthrough(self, connection: Any, log_time: int, data: bytes, msgdef: Any) -> None:
        """Copy one input message (``msgdef``: connection -> (schema encoding, text))."""
        channel = self._passthrough.get(connection.id)
        if channel is None:
            encoding, text = msgdef(connection)
            schema = self._writer.register_schema(
                name=connection.msgtype, encoding=encoding, data=text.encode()
            )
            channel = int(self._writer.register_channel(connection.topic, "cdr", schema))
            self._passthrough[connection.id] = channel
        self._writer.add_message(channel, int(log_time), bytes(data), int(log_time))
        self.messages += 1

    def finish(self) -> None:
        try:
            if self.stories is not None:
                for t, items in self.stories.encode(self.time_of):
                    self._put(items, t)
            self._writer.finish()
        except BaseException:
            self._file.discard()  # nothing half-written
            raise
        self._file.commit()

    def abort(self, interrupted: bool = False) -> None:
        self._file.discard()
