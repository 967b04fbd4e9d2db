"""The ``track`` verb's ROS 2 options and the seams it calls: a bag as ``--detections``, an
``.mcap`` ``--output``, ``--passthrough`` and ``--live``. Imports nothing of the extra until an
option asks for it (then a missing extra is one line naming ``sensemaking[ros]``)."""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path
from typing import Any

from sensemaking.errors import InputError
from sensemaking.ros import is_bag, is_mcap_output

__all__ = ["add_options", "open_input", "RosInput", "run_stories", "tracks_sink", "extra_sinks"]

log = logging.getLogger(__name__)


def add_options(p: argparse.ArgumentParser) -> None:
    """The ROS 2 / MCAP options of ``sensemaking track`` (extra ``ros``; docs/ROS.md)."""
    g = p.add_argument_group("ROS 2 bags, MCAP and Foxglove (extra 'ros'; docs/ROS.md)")
    g.add_argument(
        "--topic",
        default=None,
        help="with --detections BAG (.mcap, .db3 or a bag folder): the vision_msgs/msg/"
        "Detection2DArray topic (default: the bag's only one)",
    )
    g.add_argument(
        "--classes",
        default=None,
        metavar="TABLE",
        help="class table of the bag's class_id strings: 0=pedestrian,2=car (or a JSON file "
        '{"0": "pedestrian"}; NAME ignore drops a class). Default: class_id is one of our '
        "class names (car, pedestrian, cyclist, ...)",
    )
    g.add_argument(
        "--camera-info",
        default=None,
        metavar="TOPIC",
        help="the sensor_msgs/msg/CameraInfo topic for the image size and intrinsics "
        "(default: the bag's only one, if any)",
    )
    g.add_argument(
        "--passthrough",
        action="store_true",
        help="copy every topic of the input bag into --output RUN.mcap (one file holds the "
        "drive and its explanation) and into the --live view",
    )
    g.add_argument(
        "--stories",
        action="store_true",
        help="with --output RUN.mcap or --live: when the run ends, each track's story (what "
        "`explain` says of it) on /sensemaking/stories; keeps the run's scene in memory and "
        "costs about a third more time on KITTI with a camera model (docs/ROS.md)",
    )
    g.add_argument(
        "--live",
        action="store_true",
        help="serve the run on Foxglove's WebSocket protocol at ws://127.0.0.1:PORT while it "
        "is tracked (open it in Foxglove: Open connection)",
    )
    g.add_argument(
        "--live-port",
        type=int,
        default=None,
        metavar="PORT",
        help="port of --live (default 8765, Foxglove's; 0 picks a free one)",
    )
    g.add_argument(
        "--live-wait",
        type=float,
        default=0.0,
        metavar="S",
        help="with --live: wait up to S seconds for a viewer to subscribe before tracking",
    )


class RosInput:
    """A bag given as ``--detections``: its reader, checked before any work (opened by
    :meth:`info`, after the outputs are checked), and the sinks that take its messages
    (``--passthrough``)."""

    def __init__(self, args: argparse.Namespace, path: Path):
        from sensemaking.classes import class_id
        from sensemaking.ros.reader import ClassTable

        default = None
        if args.class_name is not None:
            try:
                default = class_id(args.class_name)
            except KeyError:
                raise InputError(f"--class {args.class_name}: unknown class name") from None
        self.args, self.path = args, path
        self.classes = ClassTable.parse(args.classes, default)
        self.targets: list[Any] = []  # sinks with passthrough(connection, time, data, msgdef)
        self.batch = 0  # messages read ahead of the tracker (0: the reader's own batch)

    def info(self) -> tuple[float | None, tuple[int, int] | None, int | None]:
        """Open and check the bag; (fps, image size, number of frames) as ``_sequence_info``
        gives them for files (the size is set as ``--image-size`` from the CameraInfo)."""
        from sensemaking.config import MAX_IMAGE_SIDE, parse_size
        from sensemaking.ros.reader import BagReader

        args, path = self.args, self.path
        self.reader = BagReader(
            path,
            args.topic,
            self.classes,
            first_frame=1 if args.format == "mot" else 0,
            fps=args.fps,
            camera_topic=args.camera_info,
        )
        try:
            cam = self.reader.camera
            if cam is not None and args.image_size is None and cam.width > 0 and cam.height > 0:
                if max(cam.width, cam.height) > MAX_IMAGE_SIDE:
                    raise InputError(
                        f"{cam.topic}: image size {cam.width}x{cam.height} is implausible", path
                    )
                args.image_size = f"{cam.width}x{cam.height}"
            if (
                cam is not None
                and cam.fx > 0
                and args.camera is None
                and (args.warnings or args.scene or wants_stories(args))
            ):
                # a level camera: the horizon at the principal point's row; KITTI's height
                args.camera = f"{cam.fx},1.65,{cam.cy},{cam.cx}"
                log.info("camera model from %s: --camera %s", cam.topic, args.camera)
            size = parse_size(args.image_size) if args.image_size else None
            log.info("checking %s before tracking", path)
            self.summary = self.reader.scan(size)
        except BaseException:
            self.reader.close()
            raise
        s = self.summary
        length = None if s.last is None else s.last - s.first + 1
        return s.fps, None, length

    def frames(self, args: argparse.Namespace, config: Any) -> tuple[Any, int, Any, list[int]]:
        """(frames, first frame, last frame, class ids) as ``_file_frames`` gives them."""
        from sensemaking.classes import check_kitti_class

        s = self.summary
        if not is_mcap_output(args.output):
            for c in s.classes:
                check_kitti_class(args.format, c, f"{self.reader.path}: class {c}")

        def stream() -> Any:
            # the sinks that take the bag's messages are made after this: asked at the start
            raw = self._raw if self.targets else None
            try:
                yield from self.reader.frames(config.image_size, raw, batch=self.batch or None)
            finally:  # the stamps the sinks still ask for are kept by the reader, not the file
                self.reader.close()

        return stream(), s.first, s.last, list(s.classes)

    def _raw(self, connection: Any, log_time: int, data: bytes) -> None:
        for sink in self.targets:
            sink.passthrough(connection, log_time, data, self.reader.msgdef)


