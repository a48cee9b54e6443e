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
from ._conversions import AUDIO_TYPES, frames_per_chunk, head_state, number, planar_odometry, seconds_of, stamp_of
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
    head = head_state(data)
    return {"header": _header(stamp, name.split("/")[0]), "name": ["head_yaw"], "position": [head.position],
            "velocity": [head.velocity]}


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
    # nav_msgs/Odometry carries the twist in the robot's frame (child_frame_id); the port gives the room's.
    odometry = planar_odometry(data)
    orientation = dict(zip("xyzw", odometry.orientation, strict=True))
    return {"header": _header(stamp, "map"), "child_frame_id": "base_footprint",
            "pose": {"pose": {"position": {"x": odometry.x, "y": odometry.y, "z": 0.0}, "orientation": orientation}},
            "twist": {"twist": {"linear": {"x": odometry.forward, "y": odometry.leftward, "z": 0.0},
                                "angular": {"x": 0.0, "y": 0.0, "z": odometry.turn}}}}


def _laser_scan(data: Json, stamp: float, name: str) -> Json:
    header = data.get("header") or {}
    return {"header": _header(stamp, str(header.get("frame_id", ""))),
            **{key: number(data.get(key)) for key in ("angle_min", "angle_max", "angle_increment", "range_min",
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
        self._chunk_frames = 0  # a capture's frames per chunk, once a read has said it

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
            self._chunk_frames = 0  # a new capture may have another chunk size
            return True
        return False

    def write(self, data: Json, *, since: int, lost: int, rig_time: float) -> None:
        """Write the items of a ``since=`` read that were not recorded yet.

        Which items the read holds is read from the data itself (they end at its newest index),
        not taken on trust from *since*: items recorded already are skipped, and those between
        the last one recorded and the first one held are counted as lost.

        Args:
            data: The port struct of the read (its arrays hold only the new items).
            since: The index the read asked after.
            lost: Items between *since* and the first one returned that the port no longer held.
            rig_time: The rig's clock when the read was made.

        Raises:
            RecordingError: when a capture's read is not whole chunks (it is not the read asked for).
        """
        left = np.asarray(data.get("left", ()), dtype=np.int32).reshape(-1)
        right = np.asarray(data.get("right", ()), dtype=np.int32).reshape(-1)
        newest = self.index_of(data)
        recorded, self.since = self.since, max(self.since, newest)
        if left.size == 0:
            return
        if self.numbering == "chunks":
            rate = int(data.get("transfer_rate", 0))
            held, per_chunk = self._chunks_held(left.size, newest, since, lost, data.get("positions"))
            first_chunk = max(newest - held + 1, recorded + 1)  # the chunks recorded already are skipped
            skipped = first_chunk - (newest - held + 1)
            lost_frames = (first_chunk - recorded - 1) * per_chunk
            start = seconds_of(data.get("ts")) or rig_time
            positions = data.get("positions")
            azimuths = np.full(held, math.nan) if positions is None else _floats(positions, np.float64)
            chunks = [_Piece(chunk=chunk, first_frame=(chunk - 1) * per_chunk + 1, offset=(k + skipped) * per_chunk,
                             frames=per_chunk,
                             stamp=(start + (chunk - 1) * per_chunk / rate) if rate else rig_time,
                             azimuth=float(azimuths[k + skipped]) if k + skipped < azimuths.size else math.nan)
                      for k, chunk in enumerate(range(first_chunk, newest + 1))]
        else:
            rate = int(data.get("sampleRate", 0))
            per_chunk = int(data.get("nFramesPerChunk", 0)) or max(1, left.size)
            first = max(newest - left.size + 1, recorded + 1)  # the frames recorded already are skipped
            lost_frames = first - recorded - 1
            # bass's port carries no time: the newest frame is taken as captured when it was read.
            chunks = []
            done = first - (newest - left.size + 1)
            while done < left.size:
                frame = newest - left.size + 1 + done
                size = min(per_chunk - (frame - 1) % per_chunk, left.size - done)
                stamp = rig_time - (newest - frame + 1) / rate if rate else rig_time
                chunks.append(_Piece((frame - 1) // per_chunk + 1, frame, done, size, stamp, math.nan))
                done += size
        if not chunks:
            return
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

    def _chunks_held(self, frames: int, newest: int, since: int, lost: int, positions: Any) -> tuple[int, int]:
        """How many chunks a capture's read of *frames* frames holds, and the frames of each.

        The capture's chunk size, once known, says it; the first read learns it from the chunks
        it asked for (``newest - since - lost``).  A ``kemarcapture`` read carries a position per chunk.
        """
        if positions is not None and len(positions):
            chunks = len(positions)
        elif self._chunk_frames and frames % self._chunk_frames == 0:
            chunks = frames // self._chunk_frames
        else:
            chunks = newest - since - lost
        try:
            per_chunk = frames_per_chunk(frames, chunks)
        except ValueError as exc:
            raise RecordingError(f"{self.name}: a read after chunk {since} up to chunk {newest} holds {frames} "
                                 f"frames: {exc}") from None
        self._chunk_frames = per_chunk
        return frames // per_chunk, per_chunk

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
