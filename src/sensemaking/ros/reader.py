"""Detections from a ROS 2 bag or MCAP file: ``vision_msgs/msg/Detection2DArray`` messages of
one topic become ``(frame, Detections)`` pairs, in the order of their header stamps.

Time: each message's ``header.stamp`` is its time. Frames are numbered at the nominal rate
(``--fps``, else the median interval of the first :data:`RATE_SAMPLE` stamps, rounded to
0.001 frames per second): message k goes to frame ``max(f[k-1] + 1, first + round((t[k] -
t[0]) * fps))``, so a dropped message leaves an empty frame (tracks age by time, not by
message count) and jitter never puts two messages in one frame. Stamps must increase in the
bag's order. Memory: a batch of :attr:`BagReader.BATCH` messages (the first
:data:`RATE_SAMPLE`, until the rate is known), and the boxes of the checking pass kept for the
run when there are at most :attr:`BagReader.KEEP_BOXES`.

Classes: a hypothesis's ``class_id`` string is mapped by a :class:`ClassTable` (``--classes``);
the detection's class is that of its best-scored hypothesis, its score that hypothesis's.
"""

from __future__ import annotations

import logging
import struct
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sensemaking.detections import MAX_FRAME, Detections, validate_detections
from sensemaking.errors import TOO_DEEP, InputError
from sensemaking.io.text import load_json, read_input_text
from sensemaking.ros import require_ros
from sensemaking.ros.msgs import CAMERA_INFO, DETECTION_TYPES, typestore

__all__ = ["ClassTable", "BagReader", "CameraInfo", "BagSummary", "RATE_SAMPLE"]

log = logging.getLogger(__name__)

#: stamps whose median interval gives the nominal rate when --fps is not given
RATE_SAMPLE = 1000
#: the class name that drops a class id's detections (``--classes 7=ignore``)
IGNORE = "ignore"


class ClassTable:
    """Detection ``class_id`` strings -> class ids of :mod:`sensemaking.classes`.

    A string is looked up in the table (``--classes``: ``"0=pedestrian,2=car"``, or a JSON file
    ``{"0": "pedestrian", "2": "car"}``; the name ``ignore`` drops that class's detections),
    else taken as one of our class names (``car``, ``Pedestrian``, ``cyclist``, ...). Numbers
    are not guessed (a COCO 2 is not our 2): an unmapped number is an error naming the table.
    An empty string (no class given) is ``default`` (``--class``), else an error.
    """

    def __init__(self, table: dict[str, str] | None = None, default: int | None = None):
        from sensemaking.classes import class_id

        self.default = default
        self.table: dict[str, int | None] = {}
        for key, name in (table or {}).items():
            if name.strip().lower() == IGNORE:
                self.table[key.strip()] = None
                continue
            try:
                self.table[key.strip()] = class_id(name)
            except KeyError:
                raise InputError(
                    f"--classes {key}={name}: unknown class name {name!r} (names in "
                    "sensemaking.classes, e.g. pedestrian, car, cyclist; or 'ignore')"
                ) from None
        self._cache: dict[str, int | None] = {}

    @classmethod
    def parse(cls, text: str | None, default: int | None = None) -> ClassTable:
        """From the ``--classes`` option: ``ID=NAME,...`` or the path of a JSON object."""
        if text is None:
            return cls(None, default)
        path = Path(text)
        if path.suffix.lower() == ".json" or path.is_file():
            try:
                data = load_json(read_input_text(path))
            except OSError as exc:
                raise InputError(f"cannot read the class table: {exc.strerror}", path) from None
            except InputError:
                raise
            except ValueError as exc:
                raise InputError(f"the class table is not JSON: {exc}", path) from None
            except RecursionError:
                raise InputError(TOO_DEEP, path) from None
            if not isinstance(data, dict) or not all(isinstance(v, str) for v in data.values()):
                raise InputError('the class table must be a JSON object {"ID": "name"}', path)
            return cls({str(k): v for k, v in data.items()}, default)
        table: dict[str, str] = {}
        for item in text.split(","):
            key, sep, name = item.partition("=")
            if not sep or not key.strip() or not name.strip():
                raise InputError(
                    f"--classes must look like 0=pedestrian,2=car (or name a JSON file), got "
                    f"{text!r}"
                )
            table[key.strip()] = name.strip()
        return cls(table, default)

    def lookup(self, key: str) -> int | None:
        """Our class id of a detection's ``class_id`` (None: dropped). Raises InputError."""
        try:
            return self._cache[key]
        except KeyError:
            pass
        from sensemaking.classes import class_id

        k = key.strip()
        if k in self.table:
            value = self.table[k]
        elif not k:
            if self.default is None:
                raise InputError(
                    "a detection has no class (empty class_id): give --class NAME for it"
                )
            value = self.default
        else:
            try:
                value = class_id(k)
            except KeyError:
                raise InputError(
                    f"class_id {k!r} is not in the class table: map it with --classes "
                    f"{k}=NAME (e.g. {k}=car, or {k}=ignore to drop it; see docs/ROS.md)"
                ) from None
        self._cache[key] = value
        return value


