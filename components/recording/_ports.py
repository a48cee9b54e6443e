"""How each kind of port is written: audio as standard audio with its frame indexes, pictures, everything else as JSON.

A port recorder turns the data of one port (as JSON-ready data: what ``/read`` and
``/watch`` answer, or ``port.type.encode(value)`` in-process; arrays may stay numpy
arrays) into messages on its channels:

* **audio** (the ``Port`` of ``capture`` and ``kemarcapture``, the ``Audio`` of ``bass``):
  one ``audio_common_msgs/msg/AudioDataStamped`` per captured chunk on ``/<instance>/<port>``
  (interleaved ``S32LE`` stereo, losslessly), its twin ``aiogenomix_msgs/msg/AudioFrames`` on
  ``/<instance>/<port>/frames`` (frame number, chunk number, frames lost before it, head
  azimuth), and ``audio_common_msgs/msg/AudioInfo`` on ``/<instance>/<port>/info`` whenever
  the format changes;
* **camera pictures** (``sensor_msgs__Image`` ports): ``sensor_msgs/msg/Image``, every member kept;
* **any other port**: its data as JSON on ``/<instance>/<port>``, losslessly, its JSON Schema in
  the channel's metadata (:data:`SCHEMA_KEY`: ``rosbags`` refuses a file with ``jsonschema`` schema
  records), plus a companion channel in the standard type robotics tools show when one
  fits: the head's state as ``sensor_msgs/msg/JointState`` in radians (the port says degrees),
  odometry as ``nav_msgs/msg/Odometry``, laser scans, joint states, stamped poses.

Each message's MCAP ``log_time`` is when the recorder received it (this machine's clock) and
its ``publish_time``, like its header stamp, is the capture's own time (the rig's clock,
simulated or not).  Decision 0031 says why.
"""

from __future__ import annotations

import abc
import math
from collections.abc import Callable, Mapping
from typing import Any, NamedTuple

import numpy as np
import orjson

from ..core import json_schema
from ._cdr import MessageType
from ._messages import (
    AUDIO_DATA_STAMPED, AUDIO_FRAMES, AUDIO_INFO, IMAGE, JOINT_STATE, LASER_SCAN, ODOMETRY, POSE_STAMPED,
)
from ._writer import RecordingWriter

__all__ = [
    "PortRecorder", "AudioRecorder", "ImageRecorder", "JsonRecorder", "recorder_for", "AUDIO_TYPES", "stamp_of",
    "RecordedPort", "SCHEMA_KEY",
]

Json = Mapping[str, Any]

#: The audio ports: their IDL type and whether their index counts chunks (capture) or frames (bass).
AUDIO_TYPES = {"::capture::port_t": "chunks", "::kemarcapture::port_t": "chunks", "::binaudio::portStruct": "frames"}
IMAGE_TYPES = ("::subscriber::sensor_msgs__Image",)
#: The channel metadata keys a recording sets (what a replay needs to publish a port again).
PORT_KEY, TYPE_KEY, DOC_KEY, ROLE_KEY = "aiogenomix.port", "aiogenomix.type", "aiogenomix.doc", "aiogenomix.role"
#: Where a JSON channel keeps its JSON Schema: rosbags (0.11) refuses a whole file that holds a schema
#: record in the ``jsonschema`` encoding, so JSON channels have none (MCAP allows it) and carry theirs here.
SCHEMA_KEY = "aiogenomix.jsonschema"
_NUMPY = orjson.OPT_SERIALIZE_NUMPY | orjson.OPT_NON_STR_KEYS


def _ns(seconds: float) -> int:
    return max(0, int(round(seconds * 1e9)))


def _time(seconds: float) -> dict[str, int]:
    """A ``builtin_interfaces/Time`` of POSIX *seconds*."""
    whole = math.floor(seconds)
    return {"sec": int(whole), "nanosec": min(999_999_999, int(round((seconds - whole) * 1e9)))}


def _seconds(stamp: Any) -> float | None:
    """POSIX seconds of a port's timestamp struct (``{tv_sec, tv_nsec}``), or None when it is not one."""
    if isinstance(stamp, Mapping) and "tv_sec" in stamp and "tv_nsec" in stamp:
        seconds = float(stamp["tv_sec"]) + float(stamp["tv_nsec"]) * 1e-9
        return seconds if seconds > 0 else None
    return None


def stamp_of(data: Any) -> float | None:
    """The capture time a port's data carries: a ``timestamp``, ``stamp`` or ``ts`` member, or its header's stamp."""
    if not isinstance(data, Mapping):
        return None
    for key in ("timestamp", "stamp", "ts"):
        seconds = _seconds(data.get(key))
        if seconds is not None:
            return seconds
    header = data.get("header")
    if isinstance(header, Mapping):
        return _seconds(header.get("stamp"))
    return None


