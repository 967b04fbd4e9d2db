"""Detections as a ROS 2 bag: ``vision_msgs/msg/Detection2DArray`` messages, one a frame, and
a ``sensor_msgs/msg/CameraInfo``, written with rosbags (no ROS needed). For tests, benchmarks
and users who want to look at a text file's detections in a ROS tool."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from sensemaking.classes import class_name
from sensemaking.detections import Detections
from sensemaking.ros import require_ros
from sensemaking.ros.msgs import CAMERA_INFO, DETECTION_ARRAY, typestore

__all__ = ["write_detection_bag"]


def _time(store: Any, ns: int) -> Any:
    sec, nsec = divmod(int(ns), 1_000_000_000)
    return store.types["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec)


def _array(store: Any, dets: Detections, stamp: Any, frame_id: str) -> Any:
    t = store.types
    header = t["std_msgs/msg/Header"](stamp=stamp, frame_id=frame_id)
    items = []
    pose = t["geometry_msgs/msg/PoseWithCovariance"](
        pose=t["geometry_msgs/msg/Pose"](
            position=t["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
            orientation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
        ),
        covariance=np.zeros(36),
    )
    for box, score, cid in zip(dets.xyxy, dets.confidence, dets.class_id, strict=True):
        x1, y1, x2, y2 = (float(v) for v in box)
        hyp = t["vision_msgs/msg/ObjectHypothesisWithPose"](
            hypothesis=t["vision_msgs/msg/ObjectHypothesis"](
                class_id=class_name(int(cid)), score=float(score)
            ),
            pose=pose,
        )
        bbox = t["vision_msgs/msg/BoundingBox2D"](
            center=t["vision_msgs/msg/Pose2D"](
                position=t["vision_msgs/msg/Point2D"](x=(x1 + x2) / 2.0, y=(y1 + y2) / 2.0),
                theta=0.0,
            ),
            size_x=x2 - x1,
            size_y=y2 - y1,
        )
        items.append(
            t["vision_msgs/msg/Detection2D"](header=header, results=[hyp], bbox=bbox, id="")
        )
    return t[DETECTION_ARRAY](header=header, detections=items)


def write_detection_bag(
    path: Path,
    frames: Iterable[tuple[int, Detections]],
    *,
    fps: float,
    topic: str = "/detections",
    image_size: tuple[int, int] | None = None,
    camera: tuple[float, float, float, float] | None = None,
    t0_ns: int = 1_700_000_000_000_000_000,
    storage: str = "mcap",
    frame_id: str = "camera",
) -> Path:
    """Write a ROS 2 bag folder ``path`` (``storage``: ``"mcap"`` or ``"sqlite3"``) with one
    Detection2DArray on ``topic`` per ``(frame, Detections)`` (give every frame, empty ones
    too, as a detector publishes), stamped ``t0_ns + frame / fps`` seconds; the classes as our
    class names. With ``image_size`` a CameraInfo on ``/camera/camera_info`` (intrinsics
    ``camera`` = fx, fy, cx, cy in pixels, or zeros). Returns ``path``."""

    rosbag2 = require_ros("rosbags.rosbag2")
    store = typestore()
    plugin = rosbag2.StoragePlugin.MCAP if storage == "mcap" else rosbag2.StoragePlugin.SQLITE3
    with rosbag2.Writer(path, version=9, storage_plugin=plugin) as writer:
        conn = writer.add_connection(topic, DETECTION_ARRAY, typestore=store)
        cam = None
        if image_size is not None:
            cam = writer.add_connection("/camera/camera_info", CAMERA_INFO, typestore=store)
        for k, (frame, dets) in enumerate(frames):
            ns = t0_ns + int(round(frame * 1e9 / fps))
            stamp = _time(store, ns)
            if cam is not None and k == 0 and image_size is not None:
                fx, fy, cx, cy = camera or (0.0, 0.0, 0.0, 0.0)
                info = store.types[CAMERA_INFO](
                    header=store.types["std_msgs/msg/Header"](stamp=stamp, frame_id=frame_id),
                    height=int(image_size[1]),
                    width=int(image_size[0]),
                    distortion_model="plumb_bob",
                    d=np.zeros(5),
                    k=np.array([fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0]),
                    r=np.eye(3).ravel(),
                    p=np.array([fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0]),
                    binning_x=0,
                    binning_y=0,
                    roi=store.types["sensor_msgs/msg/RegionOfInterest"](
                        x_offset=0, y_offset=0, height=0, width=0, do_rectify=False
                    ),
                )
                writer.write(cam, ns, store.serialize_cdr(info, CAMERA_INFO))
            msg = _array(store, dets, stamp, frame_id)
            writer.write(conn, ns, store.serialize_cdr(msg, DETECTION_ARRAY))
    return Path(path)