@dataclass(frozen=True)
class CameraInfo:
    """The first ``sensor_msgs/msg/CameraInfo`` of the camera topic: image ``width``, ``height``
    (pixels) and the intrinsics ``fx``, ``fy``, ``cx``, ``cy`` (pixels; 0 when not given)."""

    topic: str
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float


@dataclass(frozen=True)
class BagSummary:
    """What the checking pass found: ``messages`` on the topic, ``first``/``last`` frame,
    ``fps`` (nominal), ``t0`` (the first stamp, ns), ``detections`` kept, ``dropped`` (zero
    width or height), ``classes`` (sorted ids)."""

    messages: int
    first: int
    last: int | None
    fps: float
    t0: int | None
    detections: int
    dropped: int
    classes: tuple[int, ...]


def _generic(msg: Any) -> tuple[int, list[tuple]]:
    """(stamp ns, boxes) of a decoded Detection2DArray as :func:`parse_detection_array` gives
    them; vision_msgs 4 (``hypothesis``, ``center.position``) or 3 (fields on the result, a
    geometry_msgs Pose2D center)."""
    st = msg.header.stamp
    out = []
    for d in msg.detections:
        box = d.bbox
        pos = getattr(box.center, "position", box.center)
        results = []
        for r in d.results:
            hyp = getattr(r, "hypothesis", r)
            results.append((str(getattr(hyp, "class_id", getattr(hyp, "id", ""))), hyp.score))
        out.append((float(pos.x), float(pos.y), float(box.size_x), float(box.size_y), results))
    return int(st.sec) * 1_000_000_000 + int(st.nanosec), out


def _boxes_of(items: list[tuple], table: ClassTable) -> list[tuple]:
    """(cx, cy, w, h, score, class id or -1 for dropped) of a message's detections; a
    detection's class and score are those of its best-scored hypothesis (none: the table's
    default class, score 1)."""
    out: list[tuple] = []
    for cx, cy, w, h, results in items:
        name, score = max(results, key=lambda r: r[1]) if results else ("", 1.0)
        c = table.lookup(name)
        out.append((cx, cy, w, h, score, -1 if c is None else c))
    return out


_U32 = struct.Struct("<I")
_TIME = struct.Struct("<iI")
_F64 = struct.Struct("<d")
_BOX = struct.Struct("<5d")
#: geometry_msgs/PoseWithCovariance: 7 + 36 float64
_POSE_BYTES = 43 * 8


def parse_detection_array(raw: bytes | memoryview) -> tuple[int, list[tuple]] | None:
    """A little-endian CDR ``vision_msgs/msg/Detection2DArray`` (vision_msgs 4 layout) read
    directly: (stamp ns, [(cx, cy, size_x, size_y, [(class_id, score), ...]), ...]), or None
    when the bytes do not end where that layout ends (another layout: the generic decoder).
    About 20 times faster than the generic decoder, which dominates reading otherwise."""
    buf = memoryview(raw)
    end = len(buf)
    if end < 16 or buf[1] != 1:  # CDR_LE (0x0001) only
        return None
    try:
        sec, nsec = _TIME.unpack_from(buf, 4)
        o = 12
        o += 4 + _U32.unpack_from(buf, o)[0]  # frame_id
        o += -(o - 4) % 4
        (count,) = _U32.unpack_from(buf, o)
        o += 4
        out = []
        for _ in range(count):
            o += -(o - 4) % 4
            o += 8  # the detection's stamp
            o += 4 + _U32.unpack_from(buf, o)[0]  # its frame_id
            o += -(o - 4) % 4
            (n_results,) = _U32.unpack_from(buf, o)
            o += 4
            results = []
            for _ in range(n_results):
                o += -(o - 4) % 4
                (length,) = _U32.unpack_from(buf, o)
                if length == 0 or o + 4 + length > end:
                    return None
                name = bytes(buf[o + 4 : o + 3 + length]).decode("utf-8", "replace")
                o += 4 + length
                o += -(o - 4) % 8
                (score,) = _F64.unpack_from(buf, o)
                o += 8 + _POSE_BYTES
                results.append((name, score))
            o += -(o - 4) % 8
            cx, cy, _theta, sx, sy = _BOX.unpack_from(buf, o)
            o += 40
            o += 4 + _U32.unpack_from(buf, o)[0]  # id
            out.append((cx, cy, sx, sy, results))
    except struct.error:
        return None
    if not 0 <= end - o < 8:  # at most the padding to an 8-byte boundary is left over
        return None
    return sec * 1_000_000_000 + nsec, out


