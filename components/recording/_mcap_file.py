"""An MCAP file written chunk by chunk, each chunk committed whole: a full disk leaves a readable file.

The records are the ``mcap`` library's (:mod:`mcap.records`); the file's layout is
ours to control.  Messages gather in an open chunk; when it passes ``chunk_size``
bytes it is compressed (zstd) and written, with its message indexes, in one write.
If that write fails (no space left, a file size limit), the file is cut back to the
end of the last chunk written whole, and :meth:`McapFile.finish` still ends it with
its summary and footer, listing only what the file holds.  So the part written before
a failure is a valid MCAP file that every reader opens.  With a quota (the host's
budgets of bytes), each record is taken from it before it is written, with room for
the summary it will need: a chunk that does not fit ends the file the same way.

Blocking: it writes a file.  The recorders run it on a thread of its own
(:class:`~._writer.RecordingWriter`).
"""

from __future__ import annotations

import errno
import os
import zlib
from collections import defaultdict
from typing import BinaryIO, Protocol

import zstandard
from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (
    Channel, Chunk, ChunkIndex, DataEnd, Footer, Header, Message, MessageIndex, Metadata, MetadataIndex, Schema,
    Statistics, SummaryOffset,
)

from ..core import OverBudget

__all__ = ["McapFile", "MAGIC", "DEFAULT_CHUNK_SIZE", "WriteFailed", "QuotaReached", "ByteQuota", "file_ending",
           "record_bytes"]

MAGIC = b"\x89MCAP0\r\n"
#: Uncompressed bytes gathered before a chunk is written.  The mcap reader decompresses whole chunks
#: (mcap issue 974): 1 MiB keeps a reader's memory small and a chunk's compression good (about
#: three seconds of binaural audio, or four camera frames).
DEFAULT_CHUNK_SIZE = 1 << 20
#: zstd level: 1 compresses audio and pictures nearly as well as the default (3) at twice its speed.
DEFAULT_LEVEL = 1


class WriteFailed(OSError):
    """Writing the file failed (the disk is full, the file is too large...); what it held before stays readable."""


class QuotaReached(WriteFailed):
    """The file's quota (a budget of the host) does not take its next record; what it held before stays readable.

    Attributes:
        over: The refusal, naming the budget and its flag.
    """

    def __init__(self, over: OverBudget) -> None:
        super().__init__(errno.EDQUOT, str(over))
        self.over = over


class ByteQuota(Protocol):
    """The bytes a file may still take (:class:`~._quota.FileQuota`)."""

    def take(self, amount: int) -> None:
        """Take *amount* more bytes (raises ``OverBudget``, taking nothing, when they do not fit)."""

    def close(self, kept: int) -> None:
        """The file ended holding *kept* bytes."""


#: The most bytes of the ending that do not depend on what the file holds: DataEnd (13), the footer
#: (29), the magic (8), a summary offset record (26) for each of the five summary groups, and the
#: statistics record's fixed part (55).
_ENDING_FIXED = 13 + 29 + 8 + 5 * 26 + 55


