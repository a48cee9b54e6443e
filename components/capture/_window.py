"""The chunk window: the last ``Port_chunks`` chunks with absolute indices, sans I/O.

This is the linear port design of the seed (section 5.2.1) without its shifting
copies.  Chunks are numbered from 1 (the port ``index`` is the number of chunks
published since the start, so it is also the index of the newest chunk).  Each
chunk is written twice, at slot ``s`` and ``s + capacity`` of a ring twice the
window long, so that any run of consecutive chunks ending at the newest one is
one contiguous slice: reading the whole window, or the chunks after index *k*,
costs one copy and never a gather.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import numpy.typing as npt

__all__ = ["ChunkWindow", "WindowRead"]

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
        self._left = np.zeros((2 * capacity, frames_per_chunk), dtype=np.int32)
        self._right = np.zeros((2 * capacity, frames_per_chunk), dtype=np.int32)
        self._positions = np.zeros(2 * capacity, dtype=np.float64) if with_positions else None
        self._last = 0

    @property
    def last_index(self) -> int:
        """The index of the newest chunk (0 before the first one)."""
        return self._last

    @property
    def first_index(self) -> int:
        """The index of the oldest chunk still held (1 until the window wraps)."""
        return max(1, self._last - self.capacity + 1)

    @property
    def nbytes(self) -> int:
        """Memory used by the window's buffers."""
        extra = self._positions.nbytes if self._positions is not None else 0
        return self._left.nbytes + self._right.nbytes + extra

    def append(self, left: npt.ArrayLike, right: npt.ArrayLike, position: float | None = None) -> int:
        """Add the next chunk and return its index.

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
        slot = self._last % self.capacity
        for row in (slot, slot + self.capacity):
            self._left[row] = left_arr
            self._right[row] = right_arr
            if self._positions is not None:
                self._positions[row] = position
        self._last += 1
        return self._last

    def _rows(self, count: int) -> slice:
        # The newest chunk sits at slot (last-1) % capacity and at that plus capacity;
        # the `count` chunks ending there are the contiguous rows just before `end`.
        end = (self._last - 1) % self.capacity + self.capacity + 1
        return slice(end - count, end)

    def since(self, index: int, *, limit: int | None = None, copy: bool = True) -> WindowRead:
        """The chunks newer than *index* that the window still holds.

        Args:
            index: The index of the last chunk the reader holds (0 for none).  An
                index ahead of the window (a reader of an earlier capture) gets
                nothing and no loss.
            limit: Return at most this many chunks (the newest ones; the older
                ones count as lost).
            copy: Return copies (the default).  ``copy=False`` returns views into
                the ring, valid only until the next :meth:`append`.

        Returns:
            The chunks, oldest first, with the count of chunks lost.
        """
        newer = max(0, self._last - max(0, index))
        count = min(newer, self.capacity if limit is None else max(0, min(limit, self.capacity)))
        rows = self._rows(count)
        left, right = self._left[rows], self._right[rows]
        positions = self._positions[rows] if self._positions is not None else None
        if copy:
            left, right = left.copy(), right.copy()
            positions = positions.copy() if positions is not None else None
        return WindowRead(left=left, right=right, positions=positions,
                          first_index=self._last - count + 1, last_index=self._last, lost=newer - count)

    def snapshot(self) -> WindowRead:
        """The whole window, zero-filled before the first chunks, as the port publishes it.

        Like the original port, it always holds ``capacity`` chunks: until the
        window fills, the oldest ones are zeros (with indices below 1).
        """
        rows = self._rows(self.capacity)
        positions = self._positions[rows].copy() if self._positions is not None else None
        return WindowRead(left=self._left[rows].copy(), right=self._right[rows].copy(), positions=positions,
                          first_index=self._last - self.capacity + 1, last_index=self._last, lost=0)