#: the fields of the types a Detection2DArray is made of (vision_msgs 4), by type: a bag
#: whose definitions say this is read directly (:func:`parse_detection_array`)
_LAYOUT: dict[str, list[str]] = {
    "vision_msgs/Detection2DArray": [
        "std_msgs/Header header",
        "vision_msgs/Detection2D[] detections",
    ],
    "std_msgs/Header": ["builtin_interfaces/Time stamp", "string frame_id"],
    "builtin_interfaces/Time": ["int32 sec", "uint32 nanosec"],
    "vision_msgs/Detection2D": [
        "std_msgs/Header header",
        "vision_msgs/ObjectHypothesisWithPose[] results",
        "vision_msgs/BoundingBox2D bbox",
        "string id",
    ],
    "vision_msgs/ObjectHypothesisWithPose": [
        "vision_msgs/ObjectHypothesis hypothesis",
        "geometry_msgs/PoseWithCovariance pose",
    ],
    "vision_msgs/ObjectHypothesis": ["string class_id", "float64 score"],
    "geometry_msgs/PoseWithCovariance": ["geometry_msgs/Pose pose", "float64[36] covariance"],
    "geometry_msgs/Pose": ["geometry_msgs/Point position", "geometry_msgs/Quaternion orientation"],
    "geometry_msgs/Point": ["float64 x", "float64 y", "float64 z"],
    "geometry_msgs/Quaternion": ["float64 x", "float64 y", "float64 z", "float64 w"],
    "vision_msgs/BoundingBox2D": ["vision_msgs/Pose2D center", "float64 size_x", "float64 size_y"],
    "vision_msgs/Pose2D": ["vision_msgs/Point2D position", "float64 theta"],
    "vision_msgs/Point2D": ["float64 x", "float64 y"],
}
#: the first fields of sensor_msgs/msg/CameraInfo, read by :func:`parse_camera_info`
_CAMERA_FIELDS = [
    "std_msgs/Header header",
    "uint32 height",
    "uint32 width",
    "string distortion_model",
    "float64[] d",
    "float64[9] k",
]
_PRIMITIVES = frozenset(
    "bool byte char float32 float64 int8 uint8 int16 uint16 int32 uint32 int64 uint64 string "
    "wstring".split()
)


def _type_name(name: str, package: str) -> str:
    """``pkg/Type`` of a field's type as a definition writes it (``pkg/msg/Type``, ``pkg/Type``
    or, within its own package, ``Type``); primitives and array suffixes kept."""
    base, bracket, rest = name.partition("[")
    if base.split("<=", 1)[0] in _PRIMITIVES:
        return name
    parts = base.split("/")
    if len(parts) == 1:
        return f"{package}/{base}{bracket}{rest}"
    return f"{parts[0]}/{parts[-1]}{bracket}{rest}"


def _sections(definition: str, top: str) -> dict[str, list[str]]:
    """``pkg/Type`` -> its fields (``"type name"``; comments, constants and defaults aside) of
    a ROS 2 ``.msg`` definition: the top type (``top``) then its ``MSG:`` sections."""
    found: dict[str, list[str]] = {}
    for k, section in enumerate(definition.split("\n" + "=" * 80 + "\n")):
        lines = section.splitlines()
        name = top
        if k:
            if not lines or not lines[0].startswith("MSG: "):
                return {}
            name = _type_name(lines[0][5:].strip(), "")
            lines = lines[1:]
        package = name.split("/", 1)[0]
        fields = []
        for line in lines:
            words = line.split("#", 1)[0].split()
            if len(words) < 2 or "=" in words[1] or (len(words) > 2 and words[2] == "="):
                continue  # blank, comment or constant
            fields.append(f"{_type_name(words[0], package)} {words[1]}")
        found[name] = fields
    return found


def has_layout(definition: str) -> bool:
    """True when a ROS 2 ``.msg`` definition of Detection2DArray (the top type, then ``MSG:``
    sections of its parts) has exactly the vision_msgs 4 fields :func:`parse_detection_array`
    reads (names and types; comments, constants and defaults aside)."""
    found = _sections(definition, "vision_msgs/Detection2DArray")
    return all(found.get(name) == fields for name, fields in _LAYOUT.items())