class McapFile:
    """One MCAP file being written.

    Args:
        stream: The file, open for writing in binary without a buffer (``open(..., "wb", buffering=0)``),
            at its start; it is closed by :meth:`finish`.
        profile: The MCAP profile (``ros2``: channels of ROS 2 messages, and JSON ones).
        library: Who writes it (in the file's header).
        chunk_size: Uncompressed bytes per chunk.
        level: The zstd compression level.
        quota: What the file may take (None: whatever the disk takes).

    Raises:
        WriteFailed: when not even the file's header can be written (:class:`QuotaReached` for the quota).
    """

    def __init__(self, stream: BinaryIO, *, profile: str = "ros2", library: str = "aiogenomix",
                 chunk_size: int = DEFAULT_CHUNK_SIZE, level: int = DEFAULT_LEVEL,
                 quota: ByteQuota | None = None) -> None:
        self._stream = stream
        self._quota = quota
        # The summary records' bytes besides the chunk indexes and statistics (schemas, channels,
        # metadata indexes): with those, the room the ending needs is known without building it.
        self._summary_bytes = 0
        self._chunk_size = chunk_size
        self._compressor = zstandard.ZstdCompressor(level=level)
        self._schemas: dict[int, Schema] = {}
        self._channels: dict[int, Channel] = {}
        # The summary lists every chunk: their index records are kept encoded (about 130 bytes each
        # against 600 as objects), since an hour's recording writes some 20,000 chunks.
        self._chunk_indexes = bytearray()
        self._chunk_count = 0
        self._metadata_indexes: list[MetadataIndex] = []
        self._counts: dict[int, int] = defaultdict(int)
        self._start_time: int | None = None
        self._end_time = 0
        self._open = RecordBuilder()
        self._open_indexes: dict[int, MessageIndex] = {}
        self._open_counts: dict[int, int] = defaultdict(int)
        self._open_times: tuple[int, int] | None = None
        #: Bytes of the file that hold whole records (what a reader gets).
        self.committed = 0
        # Bytes taken from the quota: what the file holds and the room its ending needs.
        self._taken = 0
        #: Why the file could not be written further (None while it can).
        self.failure: OSError | None = None
        self._finished = False
        try:
            self._write(MAGIC + _built(Header(profile=profile, library=library)), ending=self._ending_bound())
        except WriteFailed:
            self._end_quota()
            raise

    # -- what a reader needs to know about the file ----------------------------------------------

    @property
    def messages(self) -> int:
        """Messages the file holds (in chunks written whole)."""
        return sum(self._counts.values())

    # -- writing -----------------------------------------------------------------------------

    def _ending_bound(self, more: int = 0) -> int:
        """The most bytes the file's ending (DataEnd, summary, footer) can take, with *more* summary bytes."""
        return _ENDING_FIXED + 10 * len(self._channels) + self._summary_bytes + len(self._chunk_indexes) + more

    def _take(self, data: bytes, ending: int) -> None:
        """Take from the quota the room *data* and an ending of *ending* bytes need beyond what was taken.

        Raises:
            QuotaReached: when the quota does not take it (the file fails: nothing more is written but its ending).
        """
        if self._quota is None:
            return
        needed = self.committed + len(data) + ending - self._taken
        if needed <= 0:
            return
        try:
            self._quota.take(needed)
        except OverBudget as over:
            self.failure = QuotaReached(over)
            raise self.failure from over
        self._taken += needed

    def _write(self, data: bytes, *, ending: int | None = None) -> None:
        """Write *data* whole or not at all: on failure the file is cut back to its last whole record.

        Args:
            data: Whole records.
            ending: The room the file's ending needs once *data* is written (None: *data* is the ending).

        Raises:
            WriteFailed: when the file cannot take *data* (the file then ends where it ended before).
        """
        if self.failure is not None:
            raise WriteFailed(self.failure.errno, f"the recording stopped earlier: {self.failure.strerror}")
        self._take(data, ending or 0)
        try:
            view = memoryview(data)
            while view:
                # An unbuffered file may take part of the data (the last blocks of a disk): the rest
                # is written next, or the write that cannot be made raises.
                written = self._stream.write(view)
                if not written:
                    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
                view = view[written:]
        except OSError as exc:
            self._cut_back()
            self.failure = exc
            reason = os.strerror(exc.errno) if exc.errno else str(exc)
            raise WriteFailed(exc.errno or errno.EIO, reason) from exc
        self.committed += len(data)

    def _cut_back(self) -> None:
        """Drop what a failed write left past the last whole record (freeing its space)."""
        try:
            self._stream.seek(self.committed)
            self._stream.truncate(self.committed)
        except OSError:
            pass  # the file keeps a torn tail: readers that scan stop there

    def add_schema(self, name: str, encoding: str, data: bytes) -> int:
        """Write a schema record; return its id."""
        schema = Schema(id=len(self._schemas) + 1, name=name, encoding=encoding, data=data)
        record = _built(schema)
        self._write(record, ending=self._ending_bound(len(record)))
        self._schemas[schema.id] = schema
        self._summary_bytes += len(record)
        return schema.id

    def add_channel(self, topic: str, message_encoding: str, schema_id: int,
                    metadata: dict[str, str] | None = None) -> int:
        """Write a channel record; return its id."""
        channel = Channel(id=len(self._channels) + 1, topic=topic, message_encoding=message_encoding,
                          schema_id=schema_id, metadata=dict(metadata or {}))
        record = _built(channel)
        # The statistics count the channel's messages too: 10 bytes more.
        self._write(record, ending=self._ending_bound(len(record) + 10))
        self._channels[channel.id] = channel
        self._summary_bytes += len(record)
        return channel.id

    def add_metadata(self, name: str, values: dict[str, str]) -> None:
        """Write a metadata record (what the recording is, how it ended)."""
        offset = self.committed
        data = _built(Metadata(name=name, metadata=dict(values)))
        index = MetadataIndex(offset=offset, length=len(data), name=name)
        index_size = len(_built(index))
        self._write(data, ending=self._ending_bound(index_size))
        self._metadata_indexes.append(index)
        self._summary_bytes += index_size

    def add_message(self, channel_id: int, log_time: int, publish_time: int, sequence: int, data: bytes) -> None:
        """Add a message to the open chunk; write the chunk when it is full.

        Raises:
            WriteFailed: when the full chunk cannot be written (its messages are not in the file).
        """
        index = self._open_indexes.get(channel_id)
        if index is None:
            index = self._open_indexes[channel_id] = MessageIndex(channel_id=channel_id, records=[])
        index.records.append((log_time, self._open.count))
        Message(channel_id=channel_id, log_time=log_time, publish_time=publish_time, sequence=sequence,
                data=data).write(self._open)
        self._open_counts[channel_id] += 1
        first, last = self._open_times or (log_time, log_time)
        self._open_times = (min(first, log_time), max(last, log_time))
        if self._open.count >= self._chunk_size:
            self.flush()

    def flush(self) -> None:
        """Write the open chunk now (nothing when it is empty).

        Raises:
            WriteFailed: when it cannot be written (its messages are then not in the file).
        """
        if self._open_times is None:
            return
        raw = _end(self._open)
        start, end = self._open_times
        indexes, counts = self._open_indexes, self._open_counts
        self._open_indexes, self._open_counts, self._open_times = {}, defaultdict(int), None
        compressed = self._compressor.compress(raw)
        chunk = _built(Chunk(compression="zstd", data=compressed, message_start_time=start, message_end_time=end,
                             uncompressed_crc=zlib.crc32(raw), uncompressed_size=len(raw)))
        offset = self.committed
        builder = RecordBuilder()
        offsets = {}
        for channel_id, index in sorted(indexes.items()):
            offsets[channel_id] = offset + len(chunk) + builder.count
            index.write(builder)
        index_bytes = _end(builder)
        chunk_index = _built(ChunkIndex(
            message_start_time=start, message_end_time=end, chunk_start_offset=offset, chunk_length=len(chunk),
            message_index_offsets=offsets, message_index_length=len(index_bytes), compression="zstd",
            compressed_size=len(compressed), uncompressed_size=len(raw)))
        # One write: the chunk and its indexes are in the file together, or neither is.
        self._write(chunk + index_bytes, ending=self._ending_bound(len(chunk_index)))
        self._chunk_indexes += chunk_index
        self._chunk_count += 1
        for channel_id, count in counts.items():
            self._counts[channel_id] += count
        self._start_time = start if self._start_time is None else min(self._start_time, start)
        self._end_time = max(self._end_time, end)

    def finish(self) -> None:
        """Write the open chunk, the summary and the footer, and close the file (idempotent).

        After a failure the summary lists what the file holds and is written in the space the failed
        write left; if even that does not fit, the file ends with its last whole chunk, which readers
        that scan the data section still read.

        Raises:
            WriteFailed: when the file could not be ended properly (it stays readable as said above).
        """
        if self._finished:
            return
        self._finished = True
        try:
            try:
                self.flush()
            except WriteFailed:
                pass  # that chunk is lost: the summary below still ends the file
            # The summary is written even after a failure: cutting the torn chunk back freed room.
            failure, self.failure = self.failure, None
            try:
                self._write(self._ending())
            except WriteFailed:
                self.failure = failure or self.failure
                raise
            self.failure = failure
            if failure is not None:
                raise WriteFailed(failure.errno, os.strerror(failure.errno) if failure.errno else str(failure))
        finally:
            self._end_quota()
            try:
                self._stream.close()
            except OSError:
                pass

    def _end_quota(self) -> None:
        """Give back to the quota what the file took beyond what it holds."""
        if self._quota is not None:
            self._quota.close(self.committed)

    def _ending(self) -> bytes:
        """DataEnd, the summary (schemas, channels, statistics, chunk and metadata indexes), the footer, the magic."""
        return file_ending(self.committed, schemas=list(self._schemas.values()), channels=list(self._channels.values()),
                           counts=dict(self._counts), times=(self._start_time or 0, self._end_time),
                           chunk_indexes=self._chunk_indexes, chunk_count=self._chunk_count,
                           metadata_indexes=self._metadata_indexes)


