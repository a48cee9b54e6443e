"""How each kind of port is written: audio as standard audio with its frame indexes, pictures, everything else as JSON.

A port recorder turns the data of one port (as JSON-ready data: what ``/read`` and
``/watch`` answer, or ``port.type.encode(value)`` in-process; arrays may stay numpy
arrays) into messages on its channels.  What a port is, its type says (its port kind,
``carries`` in ``/info``), for any component's port:

* **audio** (:class:`~aiogenomix.components.core.AudioStream`: ``capture``'s and
  ``kemarcapture``'s ``Port``, ``bass``'s ``Audio``, any component's audio): one
  ``audio_common_msgs/msg/AudioDataStamped`` per captured chunk on ``/<instance>/<port>``
  (interleaved ``S32LE``, losslessly), its twin ``aiogenomix_msgs/msg/AudioFrames`` on
  ``/<instance>/<port>/frames`` (frame number, chunk number, frames lost before it, head
  azimuth), and ``audio_common_msgs/msg/AudioInfo`` on ``/<instance>/<port>/info`` whenever
  the format changes;
* **pictures** (:class:`~aiogenomix.components.core.Image`): ``sensor_msgs/msg/Image``, every member kept;
* **any other port**: its data as JSON on ``/<instance>/<port>``, losslessly, its JSON Schema in
  the channel's metadata (:data:`SCHEMA_KEY`: ``rosbags`` refuses a file with ``jsonschema`` schema
  records), plus a companion channel in the standard type robotics tools show when its kind has
  one: a head's state as ``sensor_msgs/msg/JointState`` in radians, odometry as
  ``nav_msgs/msg/Odometry``, laser scans, joint states, poses (``geometry_msgs/msg/PoseStamped``).

Each message's MCAP ``log_time`` is when the recorder received it (this machine's clock) and
its ``publish_time``, like its header stamp, is the capture's own time (the rig's clock,
simulated or not).  Decision 0031 says why.
"""

from __future__ import annotations

import abc
import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
import orjson

from ..core import (
    AudioRead, AudioStream, HeadState, Image, JointStates, LaserScan, Odometry, PortKind, Pose, carried_by,
    json_schema,
)
from ._cdr import MessageType
from ._conversions import stamp_of
from ._errors import RecordingError
from ._messages import (
    AUDIO_DATA_STAMPED, AUDIO_FRAMES, AUDIO_INFO, IMAGE, JOINT_STATE, LASER_SCAN, ODOMETRY, POSE_STAMPED,
)
from ._writer import RecordingWriter

__all__ = [
    "PortRecorder", "AudioRecorder", "ImageRecorder", "JsonRecorder", "recorder_for",
    "RecordedPort", "SCHEMA_KEY",
]

Json = Mapping[str, Any]
#: A companion's conversion: the port's kind, its data, the stamp, the port's name → the message's fields.
Convert = Callable[[Any, Json, float, str], Json]
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


class RecordedPort:
    """What a port recorder keeps count of.

    Attributes:
        name: ``instance/port``.
        messages: Messages written for the port (companions and twins included).
        publications: Publications recorded.
        coalesced: Publications a watch skipped (their data was replaced before the recorder read it).
        lost_frames: Audio frames the recording missed (the window turned over before they were read).
        unavailable: Reads that found the data withdrawn by its component (a sensor down): the
            recorder waited for the next publication.
    """

    def __init__(self, name: str) -> None:
        self.name = name
        self.messages = 0
        self.publications = 0
        self.coalesced = 0
        self.lost_frames = 0
        self.unavailable = 0

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
    """Any port as JSON with its JSON Schema, and a standard companion when its kind has one."""

    def open(self) -> None:
        schema = json_schema(self.type, title=self.name, doc=str(self.description.get("doc") or ""))
        metadata = {**self._metadata("port"), SCHEMA_KEY: orjson.dumps(schema).decode()}
        self._channel = self.writer.channel(self.topic, "json", 0, metadata)
        kind = carried_by(self.type)
        companion = None if kind is None else _COMPANIONS.get(type(kind))
        self._companion: tuple[int, MessageType, PortKind, Convert] | None = None
        if kind is not None and companion is not None:
            suffix, message, convert = companion
            self._companion = (self._ros_channel(f"{self.topic}/{suffix}", message, "companion"), message, kind,
                               convert)

    def write(self, data: Json, *, coalesced: int = 0, rig_time: float) -> None:
        """Write one publication; *rig_time* is the rig's clock when it was read (its time unless the data says)."""
        log_time = self._log_time()
        stamp = stamp_of(data) or rig_time
        self._sequence += 1
        self.publications += 1
        self.coalesced += coalesced
        self._send(self._channel, log_time, stamp, orjson.dumps(data, option=_NUMPY))
        if self._companion is not None:
            channel, message, kind, convert = self._companion
            self._send(channel, log_time, stamp, message.encode(convert(kind, data, stamp, self.name)))


