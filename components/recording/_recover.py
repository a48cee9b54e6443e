"""A recording its recorder never ended, read up to its last complete chunk (as ``mcap recover`` saves it).

A recorder that is killed, crashes, or whose machine goes down leaves its file without the
summary and footer that end it, perhaps with a chunk cut in the middle.  Everything before is
whole: the writer commits a chunk and its message indexes in one write, and writes schemas,
channels and metadata as records of their own.  So the file is read as far as its records are
whole: its schemas, channels and metadata, and its chunks up to the last one that is complete and
whose data checks (decompressed, its CRC).  The end it lacks is made in memory (DataEnd, a summary
of what was found, the footer) and readers read the file through it, as if it had been ended
there: nothing is written, and every reader of the ``mcap`` library works unchanged.

Blocking: it reads the file (the records' heads only, and the last chunk).
"""

from __future__ import annotations

import dataclasses
import io
import os
import struct
from collections import defaultdict
from typing import TYPE_CHECKING, BinaryIO

from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, ChunkIndex, Message, MetadataIndex, Schema
from mcap.stream_reader import breakup_chunk

from ._errors import NotARecording
from ._mcap_file import MAGIC, file_ending, record_bytes

if TYPE_CHECKING:
    from _typeshed import WriteableBuffer

__all__ = ["recover", "Recovered"]

_RECORD_HEAD = struct.Struct("<BQ")
#: A Chunk record's fields before its compression's name: start and end times, uncompressed size, CRC, and
#: the name's length.
_CHUNK_HEAD = struct.Struct("<QQQII")
#: A MessageIndex record's fields before its entries (16 bytes each): channel id, entries' byte length.
_INDEX_HEAD = struct.Struct("<HI")
#: A Message record's fields before its data: channel id, sequence, log time, publish time.
_MESSAGE_HEAD = struct.Struct("<HIQQ")
#: What may come after the data section only: met in a file being read for its data, they end it.
_SUMMARY_OPCODES = {Opcode.DATA_END, Opcode.FOOTER, Opcode.STATISTICS, Opcode.CHUNK_INDEX,
                    Opcode.ATTACHMENT_INDEX, Opcode.METADATA_INDEX, Opcode.SUMMARY_OFFSET}


@dataclasses.dataclass(frozen=True)
class Recovered:
    """What can be read of a recording that was not ended.

    Attributes:
        stream: The file read up to its last complete chunk and ended there, in memory (seekable, buffered).
        kept: Bytes of the file read (the rest is torn, or was the start of its summary).
        size: Bytes of the file.
        messages: Messages it holds.
        chunks: Chunks it holds.
        said: A sentence saying so, for a person.
    """

    stream: BinaryIO
    kept: int
    size: int
    messages: int
    chunks: int
    said: str


@dataclasses.dataclass
class _ChunkFound:
    offset: int
    length: int
    head: tuple[int, int, int, int]  # start, end, uncompressed size, CRC
    compression: str
    compressed: int
    indexes: dict[int, int] = dataclasses.field(default_factory=dict)
    index_length: int = 0
    counts: dict[int, int] = dataclasses.field(default_factory=lambda: defaultdict(int))

    def index(self) -> ChunkIndex:
        start, end, uncompressed, _ = self.head
        return ChunkIndex(message_start_time=start, message_end_time=end, chunk_start_offset=self.offset,
                          chunk_length=self.length, message_index_offsets=dict(self.indexes),
                          message_index_length=self.index_length, compression=self.compression,
                          compressed_size=self.compressed, uncompressed_size=uncompressed)