def parse_camera_info(raw: bytes | memoryview) -> tuple[int, int, list[float]] | None:
    """(width, height, k) of a little-endian CDR ``sensor_msgs/msg/CameraInfo``, or None."""
    buf = memoryview(raw)
    if len(buf) < 16 or buf[1] != 1:
        return None
    try:
        o = 12
        o += 4 + _U32.unpack_from(buf, o)[0]  # frame_id
        o += -(o - 4) % 4
        height, width = struct.unpack_from("<II", buf, o)
        o += 8
        o += 4 + _U32.unpack_from(buf, o)[0]  # distortion_model
        o += -(o - 4) % 4
        (n_d,) = _U32.unpack_from(buf, o)
        o += 4
        o += -(o - 4) % 8
        o += 8 * n_d
        k = list(struct.unpack_from("<9d", buf, o))
    except struct.error:
        return None
    return int(width), int(height), k


class _Format:
    def __init__(self, name: str):
        self.name = name


class _Definition:
    def __init__(self, encoding: str, data: str):
        self.format = _Format({"ros2msg": "MSG", "ros2idl": "IDL"}.get(encoding, "NONE"))
        self.data = data


class _Connection:
    """A channel of an MCAP file as rosbags describes a connection (what is used of it)."""

    def __init__(self, cid: int, topic: str, msgtype: str, msgdef: _Definition):
        self.id, self.topic, self.msgtype, self.msgdef = cid, topic, msgtype, msgdef


class _McapFile:
    """An MCAP file read with the mcap library, for what :class:`BagReader` asks of rosbags'
    AnyReader (connections, raw messages in log-time order, decoding): opening it costs no
    type parsing, which rosbags does for every type of the file (a tenth of a second)."""

    def __init__(self, path: Path):
        reader_mod = require_ros("mcap.reader")
        self._handle = open(path, "rb")  # noqa: SIM115 - closed by close()
        try:
            self._reader = reader_mod.make_reader(self._handle)
            summary = self._reader.get_summary()
            if summary is None:
                raise ValueError("no summary")
        except BaseException:
            self._handle.close()
            raise
        self.connections = []
        self._by_id: dict[int, _Connection] = {}
        for ch in summary.channels.values():
            schema = summary.schemas.get(ch.schema_id)
            if schema is None or ch.message_encoding != "cdr":
                continue  # not a ROS 2 topic: not read, not copied
            conn = _Connection(
                ch.id, ch.topic, schema.name, _Definition(schema.encoding, schema.data.decode())
            )
            self.connections.append(conn)
            self._by_id[ch.id] = conn
        self._store: Any = None

    def messages(self, connections: Sequence[Any]) -> Iterator[tuple[Any, int, bytes]]:
        topics = sorted({c.topic for c in connections})
        for _, channel, message in self._reader.iter_messages(topics=topics, log_time_order=True):
            conn = self._by_id.get(channel.id)
            if conn is not None:
                yield conn, message.log_time, message.data

    @property
    def typestore(self) -> Any:
        """The types of the file's definitions (parsed on first use)."""
        if self._store is None:
            stores = require_ros("rosbags.typesys")
            types: dict[str, Any] = {}
            for conn in self.connections:
                if conn.msgdef.format.name == "MSG":
                    types.update(stores.get_types_from_msg(conn.msgdef.data, conn.msgtype))
            store = stores.get_typestore(stores.Stores.EMPTY)
            store.register(types)
            self._store = store
        return self._store

    def deserialize(self, raw: bytes, msgtype: str) -> Any:
        return self.typestore.deserialize_cdr(raw, msgtype)

    def close(self) -> None:
        self._handle.close()


def _single_mcap(path: Path) -> Path | None:
    """The MCAP file of ``path`` when it is one (a file, or a bag folder of one .mcap file)."""
    if path.is_file():
        return path if path.suffix.lower() == ".mcap" else None
    files = [p for p in path.iterdir() if p.suffix.lower() in (".mcap", ".db3")]
    if len(files) == 1 and files[0].suffix.lower() == ".mcap":
        return files[0]
    return None


