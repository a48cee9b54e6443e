"""The frame-indexed audio port of ``bass``: immutable chunks, and snapshots that never change once published.

The 2015 port (``Ports.c``) is a window of ``nChunksOnPort`` chunks that
shifts by one chunk per publication, indexed by frame.  Here each captured
chunk becomes one read-only array, and a publication is an
:class:`AudioSnapshot`: a tuple of references to the chunks it holds.  So
publishing costs ``nChunksOnPort`` references, not a copy of the window, and a
reader holding a snapshot (an HTTP read being written, a socket reply, an
in port) reads exactly the frames of that publication however many chunks
arrive meanwhile.

Frame numbering follows ``Ports.c``: the port starts zero-filled with
``lastFrameIndex`` 0, each chunk adds ``nFramesPerChunk``, and
``lastFrameIndex`` names the newest frame.  So the first captured frame is
frame 1, frame *f* (f >= 1) is sample ``f - 1`` of the capture, and the
oldest frame a port holds is ``max(0, lastFrameIndex - frames on port + 1)``
(frame 0 being one of the zeros of the fresh port).

Each chunk's channels are also kept as :class:`~aiogenomix.components.core.Chunk`
(the same memory, with the JSON text made once), so the gateway reads a
snapshot without copying it (:meth:`AudioSnapshot.chunked`).
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import numpy.typing as npt

from ..core import Chunk, ChunkedArray
from ._types import AudioPortData

__all__ = ["ChunkHistory", "AudioSnapshot", "FrameRead"]

Int32Array = npt.NDArray[np.int32]


def _frozen(array: Int32Array) -> Int32Array:
    array.flags.writeable = False
    return array


def _channels(chunk: Int32Array) -> tuple[Chunk, Chunk]:
    """The rows of a read-only ``(2, frames)`` chunk (views of it, not copies)."""
    return Chunk(chunk[0]), Chunk(chunk[1])


@dataclasses.dataclass(frozen=True)
class FrameRead:
    """Consecutive frames taken from a snapshot (``getAudioData`` of the 2015 codels).

    Attributes:
        left: Left samples, int32, oldest first.
        right: Right samples, same length.
        first: Index of the first frame returned (the next frame to read when none is).
        lost: Frames the reader asked for that the port no longer held (skipped).
        last_frame_index: The snapshot's newest frame.
    """

    left: Int32Array
    right: Int32Array
    first: int
    lost: int
    last_frame_index: int

    @property
    def count(self) -> int:
        """How many frames were returned."""
        return int(self.left.shape[0])

    @property
    def next(self) -> int:
        """The index of the frame to ask for next."""
        return self.first + self.count


@dataclasses.dataclass(frozen=True, eq=False)
class AudioSnapshot:
    """One publication of the ``Audio`` port: the chunks it holds, frozen.

    It is :class:`~aiogenomix.components.core.Incremental` by frame index, so the
    gateway's ``since=`` reads and ``watch`` streams count frames here.  Members
    of the port struct are attributes (``sampleRate``, ``left``, ...), built
    from the frozen chunks on first use.

    Attributes:
        sample_rate: Frames per second.
        frames_per_chunk: Frames in a chunk.
        chunks: The ``capacity`` newest chunks, oldest first, each a read-only
            ``(2, frames_per_chunk)`` int32 array; zeros stand for the chunks
            before the first one.
        last_chunk: How many chunks were captured (the newest is ``chunks[-1]``).
        channels: The left and right rows of each chunk as
            :class:`~aiogenomix.components.core.Chunk` (made from ``chunks`` when
            not given).
    """

    sample_rate: int
    frames_per_chunk: int
    chunks: tuple[Int32Array, ...]
    last_chunk: int
    channels: tuple[tuple[Chunk, Chunk], ...] = ()

    def __post_init__(self) -> None:
        if len(self.channels) != len(self.chunks):
            object.__setattr__(self, "channels", tuple(_channels(chunk) for chunk in self.chunks))

    @classmethod
    def empty(cls) -> AudioSnapshot:
        """The port before any acquisition: no frames, every member zero."""
        return cls(0, 1, (), 0)

    @classmethod
    def from_data(cls, data: AudioPortData) -> AudioSnapshot:
        """The snapshot a whole ``binaudio::portStruct`` describes (one read of another process's port).

        An in port connected to ``bass`` in another process reads the port struct, not the
        snapshot object: this gives it back the frame-indexed reads (:meth:`frames`).

        Raises:
            ValueError: when the struct's sizes do not describe whole chunks.
        """
        fpc, capacity = int(data.nFramesPerChunk), int(data.nChunksOnPort)
        if fpc == 0 or capacity == 0:
            return cls.empty()
        left, right = np.asarray(data.left, dtype=np.int32), np.asarray(data.right, dtype=np.int32)
        if len(left) != fpc * capacity or len(right) != len(left) or data.lastFrameIndex % fpc:
            raise ValueError(f"a port of {capacity} chunks of {fpc} frames ending at frame "
                             f"{data.lastFrameIndex} cannot hold {len(left)} and {len(right)} frames")
        both = np.vstack((left, right))
        chunks = tuple(_frozen(both[:, n * fpc:(n + 1) * fpc].copy()) for n in range(capacity))
        return cls(int(data.sampleRate), fpc, chunks, int(data.lastFrameIndex) // fpc)

    @property
    def capacity(self) -> int:
        """Chunks on the port (``nChunksOnPort``)."""
        return len(self.chunks)

    @property
    def frames_on_port(self) -> int:
        """Frames on the port (``nFramesPerChunk * nChunksOnPort``)."""
        return self.capacity * self.frames_per_chunk

    @property
    def last_frame_index(self) -> int:
        """The index of the newest frame (0 before the first chunk)."""
        return self.last_chunk * self.frames_per_chunk

    @property
    def oldest_frame_index(self) -> int:
        """The index of the oldest frame the port holds."""
        return max(0, self.last_frame_index - self.frames_on_port + 1)

    @property
    def index(self) -> int:
        """The newest frame: the incremental index of this port."""
        return self.last_frame_index

    @property
    def items_per_publication(self) -> int:
        """Frames a publication adds: a new ``watch`` starts with the newest chunk."""
        return self.frames_per_chunk

    def copy_frames(self, first: int, out: Int32Array) -> None:
        """Copy frames ``first …`` (as many as *out*, of shape ``(2, n)``, holds) into *out*, chunk by chunk.

        The snapshot holds them: *first* and the count come from :meth:`placed`.
        """
        count = out.shape[1]
        if count == 0:
            return
        fpc = self.frames_per_chunk
        # The chunks tuple starts with the frame after lastFrameIndex - frames on port.
        start = first - (self.last_frame_index - self.frames_on_port + 1)
        done = 0
        while done < count:
            chunk, offset = divmod(start + done, fpc)
            taken = min(fpc - offset, count - done)
            out[:, done:done + taken] = self.chunks[chunk][:, offset:offset + taken]
            done += taken

    def placed(self, next_frame: int, limit: int | None = None) -> tuple[int, int, int]:
        """Where a read of at most *limit* frames from *next_frame* on lands: its first frame, frames lost, count.

        A *next_frame* older than the port starts at the oldest frame held and
        counts the skipped ones as lost; one beyond the newest frame gets nothing.

        Raises:
            ValueError: for a negative frame index or limit.
        """
        if next_frame < 0 or (limit is not None and limit < 0):
            raise ValueError(f"frame index and limit are never negative, not {next_frame} and {limit}")
        if not self.chunks:
            return next_frame, 0, 0
        oldest, newest = self.oldest_frame_index, self.last_frame_index
        first = max(next_frame, oldest)
        count = max(0, newest - first + 1)
        return first, max(0, oldest - next_frame), count if limit is None else min(count, limit)

    def frames(self, next_frame: int, limit: int | None = None) -> FrameRead:
        """At most *limit* frames from *next_frame* on, as the 2015 socket and ``basc`` read them (see :meth:`placed`).

        Raises:
            ValueError: for a negative frame index or limit.
        """
        first, lost, count = self.placed(next_frame, limit)
        both = np.empty((2, count), dtype=np.int32)
        self.copy_frames(first, both)
        return FrameRead(both[0], both[1], first, lost, self.last_frame_index)

    # -- the port struct ------------------------------------------------------------------

    def _struct(self, left: Int32Array, right: Int32Array) -> AudioPortData:
        return AudioPortData(sampleRate=self.sample_rate, nChunksOnPort=self.capacity,
                             nFramesPerChunk=self.frames_per_chunk, lastFrameIndex=self.last_frame_index,
                             left=left, right=right)

    @functools.cached_property
    def data(self) -> AudioPortData:
        """The whole port as ``binaudio::portStruct`` (zeros before the first frames)."""
        if not self.chunks:
            return AudioPortData()
        both = np.concatenate(self.chunks, axis=1)
        return self._struct(both[0], both[1])

    def __getattr__(self, name: str) -> object:
        # The struct's members (sampleRate, left, ...) come from the materialised data.
        if name.startswith("_") or name not in AudioPortData.__dataclass_fields__:
            raise AttributeError(name)
        return getattr(self.data, name)

    def chunked(self, since: int | None = None) -> tuple[AudioPortData, int]:
        """The port struct with ``left`` and ``right`` as chunked arrays of the snapshot's chunks.

        Args:
            since: None for the whole port; else the frames after this frame.

        Returns:
            The struct (its arrays are :class:`~aiogenomix.components.core.ChunkedArray`,
            not copies) and the frames lost.
        """
        if not self.chunks and since is None:
            return AudioPortData(), 0  # as ``data``
        if since is None:
            rows, lost = self.channels, 0
        else:
            oldest, newest = self.oldest_frame_index, self.last_frame_index
            lost = max(0, oldest - (since + 1)) if self.chunks else 0
            first = max(since + 1, oldest)
            if first > newest or not self.chunks:
                rows = ()
            else:
                head, offset = divmod(first - (newest - self.frames_on_port + 1), self.frames_per_chunk)
                rows = self.channels[head:]
                if offset:  # a read that starts inside a chunk: its tail, encoded for this read
                    rows = ((Chunk(rows[0][0].array[offset:]), Chunk(rows[0][1].array[offset:])), *rows[1:])
        left = ChunkedArray([row[0] for row in rows], np.int32)
        right = ChunkedArray([row[1] for row in rows], np.int32)
        return self._struct(left, right), lost  # type: ignore[arg-type]

    def since(self, index: int) -> tuple[AudioPortData, int]:
        """The frames after frame *index* as the port struct, and how many of those the port no longer held."""
        read = self.frames(index + 1)
        return self._struct(read.left, read.right), read.lost


class ChunkHistory:
    """The chunks of one acquisition, kept as immutable arrays; each append returns the new snapshot.

    Args:
        capacity: Chunks on the port (``nChunksOnPort``).
        frames_per_chunk: Frames in a chunk.
        sample_rate: Frames per second (reported in the port).

    Raises:
        ValueError: for a capacity or a chunk size below 1.
    """

    def __init__(self, capacity: int, frames_per_chunk: int, sample_rate: int) -> None:
        if capacity < 1 or frames_per_chunk < 1:
            raise ValueError(f"a port needs nChunksOnPort >= 1 and nFramesPerChunk >= 1, "
                             f"not {capacity} and {frames_per_chunk}")
        # One shared zero chunk stands for every chunk before the first.
        zero = _frozen(np.zeros((2, frames_per_chunk), dtype=np.int32))
        self.snapshot = AudioSnapshot(sample_rate, frames_per_chunk, (zero,) * capacity, 0,
                                      (_channels(zero),) * capacity)

    def append(self, left: npt.ArrayLike, right: npt.ArrayLike) -> AudioSnapshot:
        """Add the next chunk (its samples are copied once, into a read-only array) and return the snapshot.

        Raises:
            ValueError: for a chunk of the wrong size.
        """
        old = self.snapshot
        shape = (old.frames_per_chunk,)
        if np.shape(left) != shape or np.shape(right) != shape:
            raise ValueError(f"a chunk is {old.frames_per_chunk} frames per channel, got "
                             f"{np.shape(left)} and {np.shape(right)}")
        chunk = np.empty((2, old.frames_per_chunk), dtype=np.int32)
        chunk[0], chunk[1] = left, right
        frozen = _frozen(chunk)
        self.snapshot = dataclasses.replace(old, chunks=(*old.chunks[1:], frozen), last_chunk=old.last_chunk + 1,
                                            channels=(*old.channels[1:], _channels(frozen)))
        return self.snapshot