class _Scan:
    """The records of a file's data section, read as far as they are whole."""

    def __init__(self, stream: BinaryIO, size: int) -> None:
        self.stream, self.size = stream, size
        self.schemas: dict[int, Schema] = {}
        self.channels: dict[int, Channel] = {}
        self.metadata: list[MetadataIndex] = []
        self.chunks: list[_ChunkFound] = []
        #: Messages outside chunks (a file written without chunks), by channel, and their log times.
        self.loose: dict[int, int] = defaultdict(int)
        self.loose_times: list[int] = []
        #: Where the records read whole end: the data kept.
        self.kept = len(MAGIC)
        #: Whether the last chunk's message indexes are known whole (another record, or the data's end, followed).
        self.last_indexes_whole = False

    def run(self) -> None:
        offset = len(MAGIC)
        while True:
            self.stream.seek(offset)
            head = self.stream.read(_RECORD_HEAD.size)
            if len(head) < _RECORD_HEAD.size:
                return
            opcode, length = _RECORD_HEAD.unpack(head)
            end = offset + _RECORD_HEAD.size + length
            if end > self.size or opcode == 0:
                return   # cut short, or zeros a crash left: the data ends with the last whole record
            if opcode in _SUMMARY_OPCODES:
                self.last_indexes_whole = True   # the data section was ended: only its summary is missing
                return
            if opcode == Opcode.MESSAGE_INDEX and self.chunks:
                channel, entries = _INDEX_HEAD.unpack(self.stream.read(_INDEX_HEAD.size))
                chunk = self.chunks[-1]
                chunk.indexes[channel] = offset
                chunk.index_length = end - (chunk.offset + chunk.length)
                chunk.counts[channel] += entries // 16
            else:
                self.last_indexes_whole = opcode != Opcode.CHUNK
                self._take(opcode, offset, length)
            self.kept = offset = end

    def _take(self, opcode: int, offset: int, length: int) -> None:
        if opcode == Opcode.CHUNK:
            start, end, uncompressed, crc, named = _CHUNK_HEAD.unpack(self.stream.read(_CHUNK_HEAD.size))
            compression = self.stream.read(named).decode()
            (compressed,) = struct.unpack("<Q", self.stream.read(8))
            self.chunks.append(_ChunkFound(offset, _RECORD_HEAD.size + length, (start, end, uncompressed, crc),
                                           compression, compressed))
        elif opcode == Opcode.MESSAGE:
            channel, _, log_time, _ = _MESSAGE_HEAD.unpack(self.stream.read(_MESSAGE_HEAD.size))
            self.loose[channel] += 1
            self.loose_times.append(log_time)
        elif opcode in (Opcode.SCHEMA, Opcode.CHANNEL, Opcode.METADATA):
            record = ReadDataStream(io.BytesIO(self.stream.read(length)))
            if opcode == Opcode.SCHEMA:
                schema = Schema.read(record)
                self.schemas[schema.id] = schema
            elif opcode == Opcode.CHANNEL:
                channel = Channel.read(record)
                self.channels[channel.id] = channel
            else:
                name_length = record.read4()
                name = record.read(name_length).decode()
                self.metadata.append(MetadataIndex(offset=offset, length=_RECORD_HEAD.size + length, name=name))
        # Anything else (the header, attachments, records of other tools) is kept as it is.

    def check_last_chunks(self) -> None:
        """Drop the last chunks whose data does not check; count the messages of the last one from its data."""
        while self.chunks:
            last = self.chunks[-1]
            self.stream.seek(last.offset + _RECORD_HEAD.size)
            try:
                records = breakup_chunk(Chunk.read(ReadDataStream(self.stream)), validate_crc=True)
            except (McapError, ValueError, EOFError, struct.error):
                # Written, but not whole (a crash between the file's size and its data reaching the disk): the
                # data ends before it, and the indexes of the chunk before were followed by it, so are whole.
                self.chunks.pop()
                self.kept = last.offset
                self.metadata = [m for m in self.metadata if m.offset + m.length <= self.kept]
                self.last_indexes_whole = True
                continue
            if not self.last_indexes_whole:
                # Its indexes may lack channels: readers scan it whole; its counts come from its data.
                last.indexes, last.index_length = {}, 0
                last.counts = defaultdict(int)
                for record in records:
                    if isinstance(record, Message):
                        last.counts[record.channel_id] += 1
                self.kept = last.offset + last.length
            return


