"""The recording library: port data kept in MCAP, the robotics log format, and read back.

The ``recorder`` component, the ``replay`` component, captures that replay a recording
(``mcap:PATH``) and the ``aiogenomix-record`` command line are built on it.  What lives here:

* **Message types** in ROS 2's own encoding (:class:`MessageType`: the ``.msg`` definition, CDR in
  and out), the standard ones and our ``aiogenomix_msgs/msg/AudioFrames``.
* **The file** (:class:`McapFile`), written chunk by chunk so that a full disk or a spent budget
  (:class:`RecordQuotas`) leaves a readable recording, by a thread of its own (:class:`RecordingWriter`)
  fed through a bounded queue.
* **When port data was captured**, read once for the recording and the live view alike; what it
  is (audio, a head's state, pictures...) its type says, by its port kind
  (:class:`~aiogenomix.components.core.PortKind`), for any component's port.
* **Port recorders** (:class:`AudioRecorder`, :class:`ImageRecorder`, :class:`JsonRecorder`) and
  the :class:`Recording` that holds them; **paths** confined to the operator's directories.
* **What was commanded when**: a host's requests and events (:class:`HostEventRecorder`), as JSON
  and as log lines.
* **Reading and exporting**: :class:`RecordingReader`, :func:`export_recording` (WAV and CSV).

Decision 0031 records the formats and why.
"""

from ._cdr import CdrError, Field, MessageType
from ._commands import EVENT_COLUMNS, EVENTS_SCHEMA, EVENTS_TOPIC, LOG, HostEventRecorder, RecordedEvent, log_line
from ._conversions import number, seconds_of, stamp_of
from ._errors import NotARecording, PathRefused, RecordingError
from ._export import AUDIO_COLUMNS, HEAD_COLUMNS, ExportedFile, export_recording
from ._mcap_file import DEFAULT_CHUNK_SIZE, ByteQuota, McapFile, QuotaReached, WriteFailed
from ._messages import (
    AUDIO_DATA_STAMPED, AUDIO_FRAMES, AUDIO_INFO, HEADER, IMAGE, JOINT_STATE, LASER_SCAN, ODOMETRY, POSE_STAMPED,
)
from ._paths import SUFFIX, NewRecording, create_recording, open_recording, replay_roots
from ._ports import AudioRecorder, ImageRecorder, JsonRecorder, PortRecorder, RecordedPort
from ._reader import AudioChunk, PortMessage, RecordingReader, SessionEventRecord
from ._quota import FileQuota, RecordQuotas, directory_bytes
from ._recover import Recovered
from ._recording import EVENTS_TYPE, EventRecorder, Recording, RecordingCounts
from ._writer import DEFAULT_QUEUE_BYTES, RecordingWriter

__all__ = [
    # Recording
    "Recording", "RecordingCounts", "PortRecorder", "AudioRecorder", "ImageRecorder", "JsonRecorder",
    "RecordedPort", "EventRecorder", "EVENTS_TYPE", "HostEventRecorder",
    # When port data was captured, for every tool that shows it (what it is, its type's kind says)
    "stamp_of", "seconds_of", "number",
    # The file and its writer
    "McapFile", "RecordingWriter", "WriteFailed", "DEFAULT_CHUNK_SIZE", "DEFAULT_QUEUE_BYTES",
    # What the files may take (the host's budgets of bytes)
    "RecordQuotas", "FileQuota", "ByteQuota", "QuotaReached", "directory_bytes",
    # Paths
    "create_recording", "NewRecording", "open_recording", "replay_roots", "SUFFIX",
    # Reading and exporting
    "RecordingReader", "Recovered", "AudioChunk", "PortMessage", "SessionEventRecord", "export_recording",
    "ExportedFile", "RecordedEvent",
    "AUDIO_COLUMNS", "HEAD_COLUMNS", "EVENT_COLUMNS",
    # A host's events as recorded (what was commanded when)
    "EVENTS_SCHEMA", "EVENTS_TOPIC", "LOG", "log_line",
    # Message types
    "MessageType", "Field", "CdrError", "HEADER", "AUDIO_DATA_STAMPED", "AUDIO_FRAMES", "AUDIO_INFO", "JOINT_STATE",
    "IMAGE", "LASER_SCAN", "ODOMETRY", "POSE_STAMPED",
    # Errors
    "RecordingError", "PathRefused", "NotARecording",
]