class BagReader:
    """One detection topic of a bag (an ``.mcap`` or ``.db3`` file, or a ROS 2 bag folder).

    Args:
        path: the bag. topic: the detection topic (None: the bag's only Detection2DArray topic).
        classes: the class table. first_frame: the number of the first message's frame (0 as
            KITTI, 1 as MOTChallenge). fps: the nominal rate (None: from the stamps).
        camera_topic: the CameraInfo topic (None: the bag's only one, if any).
    """

    def __init__(
        self,
        path: Path,
        topic: str | None,
        classes: ClassTable,
        *,
        first_frame: int = 0,
        fps: float | None = None,
        camera_topic: str | None = None,
    ):
        self.path = Path(path)
        self.classes = classes
        self.first_frame = int(first_frame)
        self.fps_option = fps
        highlevel = require_ros("rosbags.highlevel")
        self._reader: Any = None
        try:
            self._reader = self._direct() or self._open(highlevel, None)
        except FileNotFoundError:
            raise InputError("bag not found", self.path) from None
        except Exception as exc:  # noqa: BLE001 - a damaged file fails in the library's ways
            self._reader = None
            raise self._damaged(exc) from None
        self.topics: dict[str, str] = {}
        for c in self._reader.connections:
            self.topics.setdefault(c.topic, c.msgtype)
        try:
            self.topic = self._choose_topic(topic)
            self.connections = [c for c in self._reader.connections if c.topic == self.topic]
            self.camera = self._camera_info(camera_topic)
        except BaseException:
            self.close()
            raise
        self.summary: BagSummary | None = None
        #: frame -> header stamp (ns) of the messages read ahead of the tracker (time_of)
        self._stamps: dict[int, int] = {}
        self._t0: int | None = None
        self.dropped = 0
        self.fps_estimate: float | None = fps
        self._fast: bool | None = None  # read directly: None until the definition says
        self._classes: set[int] = set()  # the class ids read (scan)
        self._kept: list[tuple[int, int, Detections | None]] | None = None

    # -- opening ---------------------------------------------------------------------------
    def _direct(self) -> _McapFile | None:
        """The bag as one MCAP file read with the mcap library, or None (a .db3 bag, a bag of
        several files, a file without its summary: rosbags reads those, or says why not)."""
        if not self.path.exists():
            raise FileNotFoundError(self.path)
        single = _single_mcap(self.path)
        if single is None:
            return None
        try:
            return _McapFile(single)
        except Exception:  # noqa: BLE001 - damaged or truncated: rosbags tries, or says why
            log.debug("reading %s with rosbags", single, exc_info=True)
            return None

    def _open(self, highlevel: Any, store: Any) -> Any:
        """An open AnyReader; the types of a bag without definitions (.db3) from
        :func:`~sensemaking.ros.msgs.typestore` (made only then: it takes a quarter second)."""
        reader = highlevel.AnyReader([self.path], default_typestore=store)
        try:
            reader.open()
        except highlevel.AnyReaderError as exc:
            if store is None and "no type definitions" in str(exc):
                return self._open(highlevel, typestore())
            raise
        return reader

    def _damaged(self, exc: BaseException) -> InputError:
        text = " ".join(str(exc).split()) or type(exc).__name__
        return InputError(f"cannot read the bag (truncated or damaged?): {text}", self.path)

    def _listing(self) -> str:
        return ", ".join(f"{t} ({m})" for t, m in sorted(self.topics.items())) or "none"

    def _choose_topic(self, topic: str | None) -> str:
        if topic is None:
            found = [t for t, m in sorted(self.topics.items()) if m in DETECTION_TYPES]
            if len(found) == 1:
                log.info("reading detections from %s", found[0])
                return found[0]
            why = "no Detection2DArray topic" if not found else "several Detection2DArray topics"
            raise InputError(
                f"{why}: give --topic; the bag's topics: {self._listing()}", self.path
            )
        if topic not in self.topics:
            raise InputError(
                f"no topic {topic} in the bag; its topics: {self._listing()}", self.path
            )
        if self.topics[topic] not in DETECTION_TYPES:
            raise InputError(
                f"topic {topic} has {self.topics[topic]} messages, expected "
                f"{DETECTION_TYPES[0]}; the bag's topics: {self._listing()}",
                self.path,
            )
        return topic

    def _camera_info(self, topic: str | None) -> CameraInfo | None:
        if topic is not None and topic not in self.topics:
            raise InputError(
                f"no camera topic {topic} in the bag; its topics: {self._listing()}", self.path
            )
        if topic is not None and self.topics[topic] != CAMERA_INFO:
            raise InputError(
                f"--camera-info {topic} has {self.topics[topic]} messages, expected {CAMERA_INFO}",
                self.path,
            )
        if topic is None:
            found = [t for t, m in sorted(self.topics.items()) if m == CAMERA_INFO]
            if len(found) != 1:
                if found:
                    log.info("several CameraInfo topics: choose one with --camera-info")
                return None
            topic = found[0]
        conns = [c for c in self._reader.connections if c.topic == topic]
        for conn, _, raw in self._messages(conns):
            fast = None
            top = "sensor_msgs/CameraInfo"
            fields = _sections(self.msgdef(conn)[1], top).get(top, [])
            if fields[:6] == _CAMERA_FIELDS:
                fast = parse_camera_info(raw)
            if fast is not None:
                width, height, k = fast
            else:
                msg = self._deserialize(raw, conn.msgtype, 1)
                try:
                    width, height = int(msg.width), int(msg.height)
                    k = [float(v) for v in msg.k] if len(msg.k) == 9 else [0.0] * 9
                except (AttributeError, TypeError, ValueError) as exc:
                    raise InputError(
                        f"{topic}: not a CameraInfo as sensor_msgs defines it ({exc})", self.path
                    ) from None
            return CameraInfo(topic, width, height, k[0], k[4], k[2], k[5])
        return None

    def _messages(self, connections: Sequence[Any]) -> Iterator[tuple[Any, int, bytes]]:
        """(connection, log time ns, raw bytes) in log-time order; a library failure (a
        truncated file) is an InputError."""
        it = self._reader.messages(connections=connections)
        while True:
            try:
                item = next(it)
            except StopIteration:
                return
            except Exception as exc:  # noqa: BLE001 - a damaged file fails in the library's ways
                raise self._damaged(exc) from None
            yield item

    def _deserialize(self, raw: bytes, msgtype: str, number: int) -> Any:
        try:
            return self._reader.deserialize(raw, msgtype)
        except Exception as exc:  # noqa: BLE001 - a damaged message fails in the library's ways
            raise InputError(
                f"{self.topic} message {number}: cannot decode it as {msgtype}: "
                f"{' '.join(str(exc).split())}",
                self.path,
            ) from None

    def _decode(self, raw: bytes, msgtype: str, number: int) -> tuple[int, list[tuple]]:
        """(stamp ns, boxes) of a detection message: read directly when the topic's definition
        is vision_msgs 4's and the bytes end where that layout ends, else by the generic
        decoder."""
        if self._fast is None:
            self._fast = has_layout(self.msgdef(self.connections[0])[1])
            log.debug("%s: vision_msgs 4 layout, read directly: %s", self.topic, self._fast)
        if self._fast:
            parsed = parse_detection_array(raw)
            if parsed is not None:
                return parsed
        msg = self._deserialize(raw, msgtype, number)
        try:
            return _generic(msg)
        except (AttributeError, TypeError, ValueError) as exc:  # a definition without the fields
            raise InputError(
                f"{self.topic} message {number}: not a Detection2DArray as vision_msgs defines "
                f"it ({exc})",
                self.path,
            ) from None

    def msgdef(self, connection: Any) -> tuple[str, str]:
        """(MCAP schema encoding, definition text) of an input connection, for copying it."""
        fmt = getattr(connection.msgdef.format, "name", "NONE")
        if fmt in ("MSG", "IDL") and connection.msgdef.data:
            return ("ros2msg" if fmt == "MSG" else "ros2idl"), connection.msgdef.data
        try:  # a .db3 bag keeps no definitions: the typestore's, as ROS 2 .msg text
            text = self._reader.typestore.generate_msgdef(connection.msgtype, ros_version=2)[0]
        except Exception:  # noqa: BLE001 - a type the typestore lacks: copied without one
            text = ""
        return "ros2msg", text

    def close(self) -> None:
        if self._reader is not None:
            reader, self._reader = self._reader, None
            reader.close()

    # -- frames ----------------------------------------------------------------------------
    #: boxes kept from the checking pass for the run (about 80 bytes each): a bag with more is
    #: read twice, so memory stays bounded
    KEEP_BOXES = 250_000

    #: messages decoded before their boxes are converted and checked together (numpy's
    #: per-call cost is then paid per batch, not per message)
    BATCH = 256

    def _frames(
        self, image_size: tuple[int, int] | None, raw_out: Any = None, batch_size: int = BATCH
    ) -> Iterator[tuple[int, int, Detections | None]]:
        """(frame, stamp ns, Detections or None for none) of every message, checked, read
        ``batch_size`` messages ahead; with ``raw_out`` (connection, log time, raw) of every
        message of every topic go to it."""
        conns = self._reader.connections if raw_out is not None else self.connections
        wanted = {c.id for c in self.connections}
        previous: int | None = None
        sample: list[int] = []  # the first stamps, until the rate is known
        period = None if self.fps_option is None else 1e9 / self.fps_option
        frame = self.first_frame - 1
        number = 0

        def place(stamp: int) -> int:
            nonlocal frame
            assert period is not None and self._t0 is not None
            slot = self.first_frame + int(round((stamp - self._t0) / period))
            frame = max(frame + 1, slot)
            if frame > MAX_FRAME:
                raise InputError(
                    f"{self.topic}: stamp {stamp / 1e9:.9f} s is frame {frame}, beyond the "
                    f"plausibility bound {MAX_FRAME} (a stamp far from the others?)",
                    self.path,
                )
            return frame

        held: list[tuple[int, Detections | None]] = []  # checked, until the rate is known
        batch: list[tuple[int, int, list[tuple]]] = []

        def flush() -> Iterator[tuple[int, int, Detections | None]]:
            nonlocal period, held
            checked = self._checked(batch, image_size)
            batch.clear()
            if period is None:
                held.extend(checked)
                if len(sample) <= RATE_SAMPLE:
                    return
                period = self._nominal_period(sample)
                checked, held = held, []
            for stamp, dets in checked:
                yield place(stamp), stamp, dets

        for conn, log_time, raw in self._messages(conns):
            if raw_out is not None:
                raw_out(conn, log_time, raw)
                if conn.id not in wanted:
                    continue
            number += 1
            stamp, items = self._decode(raw, conn.msgtype, number)
            if previous is not None and stamp <= previous:
                raise InputError(
                    f"{self.topic} message {number}: header stamp {stamp / 1e9:.9f} s is not "
                    f"after the previous message's {previous / 1e9:.9f} s: stamps must "
                    "increase in the bag's order",
                    self.path,
                )
            previous = stamp
            if self._t0 is None:
                self._t0 = stamp
            if period is None and len(sample) <= RATE_SAMPLE:
                sample.append(stamp)
            batch.append((number, stamp, items))
            if len(batch) >= batch_size:
                yield from flush()
        if batch:
            yield from flush()
        if held:
            period = self._nominal_period(sample)
            for stamp, dets in held:
                yield place(stamp), stamp, dets

    def _checked(
        self, batch: list[tuple[int, int, list[tuple]]], image_size: tuple[int, int] | None
    ) -> list[tuple[int, Detections | None]]:
        """(stamp, Detections or None) of decoded messages ``(number, stamp, boxes)``, classes
        mapped and boxes checked; errors name the message."""
        flat: list[tuple] = []
        counts: list[int] = []
        for number, _, items in batch:
            try:
                flat.extend(_boxes_of(items, self.classes))
            except InputError as exc:
                raise InputError(
                    f"{self.topic} message {number}: {exc.problem}", self.path
                ) from None
            counts.append(len(flat))
        out: list[tuple[int, Detections | None]] = []
        if not flat:
            return [(stamp, None) for _, stamp, _ in batch]
        arr = np.array(flat, dtype=np.float64)  # cx, cy, w, h, score, class
        keep = (arr[:, 2] != 0.0) & (arr[:, 3] != 0.0)  # as the text readers: dropped
        self.dropped += int((~keep[arr[:, 5] >= 0]).sum())
        keep &= arr[:, 5] >= 0  # class -1: dropped by the table
        half = arr[:, 2:4] / 2.0
        # corners to a micro-pixel: center +- size/2 is off by an ulp, and a box written from a
        # file with up to 6 decimals must come back as the very numbers of the file
        xyxy = np.round(np.concatenate([arr[:, :2] - half, arr[:, :2] + half], axis=1), 6)
        conf = arr[:, 4].copy()
        cls = arr[:, 5].astype(np.int64)
        rows = np.repeat(
            np.array([number for number, _, _ in batch], dtype=np.int64),
            np.diff(np.array([0, *counts])),
        )
        every = Detections.trusted(
            xyxy=xyxy[keep],
            confidence=conf[keep],
            class_id=cls[keep],
            tracker_id=np.full(int(keep.sum()), -1, dtype=np.int64),
            frame=np.zeros(int(keep.sum()), dtype=np.int64),
            source_row=rows[keep],
            data={},
        )
        self._classes.update(np.unique(every.class_id).tolist())
        try:
            validate_detections(every, image_size)
        except InputError:
            for number in np.unique(every.source_row).tolist():  # which message: checked alone
                one = every[every.source_row == number]
                try:
                    validate_detections(one.with_(source_row=-1), image_size)
                except InputError as exc:
                    raise InputError(
                        f"{self.topic} message {number}: {exc.problem}", self.path
                    ) from None
            raise
        start = 0
        kept = np.concatenate([[0], np.cumsum(keep)])
        for (_, stamp, _), end in zip(batch, counts, strict=True):
            a, b = int(kept[start]), int(kept[end])
            start = end
            if a == b:
                out.append((stamp, None))
                continue
            out.append(
                (
                    stamp,
                    Detections.trusted(
                        xyxy=every.xyxy[a:b],
                        confidence=every.confidence[a:b],
                        class_id=every.class_id[a:b],
                        tracker_id=every.tracker_id[a:b],
                        frame=every.frame[a:b],
                        source_row=np.full(b - a, -1, dtype=np.int64),
                        data={},
                    ),
                )
            )
        return out

    def _nominal_period(self, stamps: list[int]) -> float:
        """The median interval of ``stamps`` (ns), as a rate rounded to 0.001 fps."""
        from sensemaking.config import check_fps

        if len(stamps) < 2:
            fps = 10.0  # one message: any rate numbers it as the first frame
        else:
            fps = round(1e9 / float(np.median(np.diff(np.asarray(stamps, dtype=np.int64)))), 3)
        self.fps_estimate = check_fps(fps, f"the rate of {self.topic}'s stamps", self.path)
        return 1e9 / self.fps_estimate

    def scan(self, image_size: tuple[int, int] | None) -> BagSummary:
        """Check every message of the topic before any work; the frame range and the rate."""
        n = n_dets = 0
        last: int | None = None
        self.dropped = 0
        self.fps_estimate = self.fps_option
        self._classes = set()
        kept: list[tuple[int, int, Detections | None]] | None = []
        for f, stamp, dets in self._frames(image_size):
            n += 1
            last = f
            if dets is not None:
                n_dets += len(dets)
            if kept is not None:
                kept.append((f, stamp, dets))
                if n_dets > self.KEEP_BOXES:
                    kept = None  # a long bag: read again by frames()
        self._kept = kept
        classes = self._classes
        if n == 0:
            log.warning("%s: no messages on %s", self.path, self.topic)
        if self.dropped:
            log.warning(
                "%s: dropped %d detection(s) of zero width or height", self.path, self.dropped
            )
        fps = self.fps_estimate if self.fps_estimate is not None else 10.0
        self.summary = BagSummary(
            n,
            self.first_frame,
            last,
            float(fps),
            self._t0,
            n_dets,
            self.dropped,
            tuple(sorted(classes)),
        )
        return self.summary

    @property
    def all_connections(self) -> list[Any]:
        """Every connection (topic) of the bag."""
        return list(self._reader.connections)

    def frames(
        self, image_size: tuple[int, int] | None, raw_out: Any = None, *, batch: int | None = None
    ) -> Iterator[tuple[int, Detections]]:
        """``(frame, Detections)`` of every message with detections (frames without any are
        left to the pipeline, as for a text file), frame numbers as :meth:`scan` gave them.
        The stamps of the frames read ahead are kept for :meth:`time_of` until the consumer
        asks for the next frame (it has then written every frame before)."""
        if raw_out is None and self._kept is not None:  # what scan() read, not read again
            kept, self._kept = self._kept, None
            source: Iterator[tuple[int, int, Detections | None]] = _drain(kept)
        else:
            self._t0 = None
            self.dropped = 0
            source = self._frames(image_size, raw_out, batch or self.BATCH)
        for f, stamp, dets in source:
            self._stamps[f] = stamp
            if dets is None:
                continue
            n = len(dets)
            yield (
                f,
                Detections.trusted(
                    xyxy=dets.xyxy,
                    confidence=dets.confidence,
                    class_id=dets.class_id,
                    tracker_id=np.full(n, -1, dtype=np.int64),
                    frame=np.full(n, f, dtype=np.int64),
                    source_row=np.full(n, -1, dtype=np.int64),
                    data={},
                ),
            )
            for g in [g for g in self._stamps if g < f]:
                del self._stamps[g]

    def time_of(self, frame: int) -> int:
        """The time (ns) of a frame: its message's header stamp, else (a frame between
        messages) the first stamp plus the frames at the nominal rate."""
        stamp = self._stamps.get(frame)
        if stamp is not None:
            return stamp
        assert self.summary is not None and self.summary.t0 is not None
        return self.summary.t0 + int(round((frame - self.first_frame) * 1e9 / self.summary.fps))


def _drain(items: list[Any]) -> Iterator[Any]:
    """The items of a list in order, each dropped from it once given (memory freed as read)."""
    items.reverse()
    while items:
        yield items.pop()
