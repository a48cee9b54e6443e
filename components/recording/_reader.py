"""Reading a recording back: its audio chunk by chunk with their frame indexes, its ports as they were published.

Used by the export (WAV and CSV), by captures that replay a recording (``mcap:PATH``) and by
the ``replay`` component.  Messages come in the order they were received, one chunk of the
file in memory at a time (the mcap reader decompresses whole chunks).  A recording its recorder
did not end (killed, crashed, its machine down) is read up to its last complete chunk, and says
so (:attr:`RecordingReader.unfinished`).  Blocking: run it off the event loop.
"""

from __future__ import annotations

import dataclasses
import struct
from collections.abc import Iterator, Mapping
from typing import Any, BinaryIO

import numpy as np
import numpy.typing as npt
import orjson
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Channel
from mcap.summary import Summary

from ._cdr import CdrError
from ._commands import EVENTS_TOPIC, RecordedEvent, listened_record
from ._errors import NotARecording
from ._messages import AUDIO_DATA_STAMPED, AUDIO_FRAMES, AUDIO_INFO, IMAGE
from ._ports import PORT_KEY, ROLE_KEY, TYPE_KEY
from ._recover import Recovered, recover

__all__ = ["RecordingReader", "AudioChunk", "PortMessage", "SessionEventRecord"]


@dataclasses.dataclass(frozen=True)
class AudioChunk:
    """One recorded chunk of audio.

    Attributes:
        frames: ``(n, channels)`` int32 frames (two: left then right).
        first_frame: The number of the first frame (frames count from 1 at the capture's start).
        chunk: The capture's number of the chunk.
        lost_frames: Frames the recording missed just before this chunk.
        head_azimuth: Head azimuth at the chunk's end (degrees, positive left), NaN when unknown.
        sample_rate: Frames per second.
        capture_time: The capture's own time of the first frame (POSIX seconds on the rig's clock).
        receive_time: When the recorder received it (POSIX seconds on the recorder's machine).
    """

    frames: npt.NDArray[np.int32]
    first_frame: int
    chunk: int
    lost_frames: int
    head_azimuth: float
    sample_rate: int
    capture_time: float
    receive_time: float


@dataclasses.dataclass(frozen=True)
class PortMessage:
    """One publication of a recorded port, as its data was (JSON-ready).

    Attributes:
        port: ``instance/port``.
        data: The port's data (arrays as numpy arrays for pictures).
        capture_time: Its time on the rig's clock (POSIX seconds).
        receive_time: When the recorder received it.
    """

    port: str
    data: Any
    capture_time: float
    receive_time: float


@dataclasses.dataclass(frozen=True)
class SessionEventRecord:
    """One recorded event of a session.

    Attributes:
        event: ``request``, ``unload`` or ``quit``.
        data: A request's status object, the instance or the session name.
        receive_time: When the recorder received it.
    """

    event: str
    data: Any
    receive_time: float


def _stamp(header: Mapping[str, Any]) -> float:
    stamp = header["stamp"]
    return float(stamp["sec"]) + float(stamp["nanosec"]) * 1e-9