def _header(stamp: float, frame: str) -> dict[str, Any]:
    return {"stamp": _time(stamp), "frame_id": frame}


def _head_joint_state(kind: HeadState, data: Json, stamp: float, name: str) -> Json:
    head = kind.read(data)  # radians, as ROS says them
    return {"header": _header(stamp, name.split("/")[0]), "name": ["head_yaw"], "position": [head.position],
            "velocity": [head.velocity]}


def _joint_state(kind: JointStates, data: Json, stamp: float, name: str) -> Json:
    joints = kind.read(data)
    return {"header": _header(stamp, joints.frame), "name": joints.names, "position": joints.positions,
            "velocity": joints.velocities}


def _odometry(kind: Odometry, data: Json, stamp: float, name: str) -> Json:
    # nav_msgs/Odometry carries the twist in the robot's frame (child_frame_id), as the kind reads it.
    odometry = kind.read(data)
    orientation = dict(zip("xyzw", odometry.orientation, strict=True))
    return {"header": _header(stamp, "map"), "child_frame_id": "base_footprint",
            "pose": {"pose": {"position": {"x": odometry.x, "y": odometry.y, "z": 0.0}, "orientation": orientation}},
            "twist": {"twist": {"linear": {"x": odometry.forward, "y": odometry.leftward, "z": 0.0},
                                "angular": {"x": 0.0, "y": 0.0, "z": odometry.turn}}}}


def _laser_scan(kind: LaserScan, data: Json, stamp: float, name: str) -> Json:
    scan = kind.read(data)
    return {"header": _header(stamp, scan.frame), "angle_min": scan.angle_min, "angle_max": scan.angle_max,
            "angle_increment": scan.angle_increment, "range_min": scan.range_min, "range_max": scan.range_max,
            "ranges": scan.ranges}


def _pose_stamped(kind: Pose, data: Json, stamp: float, name: str) -> Json:
    pose = kind.read(data)
    return {"header": _header(stamp, pose.frame), "pose": {
        "position": dict(zip("xyz", pose.position, strict=True)),
        "orientation": dict(zip("xyzw", pose.orientation, strict=True))}}


#: The standard companion of each kind: (topic suffix, message type, conversion of the port's data).
_COMPANIONS: dict[type[PortKind], tuple[str, MessageType, Convert]] = {
    HeadState: ("joint_state", JOINT_STATE, _head_joint_state),
    Odometry: ("odometry", ODOMETRY, _odometry),
    JointStates: ("joint_state", JOINT_STATE, _joint_state),
    LaserScan: ("scan", LASER_SCAN, _laser_scan),
    Pose: ("pose", POSE_STAMPED, _pose_stamped),
}


class ImageRecorder(PortRecorder):
    """A picture port as ``sensor_msgs/msg/Image`` (width, height, encoding, step and pixels: the whole picture)."""

    def __init__(self, writer: RecordingWriter, name: str, description: Json, log_time: Callable[[], int],
                 kind: Image) -> None:
        super().__init__(writer, name, description, log_time)
        self.kind = kind

    def open(self) -> None:
        self._channel = self._ros_channel(self.topic, IMAGE, "port")

    def write(self, data: Json, *, coalesced: int = 0, rig_time: float) -> None:
        """Write one picture, stamped with the rig's clock when it was read (pictures carry no time)."""
        log_time = self._log_time()
        self._sequence += 1
        self.publications += 1
        self.coalesced += coalesced
        picture = self.kind.read(data)
        message = {"header": _header(rig_time, self.name.split("/", 1)[-1]), "height": picture.height,
                   "width": picture.width, "encoding": picture.encoding, "is_bigendian": 0, "step": picture.step,
                   "data": picture.data}
        self._send(self._channel, log_time, rig_time, IMAGE.encode(message))