def open_input(args: argparse.Namespace) -> RosInput | None:
    """The bag of ``--detections`` (None when it is a text file); checks that the ROS options
    are used where they mean something. Sets ``--format`` (default kitti: a drive) and, from
    the CameraInfo, ``--image-size`` (and ``--camera`` for --warnings/--scene) when not given."""
    files = list(getattr(args, "detection_files", None) or [])
    bag = bool(files) and any(is_bag(f) for f in files)
    mcap_out = is_mcap_output(args.output)
    if not bag:
        for name, given in (
            ("--topic", args.topic),
            ("--classes", args.classes),
            ("--camera-info", args.camera_info),
            ("--passthrough", args.passthrough),
        ):
            if given:
                raise InputError(
                    f"{name} reads a ROS 2 bag: give --detections DRIVE.mcap (or a .db3 file "
                    "or a bag folder)"
                )
    if args.passthrough and not (mcap_out or args.live):
        raise InputError(
            "--passthrough copies the bag's topics into --output RUN.mcap or the --live view"
        )
    if (args.live_port is not None or args.live_wait) and not args.live:
        raise InputError("--live-port and --live-wait go with --live")
    if args.live_port is not None and not 0 <= args.live_port <= 65535:
        raise InputError(f"--live-port must be 0..65535, got {args.live_port}")
    if not (args.live_wait >= 0 and args.live_wait < 1e6):
        raise InputError(f"--live-wait must be a number of seconds >= 0, got {args.live_wait}")
    if mcap_out and "{class}" in str(args.output):
        raise InputError("--output RUN.mcap holds every class: no {class} field", args.output)
    if not bag:
        return None
    if len(files) > 1:
        raise InputError(
            "a bag is the whole input: give one --detections BAG (its classes come from the "
            "messages and --classes)",
            files[0],
        )
    if args.format is None:
        args.format = "kitti"
    return RosInput(args, files[0])


def wants_stories(args: argparse.Namespace) -> bool:
    """True when the run's stories are told at its end: ``--stories`` with ``--output RUN.mcap``
    or ``--live`` (InputError for ``--stories`` without either)."""
    if not getattr(args, "stories", False):
        return False
    if not (is_mcap_output(args.output) or bool(args.live)):
        raise InputError("--stories needs --output RUN.mcap or --live (where they are written)")
    return True


def run_stories(args: argparse.Namespace, config: Any, camera: Any) -> Any:
    """The :class:`~sensemaking.ros.channels.RunStories` of ``--output RUN.mcap`` and
    ``--live`` (None for neither); its recorder goes to the pipeline. ``camera``: the
    :class:`~sensemaking.reasoning.egomotion.CameraModel` the ``--scene`` file would store."""
    if not wants_stories(args):
        return None
    from sensemaking.ros.channels import RunStories

    return RunStories(config.fps, config.image_size, None if camera is None else camera.to_json())


def _time_of(config: Any, bag: RosInput | None) -> Any:
    if bag is not None:
        return bag.reader.time_of
    period = 1e9 / float(config.fps)
    return lambda frame: int(round(frame * period))


def tracks_sink(
    args: argparse.Namespace, config: Any, bag: RosInput | None, stories: Any = None
) -> Any:
    """The :class:`~sensemaking.ros.writer.McapSink` of ``--output RUN.mcap``."""
    from sensemaking.ros.writer import McapSink

    source = bag.reader.path if bag is not None else args.detections or args.source
    meta = {
        "source": str(source),
        "fps": f"{float(config.fps):g}",
        "image_size": "" if config.image_size is None else "{}x{}".format(*config.image_size),
    }
    if bag is not None:
        meta["topic"] = bag.reader.topic
    sink = McapSink(
        args.output,
        time_of=_time_of(config, bag),
        metadata=meta,
        stories=stories,
    )
    if bag is not None and args.passthrough:
        bag.targets.append(sink)
    return sink


def extra_sinks(
    args: argparse.Namespace, config: Any, bag: RosInput | None, stories: Any = None
) -> list[Any]:
    """The :class:`~sensemaking.ros.live.LiveSink` of ``--live`` (serving from now on)."""
    if not args.live:
        return []
    from sensemaking.ros.live import DEFAULT_PORT, LiveServer, LiveSink

    server = LiveServer(DEFAULT_PORT if args.live_port is None else args.live_port)
    if not getattr(args, "quiet", False):
        print(f"sensemaking track: serving live at {server.url}", file=sys.stderr, flush=True)
    sink = LiveSink(server, _time_of(config, bag), stories)
    if bag is not None and args.passthrough:
        bag.targets.append(sink)
        bag.batch = 1  # the viewer sees the input's messages as their frames are tracked
        for conn in bag.reader.all_connections:  # subscribable before the run starts
            sink.advertise(conn, bag.reader.msgdef)
    if args.live_wait:
        try:
            if not server.wait_for_subscriber(args.live_wait):
                log.warning("no viewer subscribed within %g s: tracking anyway", args.live_wait)
        except BaseException:  # Ctrl-C while waiting: the sink is not the caller's yet
            server.close()
            raise
    return [sink]
