"""The run served live on Foxglove's WebSocket protocol (``foxglove.websocket.v1``), on the
loopback interface only, while frames are processed: a viewer connects to
``ws://127.0.0.1:PORT``, subscribes to channels, and receives each message as it is made.

The protocol as used here: on connect the server sends ``serverInfo`` and ``advertise`` (the
channels of :mod:`sensemaking.ros.channels`, JSON with JSON schemas; passed-through input topics
as CDR with their ROS 2 definitions, advertised when first seen); the client sends
``subscribe`` / ``unsubscribe`` (``{"id": subscription, "channelId": channel}``); a message goes
to each subscription as a binary frame ``0x01, subscription id (uint32 LE), time ns (uint64
LE), payload``. Other client operations are ignored. A send blocks until the socket takes it
(a slow viewer slows the run; memory does not grow); a client that fails is dropped.
"""

from __future__ import annotations

import json
import logging
import struct
import threading
import time
from collections.abc import Callable
from typing import Any

from sensemaking.errors import InputError
from sensemaking.results import FrameResult
from sensemaking.ros import require_ros
from sensemaking.ros.channels import CHANNELS, Channel, RunStories, encode_ends, encode_frame

__all__ = ["LiveServer", "LiveSink", "SUBPROTOCOL", "DEFAULT_PORT"]

log = logging.getLogger(__name__)

SUBPROTOCOL = "foxglove.websocket.v1"
#: Foxglove's default port for a WebSocket connection
DEFAULT_PORT = 8765
_MESSAGE_DATA = 0x01


class LiveServer:
    """A Foxglove WebSocket server on ``127.0.0.1:port`` (0: a free port, see ``port``),
    serving in a background thread until :meth:`close`."""

    def __init__(self, port: int = DEFAULT_PORT, *, host: str = "127.0.0.1"):
        if host not in ("127.0.0.1", "localhost", "::1"):
            raise InputError("the live server listens on the loopback interface only")
        sync_server = require_ros("websockets.sync.server")
        self._lock = threading.Lock()
        self._channels: dict[int, dict[str, Any]] = {}
        self._ids: dict[str, int] = {}
        self._clients: dict[Any, dict[int, int]] = {}  # connection -> channel id -> sub id
        self._subscribed = threading.Event()
        for ch in CHANNELS:
            self.add_channel(ch.topic, ch.schema_name, ch.schema_bytes().decode(), "json")
        try:
            self._server = sync_server.serve(
                self._handle, host, int(port), subprotocols=[SUBPROTOCOL]
            )
        except OSError as exc:
            raise InputError(
                f"--live: cannot listen on {host}:{port}: {exc.strerror or exc} (another "
                "server there? choose --live-port)"
            ) from None
        self.port = int(self._server.socket.getsockname()[1])
        self.url = f"ws://{host}:{self.port}"
        self._thread = threading.Thread(
            target=self._server.serve_forever, name="sensemaking-live", daemon=True
        )
        self._thread.start()

    # -- channels --------------------------------------------------------------------------
    def add_channel(
        self, topic: str, schema_name: str, schema: str, encoding: str, schema_encoding: str = ""
    ) -> int:
        """Advertise a channel (to the clients connected now and later); returns its id."""
        with self._lock:
            if topic in self._ids:
                return self._ids[topic]
            cid = len(self._channels) + 1
            spec = {
                "id": cid,
                "topic": topic,
                "encoding": encoding,
                "schemaName": schema_name,
                "schema": schema,
                "schemaEncoding": schema_encoding or ("jsonschema" if encoding == "json" else ""),
            }
            self._channels[cid] = spec
            self._ids[topic] = cid
            clients = list(self._clients)
        if clients:
            text = json.dumps({"op": "advertise", "channels": [spec]})
            for conn in clients:
                self._send(conn, text)
        return cid

    def channel_id(self, topic: str) -> int:
        return self._ids[topic]

    # -- clients ---------------------------------------------------------------------------
    def _handle(self, conn: Any) -> None:
        with self._lock:
            channels = list(self._channels.values())
            self._clients[conn] = {}
        try:
            conn.send(
                json.dumps(
                    {
                        "op": "serverInfo",
                        "name": "sensemaking",
                        "capabilities": [],
                        "supportedEncodings": [],
                        "metadata": {},
                        "sessionId": str(time.time_ns()),
                    }
                )
            )
            conn.send(json.dumps({"op": "advertise", "channels": channels}))
            for raw in conn:
                self._request(conn, raw)
        except Exception:  # noqa: BLE001 - a client that fails is dropped, the run goes on
            log.debug("live client dropped", exc_info=True)
        finally:
            with self._lock:
                self._clients.pop(conn, None)

    def _request(self, conn: Any, raw: Any) -> None:
        if not isinstance(raw, str):
            return  # binary client messages (publishing) are not taken
        try:
            msg = json.loads(raw)
        except ValueError:
            return
        if not isinstance(msg, dict):
            return
        op = msg.get("op")
        with self._lock:
            subs = self._clients.get(conn)
            if subs is None:
                return
            if op == "subscribe":
                for s in msg.get("subscriptions", []):
                    try:
                        sid, cid = int(s["id"]), int(s["channelId"])
                    except (KeyError, TypeError, ValueError):
                        continue
                    if cid in self._channels:
                        subs[cid] = sid
                        self._subscribed.set()
            elif op == "unsubscribe":
                gone = {int(i) for i in msg.get("subscriptionIds", []) if isinstance(i, int)}
                for cid in [c for c, s in subs.items() if s in gone]:
                    del subs[cid]

    def _send(self, conn: Any, data: str | bytes) -> None:
        try:
            conn.send(data)
        except Exception:  # noqa: BLE001 - a client that fails is dropped, the run goes on
            with self._lock:
                self._clients.pop(conn, None)

    def wait_for_subscriber(self, timeout_s: float) -> bool:
        """Wait until a client subscribes to a channel (True) or ``timeout_s`` seconds pass."""
        return self._subscribed.wait(timeout_s)

    @property
    def clients(self) -> int:
        with self._lock:
            return len(self._clients)

    # -- messages --------------------------------------------------------------------------
    def publish(self, channel_id: int, t_ns: int, payload: bytes) -> None:
        """Send a message to every subscription of the channel."""
        with self._lock:
            targets = [(c, s[channel_id]) for c, s in self._clients.items() if channel_id in s]
        for conn, sid in targets:
            self._send(conn, struct.pack("<BIQ", _MESSAGE_DATA, sid, int(t_ns)) + payload)

    def close(self) -> None:
        """Stop serving and close every connection."""
        with self._lock:
            clients = list(self._clients)
        for conn in clients:
            try:
                conn.close()
            except Exception:  # noqa: BLE001 - closing anyway
                pass
        self._server.shutdown()
        self._thread.join(timeout=5)