def recover(stream: BinaryIO, name: str) -> Recovered:
    """Read *stream*, a recording its recorder did not end, up to its last complete chunk, ended in memory.

    Args:
        stream: The file, open for reading in binary (seekable); the result reads through it.
        name: How to name it in messages.

    Raises:
        NotARecording: when it is not an MCAP file, or (saying "unfinished") holds no message to save.
    """
    size = stream.seek(0, os.SEEK_END)
    stream.seek(0)
    start = stream.read(len(MAGIC))
    if start != MAGIC[:len(start)]:
        raise NotARecording(f"{name} is not an MCAP file (it does not begin as one)")
    if size == 0:
        raise NotARecording(f"{name} is empty: an unfinished recording, stopped before its recorder wrote anything; "
                            "nothing can be saved")
    scan = _Scan(stream, size)
    if len(start) == len(MAGIC):
        scan.run()
        scan.check_last_chunks()
    counts: dict[int, int] = defaultdict(int)
    for chunk in scan.chunks:
        for channel, count in chunk.counts.items():
            counts[channel] += count
    for channel, count in scan.loose.items():
        counts[channel] += count
    messages = sum(counts.values())
    if messages == 0:
        raise NotARecording(
            f"{name} is unfinished and holds no complete chunk: its recorder stopped (killed, crashed, or its machine "
            f"went down) before its first chunk of messages was written ({size} bytes); nothing can be saved")
    times = [t for c in scan.chunks for t in c.head[:2]] + scan.loose_times
    first, last = min(times), max(times)
    ending = file_ending(scan.kept, schemas=list(scan.schemas.values()), channels=list(scan.channels.values()),
                         counts=dict(counts), times=(first, last),
                         chunk_indexes=b"".join(record_bytes(c.index()) for c in scan.chunks),
                         chunk_count=len(scan.chunks), metadata_indexes=scan.metadata)
    torn = size - scan.kept
    said = (f"{name} is unfinished: its recorder stopped without ending it (killed, crashed, or its machine went "
            f"down); it is read up to its last complete chunk: {messages} messages in {len(scan.chunks)} chunks, "
            f"{scan.kept} of its {size} bytes" + (f" (the last {torn} are torn)" if torn else ""))
    ended = io.BufferedReader(_Ended(stream, scan.kept, ending), buffer_size=1 << 16)
    return Recovered(ended, scan.kept, size, messages, len(scan.chunks), said)


class _Ended(io.RawIOBase):
    """A file's first *cut* bytes followed by *ending*: the file as if it had been ended there."""

    def __init__(self, raw: BinaryIO, cut: int, ending: bytes) -> None:
        super().__init__()
        self._raw, self._cut, self._ending = raw, cut, ending
        self._size = cut + len(ending)
        self._position = 0

    def readable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def tell(self) -> int:
        return self._position

    def seek(self, offset: int, whence: int = os.SEEK_SET) -> int:
        base = {os.SEEK_SET: 0, os.SEEK_CUR: self._position, os.SEEK_END: self._size}[whence]
        if base + offset < 0:
            raise ValueError(f"negative seek position {base + offset}")
        self._position = base + offset
        return self._position

    def readinto(self, buffer: WriteableBuffer) -> int:
        view = memoryview(buffer).cast("B")
        done = 0
        while done < len(view) and self._position < self._size:
            if self._position < self._cut:
                self._raw.seek(self._position)
                data = self._raw.read(min(len(view) - done, self._cut - self._position))
                if not data:
                    break
                got = len(data)
                view[done:done + got] = data
            else:
                at = self._position - self._cut
                got = min(len(view) - done, len(self._ending) - at)
                view[done:done + got] = self._ending[at:at + got]
            done += got
            self._position += got
        return done

    def close(self) -> None:
        super().close()
        self._raw.close()
