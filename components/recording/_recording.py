"""One recording being made: its file and writer thread, the recorders of its ports and events, its counts.

Both ways of recording use it: the ``recorder`` component, which reads the ports of its
host, and ``aiogenomix-record``, which reads them over HTTP.  Each feeds the port
recorders with what it read; this keeps the time, the counts, and the file's beginning and end.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Mapping
from typing import Any, BinaryIO

import orjson

from ..core import json_schema
from ._commands import HostEventRecorder
from ._mcap_file import DEFAULT_CHUNK_SIZE, ByteQuota
from ._ports import (
    ROLE_KEY, SCHEMA_KEY, AudioRecorder, ImageRecorder, JsonRecorder, PortRecorder, RecordedPort, recorder_for,
)
from ._writer import DEFAULT_QUEUE_BYTES, RecordingWriter

__all__ = ["Recording", "RecordingCounts", "EventRecorder", "EVENTS_TYPE"]

#: The ``/info``-style type of a session's events as recorded (``request``, ``quit``, ``unload``).
EVENTS_TYPE: dict[str, Any] = {"name": "::aiogenomix::session_event", "kind": "struct", "members": [
    {"name": "event", "type": {"name": "string", "kind": "string"}, "doc": "request, quit or unload"},
    {"name": "data", "type": {"name": "any", "kind": "any"},
     "doc": "The event's data: a request's status object, the session or the instance name"},
]}


@dataclasses.dataclass(frozen=True)
class RecordingCounts:
    """How far a recording is.

    Attributes:
        bytes: Bytes of the file that readers get (it grows a compressed chunk at a time).
        messages: Messages recorded (handed to the writer thread).
        queued: Messages of those not in the file yet (waiting for the thread, or in the chunk being gathered).
        lost_frames: Audio frames missed (the window turned over before the recorder read them).
        coalesced: Publications of other ports that a watch replaced before the recorder read them.
        unavailable: Reads that found a port's data withdrawn by its component (a sensor down), over every port.
        ports: The counts of each port, by ``instance/port``: ``publications``, ``messages``, ``lost_frames``,
            ``coalesced``, ``unavailable`` and ``index`` (audio: the newest item recorded).
    """

    bytes: int
    messages: int
    queued: int
    lost_frames: int
    coalesced: int
    unavailable: int
    ports: dict[str, dict[str, int]]


class EventRecorder(RecordedPort):
    """A session's events (``request``, ``quit``, ``unload``) as JSON on ``/session/<name>/events``."""

    def __init__(self, recording: Recording, session: str) -> None:
        super().__init__(f"session {session}")
        self._recording = recording
        writer = recording.writer
        schema = json_schema(EVENTS_TYPE, title=f"session {session} events",
                             doc="The events of a genomix session, as its listen stream gave them")
        self.topic = f"/session/{session}/events"
        self._channel = writer.channel(self.topic, "json", 0, {"aiogenomix.session": session, ROLE_KEY: "events",
                                                              SCHEMA_KEY: orjson.dumps(schema).decode()})

    def write(self, event: str, data: Any) -> None:
        """Write one event as the listen stream gave it."""
        now = self._recording.log_time()
        self.publications += 1
        self.messages += 1
        self._recording.writer.message(self._channel, now, now, self.publications,
                                       orjson.dumps({"event": event, "data": data}))


class Recording:
    """A recording: the MCAP file, the thread that writes it, and what is recorded into it.

    Make one with :meth:`open` on the event loop; add ports (:meth:`add_port`) and feed
    their recorders; :meth:`close` ends the file.

    Args:
        writer: The writer of the file.
        path: The file's full path (for messages).
        description: What the recording is (written as the file's ``aiogenomix`` metadata).
    """

    def __init__(self, writer: RecordingWriter, path: str, description: Mapping[str, str]) -> None:
        self.writer = writer
        self.path = path
        self.ports: dict[str, PortRecorder] = {}
        self.events: list[EventRecorder] = []
        #: The host's events, when the recording keeps them (:meth:`add_host_events`).
        self.host_events: HostEventRecorder | None = None
        self._last_log = 0
        writer.metadata("aiogenomix", {"started": _utc(), **description})

    @classmethod
    def open(cls, stream: BinaryIO, path: str, description: Mapping[str, str], *,
             chunk_size: int = DEFAULT_CHUNK_SIZE, queue_bytes: int = DEFAULT_QUEUE_BYTES,
             quota: ByteQuota | None = None) -> Recording:
        """Start a recording into *stream* (a new file, unbuffered); call on the event loop.

        *quota* bounds what the file may take (the host's budgets); None: whatever the disk takes.
        """
        writer = RecordingWriter(stream, queue_bytes=queue_bytes, chunk_size=chunk_size, library="aiogenomix",
                                 quota=quota)
        return cls(writer, path, description)

    def log_time(self) -> int:
        """This machine's time now in nanoseconds, never before the previous one (MCAP's log times)."""
        now = max(time.time_ns(), self._last_log)
        self._last_log = now
        return now

    def add_port(self, name: str, description: Mapping[str, Any]) -> AudioRecorder | ImageRecorder | JsonRecorder:
        """Record the port *name* (``instance/port``) whose ``/info`` description is *description*."""
        recorder = recorder_for(self.writer, name, description, self.log_time)
        self.ports[name] = recorder
        return recorder

    def add_events(self, session: str) -> EventRecorder:
        """Record the events of the session *session*."""
        recorder = EventRecorder(self, session)
        self.events.append(recorder)
        return recorder

    def add_host_events(self, whose: str) -> HostEventRecorder:
        """Record a host's events (subscribe the recorder returned to ``host.events``): a session's, or ``""``: all."""
        if self.host_events is None:
            self.host_events = HostEventRecorder(self.writer, whose, self.log_time)
        return self.host_events

    def counts(self) -> RecordingCounts:
        """How far the recording is."""
        ports = {name: {"messages": p.messages, "publications": p.publications, "lost_frames": p.lost_frames,
                        "coalesced": p.coalesced, "unavailable": p.unavailable, "index": p.index}
                 for name, p in self.ports.items()}
        return RecordingCounts(bytes=self.writer.bytes_written, messages=self.writer.messages_queued,
                               queued=self.writer.messages_queued - self.writer.messages_written,
                               lost_frames=sum(p.lost_frames for p in self.ports.values()),
                               coalesced=sum(p.coalesced for p in self.ports.values()),
                               unavailable=sum(p.unavailable for p in self.ports.values()), ports=ports)

    async def close(self, ended: str) -> RecordingCounts:
        """Say how the recording ended (metadata), write what is queued, end the file.

        Args:
            ended: Why it ended (``stopped``, ``duration``, ``the disk is full``...).

        Raises:
            WriteFailed: when the file could not be written whole (what it holds stays readable).
        """
        counts = self.counts()
        if self.writer.failure is None:
            self.writer.metadata("aiogenomix.end", {
                "ended": ended, "at": _utc(), "lost_frames": str(counts.lost_frames),
                "coalesced": str(counts.coalesced), "unavailable": str(counts.unavailable),
                "ports": orjson.dumps(counts.ports).decode()})
        await self.writer.close()
        return self.counts()


def _utc() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