class RecordedPort:
    """What a port recorder keeps count of.

    Attributes:
        name: ``instance/port``.
        messages: Messages written for the port (companions and twins included).
        publications: Publications recorded.
        coalesced: Publications a watch skipped (their data was replaced before the recorder read it).
        lost_frames: Audio frames the recording missed (the window turned over before they were read).
    """

    def __init__(self, name: str) -> None:
        self.name = name
        self.messages = 0
        self.publications = 0
        self.coalesced = 0
        self.lost_frames = 0

    @property
    def index(self) -> int:
        """The newest item recorded, for numbered data (audio chunks or frames); 0 for other data."""
        return 0


class PortRecorder(RecordedPort, abc.ABC):
    """Writes the publications of one port on its channels.

    Args:
        writer: The recording's writer.
        name: ``instance/port``.
        description: The port's ``/info`` description (name, type, doc).
        log_time: The recorder's clock, in nanoseconds (monotonic: log times never go back).
    """

    def __init__(self, writer: RecordingWriter, name: str, description: Json, log_time: Callable[[], int]) -> None:
        super().__init__(name)
        self.writer = writer
        self.description = description
        self.type: Json = description["type"]
        self.topic = "/" + name
        self._log_time = log_time
        self._schemas: dict[str, int] = {}
        self._sequence = 0

    def _metadata(self, role: str) -> dict[str, str]:
        return {PORT_KEY: self.name, ROLE_KEY: role, TYPE_KEY: orjson.dumps(self.type).decode(),
                DOC_KEY: str(self.description.get("doc") or "")}

    def _ros_channel(self, topic: str, kind: MessageType, role: str) -> int:
        schema = self._schemas.get(kind.name)
        if schema is None:
            schema = self._schemas[kind.name] = self.writer.schema(kind.name, "ros2msg", kind.definition().encode())
        return self.writer.channel(topic, "cdr", schema, self._metadata(role))

    def _send(self, channel: int, log_time: int, stamp: float, data: bytes) -> None:
        self.writer.message(channel, log_time, _ns(stamp), self._sequence, data)
        self.messages += 1

    @abc.abstractmethod
    def open(self) -> None:
        """Register the port's schemas and channels."""


class JsonRecorder(PortRecorder):
    """Any port as JSON with its JSON Schema, and a standard companion when one fits."""

    #: The companion of each type: (topic suffix, message type, conversion of the port's data).
    COMPANIONS: dict[str, tuple[str, MessageType, Callable[[Json, float, str], Json]]] = {}

    def open(self) -> None:
        schema = json_schema(self.type, title=self.name, doc=str(self.description.get("doc") or ""))
        metadata = {**self._metadata("port"), SCHEMA_KEY: orjson.dumps(schema).decode()}
        self._channel = self.writer.channel(self.topic, "json", 0, metadata)
        companion = self.COMPANIONS.get(str(self.type["name"]))
        self._companion: tuple[int, MessageType, Callable[[Json, float, str], Json]] | None = None
        if companion is not None:
            suffix, kind, convert = companion
            self._companion = (self._ros_channel(f"{self.topic}/{suffix}", kind, "companion"), kind, convert)

    def write(self, data: Json, *, coalesced: int = 0, rig_time: float) -> None:
        """Write one publication; *rig_time* is the rig's clock when it was read (its time unless the data says)."""
        log_time = self._log_time()
        stamp = stamp_of(data) or rig_time
        self._sequence += 1
        self.publications += 1
        self.coalesced += coalesced
        self._send(self._channel, log_time, stamp, orjson.dumps(data, option=_NUMPY))
        if self._companion is not None:
            channel, kind, convert = self._companion
            self._send(channel, log_time, stamp, kind.encode(convert(data, stamp, self.name)))


def _header(stamp: float, frame: str) -> dict[str, Any]:
    return {"stamp": _time(stamp), "frame_id": frame}


def _head_joint_state(data: Json, stamp: float, name: str) -> Json:
    # The port says degrees and degrees per second; ROS says radians.
    return {"header": _header(stamp, name.split("/")[0]), "name": ["head_yaw"],
            "position": [math.radians(float(_number(data.get("position"))))],
            "velocity": [math.radians(float(_number(data.get("speed"))))]}


def _number(value: Any) -> float:
    return math.nan if value is None else float(value)


def _floats(values: Any, dtype: type[np.floating[Any]]) -> np.ndarray[Any, Any]:
    """An array of numbers that JSON may have written with ``null`` for NaN."""
    if isinstance(values, list):
        values = [math.nan if v is None else v for v in values]
    return np.asarray(values, dtype=dtype)


def _joint_state(data: Json, stamp: float, name: str) -> Json:
    header = data.get("header") or {}
    return {"header": _header(stamp, str(header.get("frame_id", ""))), "name": list(data.get("name", [])),
            "position": np.asarray(data.get("position", []), dtype=np.float64),
            "velocity": np.asarray(data.get("velocity", []), dtype=np.float64)}


