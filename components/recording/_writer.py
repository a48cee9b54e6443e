"""The writer thread of a recording: the event loop hands over encoded messages, a thread compresses and writes them.

Compressing and writing take milliseconds per chunk and may block on a slow or full
disk; none of it happens on the event loop, which only appends to a queue.  The queue
is bounded in bytes: a recorder that finds it full waits (:meth:`RecordingWriter.wait_room`)
instead of queueing more, and what it cannot take meanwhile is counted where it is lost
(the audio window turns over, a watch coalesces publications), never held in memory.
"""

from __future__ import annotations

import asyncio
import collections
import dataclasses
import threading
from collections.abc import Callable
from typing import BinaryIO

from ._mcap_file import DEFAULT_CHUNK_SIZE, ByteQuota, McapFile, WriteFailed

__all__ = ["RecordingWriter", "DEFAULT_QUEUE_BYTES"]

#: Bytes of messages the loop may have handed over that the thread has not written yet.
DEFAULT_QUEUE_BYTES = 32 << 20


@dataclasses.dataclass(frozen=True)
class _Op:
    """One thing for the thread to do to the file (``finish``: end it), and the bytes of messages it holds."""

    kind: str
    apply: Callable[[McapFile], object] | None = None
    size: int = 0


class RecordingWriter:
    """An :class:`~._mcap_file.McapFile` written by a thread of its own; its methods are for the event loop.

    Args:
        stream: The file (unbuffered, at its start).
        queue_bytes: The most message bytes handed over and not yet written.
        chunk_size: Uncompressed bytes per MCAP chunk.
        library: Who writes the file (in its header).
        quota: What the file may take (None: whatever the disk takes); its end is told to it.
    """

    def __init__(self, stream: BinaryIO, *, queue_bytes: int = DEFAULT_QUEUE_BYTES,
                 chunk_size: int = DEFAULT_CHUNK_SIZE, library: str = "aiogenomix",
                 quota: ByteQuota | None = None) -> None:
        self._loop = asyncio.get_running_loop()
        self._stream, self._library, self._chunk_size, self._quota = stream, library, chunk_size, quota
        self._file: McapFile | None = None  # made by the thread: even the header is written there
        self._failure: OSError | None = None
        self._limit = queue_bytes
        self._ops: collections.deque[_Op] = collections.deque()
        self._ready = threading.Condition()
        self._pending = 0
        self._closing = False
        self._schemas = 0
        self._channels = 0
        self._room = asyncio.Event()
        self._waiting = False  # whether the loop waits for room (then the thread sets _room when it makes some)
        #: Set (on the loop) when the file failed: the recording must stop.
        self.failed = asyncio.Event()
        #: Messages handed over so far.
        self.messages_queued = 0
        self._thread = threading.Thread(target=self._run, name="aiogenomix recording writer", daemon=True)
        self._thread.start()

    # -- the loop's side ---------------------------------------------------------------------------

    @property
    def failure(self) -> OSError | None:
        """Why the file could not be written (None while it can)."""
        return self._failure or (self._file.failure if self._file is not None else None)

    @property
    def bytes_written(self) -> int:
        """Bytes of the file that readers get (whole records)."""
        return self._file.committed if self._file is not None else 0

    @property
    def messages_written(self) -> int:
        """Messages in the chunks written so far."""
        return self._file.messages if self._file is not None else 0

    def has_room(self) -> bool:
        """Whether the queue takes more messages now."""
        return self._pending < self._limit

    async def wait_room(self) -> None:
        """Wait until the queue takes more messages (at once when it does)."""
        while not self.failed.is_set():
            # Said before looking, so that the thread, which makes room before it reads this, wakes
            # the loop whenever it makes room after the look: never between the look and the wait.
            self._room.clear()
            self._waiting = True
            if self.has_room():
                break
            await self._room.wait()
        self._waiting = False

    def _put(self, op: _Op) -> None:
        if self._closing:
            raise RuntimeError("the recording writer is closed")
        with self._ready:
            self._ops.append(op)
            self._pending += op.size
            self._ready.notify()

    def schema(self, name: str, encoding: str, data: bytes) -> int:
        """Register a schema; return the id its channels name."""
        self._schemas += 1
        self._put(_Op("schema", lambda file: file.add_schema(name, encoding, data), len(data)))
        return self._schemas

    def channel(self, topic: str, message_encoding: str, schema_id: int, metadata: dict[str, str] | None = None
                ) -> int:
        """Register a channel; return the id its messages name."""
        self._channels += 1
        values = dict(metadata or {})
        self._put(_Op("channel", lambda file: file.add_channel(topic, message_encoding, schema_id, values)))
        return self._channels

    def metadata(self, name: str, values: dict[str, str]) -> None:
        """Add a metadata record."""
        copied = dict(values)
        self._put(_Op("metadata", lambda file: file.add_metadata(name, copied)))

    def message(self, channel_id: int, log_time: int, publish_time: int, sequence: int, data: bytes) -> None:
        """Hand over one message (never blocks: check :meth:`has_room` or await :meth:`wait_room` first)."""
        self.messages_queued += 1
        self._put(_Op("message", lambda file: file.add_message(channel_id, log_time, publish_time, sequence, data),
                      len(data)))

    async def close(self) -> None:
        """Write what is queued, end the file (summary, footer), and stop the thread (idempotent).

        Raises:
            WriteFailed: when the file could not be written whole; what it holds stays readable.
        """
        if not self._closing:
            self._put(_Op("finish"))
            self._closing = True
        await asyncio.to_thread(self._thread.join)
        failure = self.failure
        if failure is not None:
            raise WriteFailed(failure.errno, failure.strerror or str(failure))

    # -- the thread's side -------------------------------------------------------------------------

    def _take(self) -> _Op:
        with self._ready:
            while not self._ops:
                self._ready.wait()
            return self._ops.popleft()

    def _run(self) -> None:
        try:
            file = self._file = McapFile(self._stream, library=self._library, chunk_size=self._chunk_size,
                                         quota=self._quota)
        except OSError as exc:
            self._failure = exc
            self._stream.close()
            self._loop.call_soon_threadsafe(self.failed.set)
            file = None
        while True:
            op = self._take()
            if op.kind == "finish":
                try:
                    if file is not None:
                        file.finish()
                except WriteFailed:
                    pass  # the loop reads file.failure when the thread has ended
                return
            try:
                if file is not None and file.failure is None and op.apply is not None:
                    op.apply(file)
            except WriteFailed:
                self._loop.call_soon_threadsafe(self.failed.set)
            except Exception as exc:  # a bug must not leave the loop waiting for room forever
                if file is not None and file.failure is None:
                    file.failure = OSError(0, f"the recording writer failed: {type(exc).__name__}: {exc}")
                self._loop.call_soon_threadsafe(self.failed.set)
            finally:
                with self._ready:
                    self._pending -= op.size
                    room = self._pending < self._limit // 2 or not self._ops
                # Read after the room is made (wait_room says it waits before it looks): a waiting
                # loop is always woken. asyncio's Event is the loop's: it is set there, not here.
                if room and self._waiting:
                    self._loop.call_soon_threadsafe(self._room.set)