class LiveSink:
    """A :class:`~sensemaking.sinks.Sink` publishing each frame's channels on a
    :class:`LiveServer` and, when the run ends, the ``stories`` of its tracks (then the server
    closes)."""

    def __init__(
        self,
        server: LiveServer,
        time_of: Callable[[int], int],
        stories: RunStories | None = None,
    ):
        self.server = server
        self.time_of = time_of
        self.stories = stories
        self._passthrough: dict[int, int] = {}

    def _put(self, items: list[tuple[Channel, bytes]], t_ns: int) -> None:
        for ch, data in items:
            self.server.publish(self.server.channel_id(ch.topic), t_ns, data)

    def frame(self, result: FrameResult, warnings: list[Any]) -> None:
        t = self.time_of(int(result.frame))
        self._put(encode_frame(result, warnings, t), t)

    def end_warnings(self, ends: list[Any]) -> None:
        for e in ends:
            t = self.time_of(int(e.frame))
            self._put(encode_ends([e], t), t)

    def advertise(self, connection: Any, msgdef: Any) -> int:
        """Advertise an input topic (CDR with its ROS 2 definition); its channel id."""
        cid = self._passthrough.get(connection.id)
        if cid is None:
            encoding, text = msgdef(connection)
            cid = self.server.add_channel(
                connection.topic, connection.msgtype, text, "cdr", encoding
            )
            self._passthrough[connection.id] = cid
        return cid

    def passthrough(self, connection: Any, log_time: int, data: bytes, msgdef: Any) -> None:
        """Serve one input message on its own topic."""
        self.server.publish(self.advertise(connection, msgdef), int(log_time), bytes(data))

    def skip(self, first: int, last: int) -> None:
        pass

    def finish(self) -> None:
        try:
            if self.stories is not None:
                for t, items in self.stories.encode(self.time_of):
                    self._put(items, t)
        finally:
            self.server.close()

    def abort(self, interrupted: bool = False) -> None:
        self.server.close()