class AudioRecorder(PortRecorder):
    """An audio port: every captured frame once, chunk by chunk, as standard audio with its frame indexes.

    The recorder asks for the items after :attr:`since` (chunks for ``capture``, frames for
    ``bass``: the port's kind says which) and writes what it gets; items the port no longer held
    are counted as lost frames and said in the next chunk's ``lost_frames``.  A capture that starts
    again (its index goes back) is recorded from its first chunk.
    """

    def __init__(self, writer: RecordingWriter, name: str, description: Json, log_time: Callable[[], int],
                 kind: AudioStream) -> None:
        super().__init__(writer, name, description, log_time)
        self.kind = kind
        #: The index of the last item recorded: ask for the items after it.
        self.since = 0
        #: A capture's frames per chunk, once a read has said it.
        self.chunk_frames = 0
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
        return self.kind.newest(data)

    def restarted(self, newest: int) -> bool:
        """Whether a port whose newest item is *newest* holds a new capture (its index went back): record it all."""
        if newest < self.since:
            self.since = 0
            self.chunk_frames = 0  # a new capture may have another chunk size
            return True
        return False

    def write(self, data: Json, *, lost: int, rig_time: float) -> None:
        """Write the items of a ``since=`` read (asked after :attr:`since`) that were not recorded yet.

        Args:
            data: The port's data of the read (its arrays hold only the new items).
            lost: Items after :attr:`since` that the port no longer held (the read says).
            rig_time: The rig's clock when the read was made (the time of audio that carries none).

        Raises:
            RecordingError: when a read of chunks is not whole chunks (it is not the read asked for).
        """
        try:
            read = self.kind.read(data, since=self.since, lost=lost, now=rig_time, chunk_frames=self.chunk_frames)
        except ValueError as exc:
            raise RecordingError(f"{self.name}: {exc}") from None
        self.add(read)

    def add(self, read: AudioRead) -> None:
        """Write the frames of *read* (:meth:`AudioStream.read` of the items after :attr:`since`)."""
        if read.restarted:
            self.restarted(read.newest)
        self.since = max(self.since, read.newest)
        self.chunk_frames = read.chunk_frames or self.chunk_frames
        if not read.pieces:
            return
        self._lost_before += read.lost_frames
        self.lost_frames += read.lost_frames
        self._announce_format(read.rate, read.channels, read.pieces[0].stamp)
        log_time = self._log_time()
        self.publications += 1
        raw = read.frames.astype("<i4", copy=False).reshape(-1).view(np.uint8)
        width = 4 * read.channels  # bytes a frame
        for piece in read.pieces:
            self._sequence += 1
            header = _header(piece.stamp, "")
            samples = raw[piece.offset * width:(piece.offset + piece.frames) * width]
            self._send(self._audio, log_time, piece.stamp, AUDIO_DATA_STAMPED.encode(
                {"header": header, "audio": {"data": samples}}))
            self._send(self._frames, log_time, piece.stamp, AUDIO_FRAMES.encode(
                {"header": header, "first_frame": piece.first_frame, "frames": piece.frames, "chunk": piece.chunk,
                 "lost_frames": self._lost_before, "head_azimuth": piece.head_azimuth, "sample_rate": read.rate}))
            self._lost_before = 0

    def _announce_format(self, rate: int, channels: int, stamp: float) -> None:
        if self._format == (rate, channels):
            return
        self._format = (rate, channels)
        self._send(self._info, self._log_time(), stamp, AUDIO_INFO.encode(
            {"channels": channels, "sample_rate": rate, "sample_format": "S32LE", "bitrate": rate * channels * 32,
             "coding_format": "wave"}))


def recorder_for(writer: RecordingWriter, name: str, description: Json,
                 log_time: Callable[[], int]) -> AudioRecorder | ImageRecorder | JsonRecorder:
    """The recorder of the port *name* (``instance/port``) whose ``/info`` description is *description*.

    Its type's kind says how: audio, pictures, or JSON (with a standard companion when one fits).
    """
    kind = carried_by(description["type"])
    recorder: AudioRecorder | ImageRecorder | JsonRecorder
    if isinstance(kind, AudioStream):
        recorder = AudioRecorder(writer, name, description, log_time, kind)
    elif isinstance(kind, Image):
        recorder = ImageRecorder(writer, name, description, log_time, kind)
    else:
        recorder = JsonRecorder(writer, name, description, log_time)
    recorder.open()
    return recorder