def file_ending(data_end: int, *, schemas: list[Schema], channels: list[Channel], counts: dict[int, int],
                times: tuple[int, int], chunk_indexes: bytes | bytearray, chunk_count: int,
                metadata_indexes: list[MetadataIndex]) -> bytes:
    """The end of an MCAP file whose data section ends at *data_end*: DataEnd, the summary, the footer, the magic.

    Args:
        data_end: Where the data section ends (the ending is written there).
        schemas: The file's schemas.
        channels: Its channels.
        counts: Messages per channel id.
        times: The log times of its first and last messages.
        chunk_indexes: Its ChunkIndex records, encoded, in the order of the chunks.
        chunk_count: How many they are.
        metadata_indexes: Its metadata records' indexes.
    """
    head = _built(DataEnd(data_section_crc=0))
    summary_start = data_end + len(head)
    builder = RecordBuilder()
    offsets: list[SummaryOffset] = []

    def group(opcode: int, records: list[Schema] | list[Channel] | list[Statistics] | list[MetadataIndex]
              | bytes | bytearray) -> None:
        if not records:
            return
        start = builder.count
        if isinstance(records, (bytes, bytearray)):
            builder.write(records)  # records already encoded
        else:
            for record in records:
                record.write(builder)
        offsets.append(SummaryOffset(group_opcode=opcode, group_start=summary_start + start,
                                     group_length=builder.count - start))

    statistics = Statistics(
        message_count=sum(counts.values()), schema_count=len(schemas), channel_count=len(channels),
        attachment_count=0, metadata_count=len(metadata_indexes), chunk_count=chunk_count,
        message_start_time=times[0], message_end_time=times[1], channel_message_counts=dict(counts))
    group(Opcode.SCHEMA, schemas)
    group(Opcode.CHANNEL, channels)
    group(Opcode.STATISTICS, [statistics])
    group(Opcode.CHUNK_INDEX, chunk_indexes)
    group(Opcode.METADATA_INDEX, metadata_indexes)
    summary_offset_start = summary_start + builder.count
    for offset in offsets:
        offset.write(builder)
    summary = _end(builder)
    footer = Footer(summary_start=summary_start, summary_offset_start=summary_offset_start, summary_crc=0)
    return head + summary + _built(footer) + MAGIC


def record_bytes(record: ChunkIndex) -> bytes:
    """One record, encoded."""
    return _built(record)


def _built(record: Header | Schema | Channel | Chunk | ChunkIndex | Metadata | MetadataIndex | Footer | DataEnd
           ) -> bytes:
    builder = RecordBuilder()
    record.write(builder)
    return _end(builder)


def _end(builder: RecordBuilder) -> bytes:
    """The bytes a record builder gathered (and it starts again empty)."""
    data: bytes = builder.end()  # type: ignore[no-untyped-call]  # mcap leaves it unannotated
    return data
