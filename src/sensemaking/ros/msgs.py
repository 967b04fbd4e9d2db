"""The ROS 2 message types read and written, as ``.msg`` text for bags without definitions.

A ROS 2 MCAP file carries each message's definition (rosbags reads the types from it); a
``.db3`` bag does not, so its types come from ROS 2 Humble's common interfaces (shipped with
rosbags) plus ``vision_msgs`` (not among them), defined here as vision_msgs 4.x (Humble and
later) publishes them.
"""

from __future__ import annotations

from typing import Any

from sensemaking.ros import require_ros

__all__ = ["DETECTION_ARRAY", "CAMERA_INFO", "VISION_MSGS", "typestore", "DETECTION_TYPES"]

DETECTION_ARRAY = "vision_msgs/msg/Detection2DArray"
CAMERA_INFO = "sensor_msgs/msg/CameraInfo"
#: the detection types read (ROS 1 names as ROS 2 bags converted from ROS 1 spell them too)
DETECTION_TYPES = (DETECTION_ARRAY, "vision_msgs/Detection2DArray")

#: vision_msgs 4.x definitions (Humble, Iron, Jazzy): type name -> .msg text
VISION_MSGS: dict[str, str] = {
    "vision_msgs/msg/Point2D": "float64 x\nfloat64 y\n",
    "vision_msgs/msg/Pose2D": "vision_msgs/Point2D position\nfloat64 theta\n",
    "vision_msgs/msg/BoundingBox2D": (
        "vision_msgs/Pose2D center\nfloat64 size_x\nfloat64 size_y\n"
    ),
    "vision_msgs/msg/ObjectHypothesis": "string class_id\nfloat64 score\n",
    "vision_msgs/msg/ObjectHypothesisWithPose": (
        "vision_msgs/ObjectHypothesis hypothesis\ngeometry_msgs/PoseWithCovariance pose\n"
    ),
    "vision_msgs/msg/Detection2D": (
        "std_msgs/Header header\nvision_msgs/ObjectHypothesisWithPose[] results\n"
        "vision_msgs/BoundingBox2D bbox\nstring id\n"
    ),
    "vision_msgs/msg/Detection2DArray": (
        "std_msgs/Header header\nvision_msgs/Detection2D[] detections\n"
    ),
}


def typestore() -> Any:
    """A rosbags typestore of ROS 2 Humble's common interfaces plus :data:`VISION_MSGS`."""
    stores = require_ros("rosbags.typesys")
    store = stores.get_typestore(stores.Stores.ROS2_HUMBLE)
    types: dict[str, Any] = {}
    for name, text in VISION_MSGS.items():
        types.update(stores.get_types_from_msg(text, name))
    store.register(types)
    return store
