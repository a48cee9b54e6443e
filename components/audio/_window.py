"""The chunk window: the last ``Port_chunks`` chunks with absolute indices, sans I/O.

This is the linear port design of the seed (section 5.2.1) without its shifting
copies.  Chunks are numbered from 1 (the port ``index`` is the number of chunks
published since the start, so it is also the index of the newest chunk).  Each
chunk is copied once into read-only arrays, and the window is a tuple of
references to the newest ones: a :class:`WindowState` taken at publication
(``window.state``) keeps the chunks of that publication however many arrive
afterwards, so a read, a socket reply or a port view always gets the data of
the publication it names.  Reading the chunks after index *k* joins them in one
copy; :meth:`WindowState.chunks_since` hands them out without joining them (each
:class:`~aiogenomix.components.core.Chunk` keeps its JSON text once made, so the
gateway writes what is already encoded).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import numpy.typing as npt

from ..core import Chunk

__all__ = ["ChunkWindow", "WindowRead", "WindowState"]

Int32Array = npt.NDArray[np.int32]
Float64Array = npt.NDArray[np.float64]


@dataclasses.dataclass(frozen=True)
class WindowRead:
    """The chunks a reader gets from :meth:`ChunkWindow.since`.

    Attributes:
        left: Left samples, shape ``(n, frames_per_chunk)``, int32, oldest chunk first.
        right: Right samples, same shape.
        positions: Head position (degrees) at the end of each chunk, shape ``(n,)``,
            or None for a window without positions.
        first_index: Index of the first chunk returned (``last_index + 1`` when none).
        last_index: Index of the newest chunk in the window (0 before any chunk).
        lost: Chunks between the reader's index and ``first_index`` that the window
            no longer holds.
    """

    left: Int32Array
    right: Int32Array
    positions: Float64Array | None
    first_index: int
    last_index: int
    lost: int

    @property
    def count(self) -> int:
        """How many chunks were returned."""
        return int(self.left.shape[0])

    def frames(self) -> Int32Array:
        """The returned samples as ``(count * frames_per_chunk, 2)`` int32 frames."""
        return np.stack([self.left.reshape(-1), self.right.reshape(-1)], axis=1)


def _frozen(array: npt.NDArray[np.generic]) -> npt.NDArray[np.generic]:
    array.flags.writeable = False
    return array


@dataclasses.dataclass(frozen=True)
class WindowState:
    """The window at one publication: its chunks, frozen.

    Attributes:
        left: The ``capacity`` newest left chunks, oldest first, each a read-only
            ``(frames_per_chunk,)`` int32 array in a :class:`Chunk` (zeros stand for
            chunks before the first).
        right: The right chunks, likewise.
        positions: The head position at the end of each chunk, or None.
        last_index: The index of the newest chunk (0 before the first one).
    """

    left: tuple[Chunk, ...]
    right: tuple[Chunk, ...]
    positions: tuple[float, ...] | None
    last_index: int

    @property
    def capacity(self) -> int:
        """How many chunks the window holds."""
        return len(self.left)

    def _read(self, count: int, lost: int) -> WindowRead:
        rows = slice(self.capacity - count, self.capacity)
        fpc = len(self.left[0])
        left = np.stack([c.array for c in self.left[rows]]) if count else np.zeros((0, fpc), np.int32)
        right = np.stack([c.array for c in self.right[rows]]) if count else np.zeros((0, fpc), np.int32)
        positions = None if self.positions is None else np.array(self.positions[rows], dtype=np.float64)
        return WindowRead(left=left, right=right, positions=positions, first_index=self.last_index - count + 1,
                          last_index=self.last_index, lost=lost)

    def count_since(self, index: int, limit: int | None = None) -> tuple[int, int]:
        """How many chunks newer than *index* the window holds (at most *limit*), and how many it lost."""
        newer = max(0, self.last_index - max(0, index))
        count = min(newer, self.capacity if limit is None else max(0, min(limit, self.capacity)))
        return count, newer - count

    def chunks_since(self, index: int | None, limit: int | None = None
                     ) -> tuple[tuple[Chunk, ...], tuple[Chunk, ...], int]:
        """The chunks newer than *index* (None: the whole window), left and right, not copied; and the lost count.

        With *limit*, at most that many: the newest (the older count as lost).
        """
        count, lost = (self.capacity, 0) if index is None else self.count_since(index, limit)
        rows = slice(self.capacity - count, self.capacity)
        return self.left[rows], self.right[rows], lost

    def positions_since(self, index: int | None, limit: int | None = None) -> Float64Array | None:
        """The positions of the chunks :meth:`chunks_since` returns (None for a window without)."""
        if self.positions is None:
            return None
        count = self.capacity if index is None else self.count_since(index, limit)[0]
        return np.array(self.positions[self.capacity - count:], dtype=np.float64)

    def since(self, index: int, *, limit: int | None = None) -> WindowRead:
        """The chunks newer than *index* that the window held, in fresh arrays.

        Args:
            index: The index of the last chunk the reader holds (0 for none).  An
                index ahead of the window (a reader of an earlier capture) gets
                nothing and no loss.
            limit: Return at most this many chunks (the newest ones; the older
                ones count as lost).

        Returns:
            The chunks, oldest first, with the count of chunks lost.
        """
        return self._read(*self.count_since(index, limit))

    def snapshot(self) -> WindowRead:
        """The whole window, zero-filled before the first chunks, as the port publishes it."""
        return self._read(self.capacity, 0)


class ChunkWindow:
    """The newest *capacity* chunks of a capture, with their absolute indices.

    Args:
        capacity: How many chunks the window holds (``Port_chunks``).
        frames_per_chunk: Frames in each chunk.
        with_positions: Also keep one head position (degrees) per chunk.

    Raises:
        ValueError: for a capacity or a chunk size below 1.
    """

    def __init__(self, capacity: int, frames_per_chunk: int, *, with_positions: bool = False) -> None:
        if capacity < 1 or frames_per_chunk < 1:
            raise ValueError(f"a window needs capacity >= 1 and frames_per_chunk >= 1, "
                             f"not {capacity} and {frames_per_chunk}")
        self.capacity = capacity
        self.frames_per_chunk = frames_per_chunk
        self.with_positions = with_positions
        zero = Chunk(_frozen(np.zeros(frames_per_chunk, dtype=np.int32)))
        #: The window now: replaced (never changed) by each append.
        self.state = WindowState((zero,) * capacity, (zero,) * capacity,
                                 (0.0,) * capacity if with_positions else None, 0)

    @property
    def last_index(self) -> int:
        """The index of the newest chunk (0 before the first one)."""
        return self.state.last_index

    @property
    def first_index(self) -> int:
        """The index of the oldest chunk still held (1 until the window wraps)."""
        return max(1, self.last_index - self.capacity + 1)

    @property
    def nbytes(self) -> int:
        """Memory held by the chunks of the window."""
        arrays = {id(c): c.array.nbytes for c in (*self.state.left, *self.state.right)}
        return sum(arrays.values()) + (8 * self.capacity if self.with_positions else 0)

    def append(self, left: npt.ArrayLike, right: npt.ArrayLike, position: float | None = None) -> int:
        """Add the next chunk (copied once, into read-only arrays) and return its index.

        Args:
            left: ``frames_per_chunk`` left samples (converted to int32).
            right: ``frames_per_chunk`` right samples.
            position: The head position at the end of the chunk (required when the
                window keeps positions, refused otherwise).

        Raises:
            ValueError: for chunks of the wrong size or a missing/unexpected position.
        """
        left_arr = np.asarray(left)
        right_arr = np.asarray(right)
        shape = (self.frames_per_chunk,)
        if left_arr.shape != shape or right_arr.shape != shape:
            raise ValueError(f"a chunk is {self.frames_per_chunk} frames per channel, "
                             f"got {left_arr.shape} and {right_arr.shape}")
        if (position is None) == self.with_positions:
            raise ValueError("this window keeps a position per chunk" if self.with_positions
                             else "this window keeps no positions")
        old = self.state
        positions = None if old.positions is None else (*old.positions[1:], float(position))  # type: ignore[arg-type]
        self.state = WindowState((*old.left[1:], Chunk(_frozen(left_arr.astype(np.int32, copy=True)))),
                                 (*old.right[1:], Chunk(_frozen(right_arr.astype(np.int32, copy=True)))),
                                 positions, old.last_index + 1)
        return self.state.last_index

    def since(self, index: int, *, limit: int | None = None) -> WindowRead:
        """The chunks newer than *index* that the window still holds (see :meth:`WindowState.since`)."""
        return self.state.since(index, limit=limit)

    def snapshot(self) -> WindowRead:
        """The whole window, zero-filled before the first chunks, as the port publishes it.

        Like the original port, it always holds ``capacity`` chunks: until the
        window fills, the oldest ones are zeros (with indices below 1).
        """
        return self.state.snapshot()