class RecordingReader:
    """An MCAP recording open for reading.

    A recording whose recorder did not end it (no summary, a torn end) is read up to its last
    complete chunk, as if it had been ended there (:attr:`unfinished` says what was read of it).

    Args:
        stream: The file, open for reading in binary (seekable).
        name: How to name it in messages.

    Raises:
        NotARecording: when it is not an MCAP file, or an unfinished one with nothing to read (the
            message says "unfinished" and that nothing can be saved).
    """

    def __init__(self, stream: BinaryIO, name: str = "the recording") -> None:
        self.name = name
        self._stream = stream
        #: What was read of a recording its recorder did not end (None: it was ended).
        self.unfinished: Recovered | None = None
        try:
            self._reader = make_reader(stream)
            summary = self._reader.get_summary()
        except OSError as exc:
            raise NotARecording(f"{name} cannot be read: {exc.strerror or exc}") from exc
        except (McapError, ValueError, EOFError, struct.error):
            summary = None   # no footer where it should be: a recording cut short, or not one at all
        if summary is None:
            self.unfinished = recover(stream, name)
            try:
                self._reader = make_reader(self.unfinished.stream)
                summary = self._reader.get_summary()
            except (McapError, ValueError, EOFError, struct.error) as exc:
                raise NotARecording(f"{name} is not an MCAP file this reader reads: {exc}") from exc
            assert summary is not None  # the ending made in memory has one
        self.summary: Summary = summary

    def close(self) -> None:
        """Close the file."""
        if self.unfinished is not None:
            self.unfinished.stream.close()
        self._stream.close()

    def __enter__(self) -> RecordingReader:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- what it holds -----------------------------------------------------------------------

    def channels(self, role: str | None = None) -> list[Channel]:
        """The channels, in the order they were made (of one *role* only: ``audio``, ``port``...)."""
        return [c for c in self.summary.channels.values() if role is None or c.metadata.get(ROLE_KEY) == role]

    def audio_ports(self) -> list[str]:
        """The recorded audio ports, as ``instance/port``."""
        return [c.metadata[PORT_KEY] for c in self.channels("audio")]

    def port_type(self, port: str) -> dict[str, Any]:
        """The ``/info`` type description of the recorded port *port*."""
        for channel in self.channels():
            if channel.metadata.get(PORT_KEY) == port and TYPE_KEY in channel.metadata:
                value: dict[str, Any] = orjson.loads(channel.metadata[TYPE_KEY])
                return value
        raise NotARecording(f"{self.name} has no port {port!r}")

    def message_count(self, topic: str) -> int:
        """How many messages the channel *topic* holds."""
        counts = self.summary.statistics.channel_message_counts if self.summary.statistics else {}
        return sum(counts.get(c.id, 0) for c in self.channels() if c.topic == topic)

    def metadata(self) -> dict[str, dict[str, str]]:
        """The file's metadata records by name (``aiogenomix``: what was recorded; ``aiogenomix.end``: how it ended)."""
        return {record.name: dict(record.metadata) for record in self._reader.iter_metadata()}

    # -- audio -------------------------------------------------------------------------------

    def audio(self, port: str | None = None) -> Iterator[AudioChunk]:
        """The chunks of an audio port, in the order they were captured.

        Args:
            port: ``instance/port``; None for the only one.

        Raises:
            NotARecording: when the recording has no such audio port (or several and none was named).
        """
        ports = self.audio_ports()
        if port is None:
            if len(ports) != 1:
                listed = ", ".join(ports) or "none"
                raise NotARecording(f"{self.name} holds {len(ports)} audio ports ({listed}): name one")
            port = ports[0]
        elif port not in ports:
            raise NotARecording(f"{self.name} has no audio port {port!r} (audio ports: {', '.join(ports) or 'none'})")
        topic, frames_topic, info_topic = f"/{port}", f"/{port}/frames", f"/{port}/info"
        waiting: dict[int, tuple[Any, int]] = {}
        channels = 2  # until the port's AudioInfo says (it comes before the first chunk of each format)
        try:
            for _, channel, message in self._reader.iter_messages(topics=[topic, frames_topic, info_topic]):
                if channel.topic == info_topic:
                    channels = max(1, int(AUDIO_INFO.decode(message.data)["channels"]))
                    continue
                # A chunk is two messages of one sequence number, received together.
                other = waiting.pop(message.sequence, None)
                if other is None:
                    waiting[message.sequence] = (message, 0)
                    continue
                audio, frames = (message, other[0]) if channel.topic == topic else (other[0], message)
                yield self._chunk(audio.data, frames.data, message.log_time, channels)
        except (McapError, CdrError) as exc:
            raise NotARecording(f"{self.name}: {exc}") from exc

    @staticmethod
    def _chunk(audio: bytes, frames: bytes, log_time: int, channels: int) -> AudioChunk:
        index = AUDIO_FRAMES.decode(frames)
        samples = AUDIO_DATA_STAMPED.decode(audio)["audio"]["data"]
        interleaved = samples.view("<i4").reshape(-1, channels).astype(np.int32, copy=False)
        return AudioChunk(frames=interleaved, first_frame=int(index["first_frame"]), chunk=int(index["chunk"]),
                          lost_frames=int(index["lost_frames"]), head_azimuth=float(index["head_azimuth"]),
                          sample_rate=int(index["sample_rate"]), capture_time=_stamp(index["header"]),
                          receive_time=log_time * 1e-9)

    # -- other ports and sessions -------------------------------------------------------------------

    def sessions(self) -> list[str]:
        """The sessions whose events were recorded."""
        return [c.metadata["aiogenomix.session"] for c in self.channels("events")]

    def session_events(self, session: str) -> Iterator[SessionEventRecord]:
        """The recorded events of *session*, in the order they came."""
        try:
            for _, _, message in self._reader.iter_messages(topics=[f"/session/{session}/events"]):
                body = orjson.loads(message.data)
                yield SessionEventRecord(body["event"], body["data"], message.log_time * 1e-9)
        except (McapError, orjson.JSONDecodeError, KeyError) as exc:
            raise NotARecording(f"{self.name}: {exc}") from exc

    def has_events(self) -> bool:
        """Whether requests and events were recorded here (by the ``recorder`` component, or a session's over HTTP)."""
        return any(c.topic == EVENTS_TOPIC for c in self.channels()) or bool(self.sessions())

    def events(self) -> list[RecordedEvent]:
        """The requests and events recorded, in the order they were received.

        Those the ``recorder`` component kept (its host's: a request's service and input, its times
        on the rig's clock), and those of each session ``aiogenomix-record --session`` listened to
        (what the listen stream said: no service or input, and the time they were received).
        """
        found: list[RecordedEvent] = []
        try:
            for _, _, message in self._reader.iter_messages(topics=[EVENTS_TOPIC]):
                found.append(RecordedEvent(orjson.loads(message.data), message.publish_time * 1e-9,
                                           message.log_time * 1e-9))
        except (McapError, orjson.JSONDecodeError) as exc:
            raise NotARecording(f"{self.name}: {exc}") from exc
        for session in self.sessions():
            found += (RecordedEvent(listened_record(session, told.event, told.data), told.receive_time,
                                    told.receive_time) for told in self.session_events(session))
        found.sort(key=lambda event: event.receive_time)
        return found

    def ports(self) -> list[str]:
        """The recorded ports other than audio (JSON and picture channels), as ``instance/port``."""
        return [c.metadata[PORT_KEY] for c in self.channels("port")]

    def publications(self, ports: list[str] | None = None) -> Iterator[PortMessage]:
        """The publications of the non-audio ports (of *ports* only, when given), in the order received."""
        wanted = {c.topic: c for c in self.channels("port") if ports is None or c.metadata[PORT_KEY] in ports}
        if not wanted:
            return
        try:
            for _, channel, message in self._reader.iter_messages(topics=list(wanted)):
                port = channel.metadata[PORT_KEY]
                if channel.message_encoding == "json":
                    data = orjson.loads(message.data)
                else:
                    image = IMAGE.decode(message.data)
                    data = {"width": image["width"], "height": image["height"], "encoding": image["encoding"],
                            "step": image["step"], "data": image["data"]}
                yield PortMessage(port, data, message.publish_time * 1e-9, message.log_time * 1e-9)
        except (McapError, CdrError, orjson.JSONDecodeError) as exc:
            raise NotARecording(f"{self.name}: {exc}") from exc
