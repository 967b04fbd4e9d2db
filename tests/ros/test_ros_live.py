"""``--live``: the run served on Foxglove's WebSocket protocol, received by a client on the
loopback interface (extra 'ros')."""

from __future__ import annotations

import json
import socket
import struct
import threading
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("websockets")
pytest.importorskip("rosbags")

from websockets.sync.client import connect  # noqa: E402

from sensemaking.cli import main  # noqa: E402
from sensemaking.detections import Detections  # noqa: E402
from sensemaking.ros.live import SUBPROTOCOL, LiveServer, LiveSink  # noqa: E402


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _hello(ws) -> dict[str, int]:
    """serverInfo then advertise; topic -> channel id."""
    info = json.loads(ws.recv(timeout=10))
    assert info["op"] == "serverInfo"
    adv = json.loads(ws.recv(timeout=10))
    assert adv["op"] == "advertise"
    for ch in adv["channels"]:
        if ch["topic"].startswith("/sensemaking/"):
            assert ch["encoding"] == "json" and ch["schemaEncoding"] == "jsonschema"
            assert json.loads(ch["schema"])["type"] == "object"
        else:  # a passed-through input topic
            assert ch["encoding"] == "cdr" and ch["schemaEncoding"] == "ros2msg"
    return {ch["topic"]: ch["id"] for ch in adv["channels"]}


def _binary(data: bytes) -> tuple[int, int, dict]:
    op, sub, t = struct.unpack_from("<BIQ", data)
    assert op == 1
    return sub, t, json.loads(data[13:])


def test_server_publishes_to_subscriptions_only() -> None:
    server = LiveServer(0)
    try:
        assert server.url.startswith("ws://127.0.0.1:")
        with connect(server.url, subprotocols=[SUBPROTOCOL], open_timeout=10) as ws:
            assert ws.subprotocol == SUBPROTOCOL
            ids = _hello(ws)
            assert {"/sensemaking/tracks", "/sensemaking/annotations"} <= set(ids)
            ws.send(
                json.dumps(
                    {
                        "op": "subscribe",
                        "subscriptions": [{"id": 7, "channelId": ids["/sensemaking/tracks"]}],
                    }
                )
            )
            assert server.wait_for_subscriber(10)
            from sensemaking.results import FrameResult

            dets = Detections(
                np.array([[1.0, 2.0, 30.0, 40.0]]),
                0.9,
                3,
                tracker_id=5,
                data={
                    "state": np.array([0]),
                    "occluder": np.array([-1]),
                    "hidden_frames": np.array([0]),
                },
            )
            sink = LiveSink(server, lambda f: 1000 + f)
            sink.frame(FrameResult(frame=3, tracks=dets, events=[]), [])
            sub, t, msg = _binary(ws.recv(timeout=10))  # annotations were not subscribed to
            assert (sub, t, msg["frame"]) == (7, 1003, 3)
            assert msg["tracks"][0]["id"] == 5 and msg["tracks"][0]["x2"] == 30.0
            ws.send(json.dumps({"op": "unsubscribe", "subscriptionIds": [7]}))
            ws.send(
                json.dumps(
                    {
                        "op": "subscribe",
                        "subscriptions": [{"id": 8, "channelId": ids["/sensemaking/annotations"]}],
                    }
                )
            )
            ws.send("not json")  # ignored
            import time

            time.sleep(0.3)
            sink.frame(FrameResult(frame=4, tracks=dets, events=[]), [])
            sub, t, msg = _binary(ws.recv(timeout=10))
            assert sub == 8 and msg["points"][0]["points"][0] == {"x": 1.0, "y": 2.0}
    finally:
        server.close()


def test_live_cli_run_is_received(tmp_path: Path) -> None:
    from sensemaking.ros.convert import write_detection_bag

    frames = [
        (f, Detections(np.array([[10.0 + 3 * f, 20.0, 60.0 + 3 * f, 90.0]]), 0.9, 3))
        for f in range(30)
    ]
    bag = write_detection_bag(tmp_path / "b", frames, fps=10.0)
    port = _free_port()
    codes: list[int] = []
    run = threading.Thread(
        target=lambda: codes.append(
            main(
                [
                    "-q",
                    "track",
                    "--detections",
                    str(bag),
                    "--output",
                    str(tmp_path / "o.mcap"),
                    "--passthrough",
                    "--stories",
                    "--live",
                    "--live-port",
                    str(port),
                    "--live-wait",
                    "20",
                ]
            )
        )
    )
    run.start()
    got: list[dict] = []
    stories: list[tuple[int, dict]] = []
    raw_detections = 0
    try:
        for _ in range(100):  # the server starts with the run
            try:
                ws = connect(f"ws://127.0.0.1:{port}", subprotocols=[SUBPROTOCOL], open_timeout=5)
                break
            except OSError:
                import time

                time.sleep(0.1)
        with ws:
            ids = _hello(ws)
            # the input's topics are advertised before the run too, as CDR
            ws.send(
                json.dumps(
                    {
                        "op": "subscribe",
                        "subscriptions": [
                            {"id": 1, "channelId": ids["/sensemaking/tracks"]},
                            {"id": 2, "channelId": ids["/detections"]},
                            {"id": 3, "channelId": ids["/sensemaking/stories"]},
                        ],
                    }
                )
            )
            for message in ws:  # until the server closes at the end of the run
                if isinstance(message, str):
                    continue
                sub = struct.unpack_from("<I", message, 1)[0]
                if sub == 1:
                    got.append(_binary(message)[2])
                elif sub == 3:
                    stories.append(_binary(message)[1:])
                else:
                    raw_detections += 1
    finally:
        run.join(60)
    assert codes == [0]
    assert [m["frame"] for m in got] == list(range(30))  # every frame, in order
    assert all(len(m["tracks"]) == 1 and m["tracks"][0]["id"] == 1 for m in got[1:])
    assert raw_detections == 30  # the input's own topic, passed through
    # the story of the one track, at the end of the run, stamped at its last frame's time
    assert [(m["track"], m["first_frame"], m["last_frame"]) for _, m in stories] == [(1, 0, 29)]
    assert stories[0][0] == 1_700_000_000_000_000_000 + 29 * 100_000_000
    assert stories[0][1]["text"].startswith("Track 1 (car)")