def _odometry(data: Json, stamp: float, name: str) -> Json:
    yaw = _number(data.get("w"))
    cos, sin = math.cos(yaw), math.sin(yaw)
    vx, vy = _number(data.get("vx")), _number(data.get("vy"))
    # nav_msgs/Odometry carries the twist in the robot's frame; the port gives the room's.
    return {"header": _header(stamp, "map"), "child_frame_id": "base_footprint",
            "pose": {"pose": {"position": {"x": _number(data.get("x")), "y": _number(data.get("y")), "z": 0.0},
                              "orientation": {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}},
            "twist": {"twist": {"linear": {"x": cos * vx + sin * vy, "y": -sin * vx + cos * vy, "z": 0.0},
                                "angular": {"x": 0.0, "y": 0.0, "z": _number(data.get("vw"))}}}}


def _laser_scan(data: Json, stamp: float, name: str) -> Json:
    header = data.get("header") or {}
    return {"header": _header(stamp, str(header.get("frame_id", ""))),
            **{key: _number(data.get(key)) for key in ("angle_min", "angle_max", "angle_increment", "range_min",
                                                        "range_max")},
            "ranges": _floats(data.get("ranges", ()), np.float32)}


def _pose_stamped(data: Json, stamp: float, name: str) -> Json:
    header = data.get("header") or {}
    return {"header": _header(stamp, str(header.get("frame_id", ""))), "pose": data.get("pose", {})}


JsonRecorder.COMPANIONS.update({
    "::kemar::state": ("joint_state", JOINT_STATE, _head_joint_state),
    "::world::odometry": ("odometry", ODOMETRY, _odometry),
    "::subscriber::sensor_msgs__JointState": ("joint_state", JOINT_STATE, _joint_state),
    "::subscriber::sensor_msgs__LaserScan": ("scan", LASER_SCAN, _laser_scan),
    "::subscriber::geometry_msgs__PoseStamped": ("pose", POSE_STAMPED, _pose_stamped),
})


class ImageRecorder(PortRecorder):
    """A camera port as ``sensor_msgs/msg/Image`` (width, height, encoding, step and pixels: the whole port)."""

    def open(self) -> None:
        self._channel = self._ros_channel(self.topic, IMAGE, "port")

    def write(self, data: Json, *, coalesced: int = 0, rig_time: float) -> None:
        """Write one picture, stamped with the rig's clock when it was read (the port carries no time)."""
        log_time = self._log_time()
        self._sequence += 1
        self.publications += 1
        self.coalesced += coalesced
        pixels = data.get("data", b"")
        message = {"header": _header(rig_time, self.name.split("/", 1)[-1]), "height": data.get("height", 0),
                   "width": data.get("width", 0), "encoding": data.get("encoding", ""), "is_bigendian": 0,
                   "step": data.get("step", 0),
                   "data": pixels if isinstance(pixels, (bytes, np.ndarray)) else np.asarray(pixels, np.uint8)}
        self._send(self._channel, log_time, rig_time, IMAGE.encode(message))


class _Piece(NamedTuple):
    """One captured chunk (or the part of one that a read holds) of an audio read."""

    chunk: int
    first_frame: int
    offset: int  # its first frame within the read
    frames: int
    stamp: float
    azimuth: float


class AudioRecorder(PortRecorder):
    """An audio port: every captured frame once, chunk by chunk, as standard audio with its frame indexes.

    The recorder asks for the items after :attr:`since` (chunks for ``capture``, frames for
    ``bass``) and writes what it gets; items the port no longer held are counted as lost frames
    and said in the next chunk's ``lost_frames``.  A capture that starts again (its index goes
    back) is recorded from its first chunk.
    """

    def __init__(self, writer: RecordingWriter, name: str, description: Json, log_time: Callable[[], int]) -> None:
        super().__init__(writer, name, description, log_time)
        self.numbering = AUDIO_TYPES[str(self.type["name"])]
        #: The index of the last item recorded: ask for the items after it.
        self.since = 0
        self._format: tuple[int, int] | None = None
        self._lost_before = 0

    @property
    def index(self) -> int:
        """The newest item recorded (chunk or frame index): the port has been recorded up to it."""
        return self.since

    def open(self) -> None:
        self._audio = self._ros_channel(self.topic, AUDIO_DATA_STAMPED, "audio")
        self._frames = self._ros_channel(f"{self.topic}/frames", AUDIO_FRAMES, "audio_frames")
        self._info = self._ros_channel(f"{self.topic}/info", AUDIO_INFO, "audio_info")

    def start_at(self, index: int) -> None:
        """Record the items after *index* (the port's index when the recording starts: from then on)."""
        self.since = max(0, int(index))

    def index_of(self, data: Json) -> int:
        """The port's newest item in *data* (chunk index or last frame index)."""
        return int(data.get("index", 0) if self.numbering == "chunks" else data.get("lastFrameIndex", 0))

    def restarted(self, newest: int) -> bool:
        """Whether a port whose newest item is *newest* holds a new capture (its index went back): record it all."""
        if newest < self.since:
            self.since = 0
            return True
        return False

    def write(self, data: Json, *, since: int, lost: int, rig_time: float) -> None:
        """Write the items after *since* that *data* holds (a ``since=`` read), *lost* of them missing before.

        Args:
            data: The port struct of the read (its arrays hold only the new items).
            since: The index the read asked after.
            lost: Items between *since* and the first one returned that the port no longer held.
            rig_time: The rig's clock when the read was made.
        """
        left = np.asarray(data.get("left", ()), dtype=np.int32).reshape(-1)
        right = np.asarray(data.get("right", ()), dtype=np.int32).reshape(-1)
        newest = self.index_of(data)
        # The read answered every item up to the newest: written below, or lost.
        self.since = max(self.since, newest)
        if self.numbering == "chunks":
            rate = int(data.get("transfer_rate", 0))
            count = newest - since - lost
            if count <= 0 or left.size == 0:
                return
            per_chunk = left.size // count
            first_chunk = newest - count + 1
            lost_frames = lost * per_chunk
            start = _seconds(data.get("ts")) or rig_time
            positions = data.get("positions")
            azimuths = np.full(count, math.nan) if positions is None else _floats(positions, np.float64)
            chunks = [_Piece(chunk=first_chunk + k, first_frame=(first_chunk + k - 1) * per_chunk + 1,
                             offset=k * per_chunk, frames=per_chunk,
                             stamp=(start + (first_chunk + k - 1) * per_chunk / rate) if rate else rig_time,
                             azimuth=float(azimuths[k]) if k < azimuths.size else math.nan) for k in range(count)]
        else:
            rate = int(data.get("sampleRate", 0))
            per_chunk = int(data.get("nFramesPerChunk", 0)) or max(1, left.size)
            first = since + 1 + lost
            lost_frames = lost
            if left.size == 0:
                return
            # bass's port carries no time: the newest frame is taken as captured when it was read.
            chunks = []
            done = 0
            while done < left.size:
                frame = first + done
                size = min(per_chunk - (frame - 1) % per_chunk, left.size - done)
                stamp = rig_time - (newest - frame + 1) / rate if rate else rig_time
                chunks.append(_Piece((frame - 1) // per_chunk + 1, frame, done, size, stamp, math.nan))
                done += size
        self._lost_before += lost_frames
        self.lost_frames += lost_frames
        self._announce_format(rate, rig_time)
        log_time = self._log_time()
        self.publications += 1
        stereo = np.empty((left.size, 2), dtype="<i4")
        stereo[:, 0], stereo[:, 1] = left, right
        raw = stereo.reshape(-1).view(np.uint8)
        for piece in chunks:
            self._sequence += 1
            header = _header(piece.stamp, "")
            samples = raw[piece.offset * 8:(piece.offset + piece.frames) * 8]  # 8 bytes a frame: two int32
            self._send(self._audio, log_time, piece.stamp, AUDIO_DATA_STAMPED.encode(
                {"header": header, "audio": {"data": samples}}))
            self._send(self._frames, log_time, piece.stamp, AUDIO_FRAMES.encode(
                {"header": header, "first_frame": piece.first_frame, "frames": piece.frames, "chunk": piece.chunk,
                 "lost_frames": self._lost_before, "head_azimuth": piece.azimuth, "sample_rate": rate}))
            self._lost_before = 0

    def _announce_format(self, rate: int, stamp: float) -> None:
        if self._format == (rate, 2):
            return
        self._format = (rate, 2)
        self._send(self._info, self._log_time(), stamp, AUDIO_INFO.encode(
            {"channels": 2, "sample_rate": rate, "sample_format": "S32LE", "bitrate": rate * 2 * 32,
             "coding_format": "wave"}))


def recorder_for(writer: RecordingWriter, name: str, description: Json,
                 log_time: Callable[[], int]) -> AudioRecorder | ImageRecorder | JsonRecorder:
    """The recorder of the port *name* (``instance/port``) whose ``/info`` description is *description*."""
    type_name = str(description["type"]["name"])
    recorder: AudioRecorder | ImageRecorder | JsonRecorder
    if type_name in AUDIO_TYPES:
        recorder = AudioRecorder(writer, name, description, log_time)
    elif type_name in IMAGE_TYPES:
        recorder = ImageRecorder(writer, name, description, log_time)
    else:
        recorder = JsonRecorder(writer, name, description, log_time)
    recorder.open()
    return recorder
