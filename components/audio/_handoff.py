"""Hand-over of chunks from a device thread to the event loop, bounded and never silent.

A sound card does not wait: when the loop falls behind, the device thread must
not block (the card would overrun) nor queue without bound.  The hand-over
keeps at most *depth* chunks in flight; a chunk that finds no room is dropped
and its frames are counted, and the next chunk that gets through carries the
count (``Chunk.overrun`` and ``Chunk.lost_frames``).  Device errors travel the
same way, so a failing thread always wakes the reader.
"""

from __future__ import annotations

import asyncio
import threading

import numpy as np
import numpy.typing as npt

from ._backend import Chunk

__all__ = ["ThreadHandoff"]


class _End:
    """Marks the end of the stream."""


class ThreadHandoff:
    """Chunks from one producer thread to one reader in the event loop.

    Args:
        loop: The event loop of the reader.
        depth: How many chunks may wait for the reader before new ones are dropped.
    """

    def __init__(self, loop: asyncio.AbstractEventLoop, depth: int = 8) -> None:
        self._loop = loop
        self._queue: asyncio.Queue[Chunk | BaseException | _End] = asyncio.Queue()
        self._slots = threading.Semaphore(depth)
        # Only the producer thread touches these two.
        self._pending_overrun = False
        self._pending_lost = 0

    # -- producer side (any thread) -------------------------------------------------------

    def overrun(self, lost_frames: int) -> None:
        """Record that the device lost *lost_frames* frames before the next chunk."""
        self._pending_overrun = True
        self._pending_lost += max(0, lost_frames)

    def put(self, frames: npt.NDArray[np.int32], time: float) -> bool:
        """Offer a chunk; return False (and count its frames as lost) when the reader is behind."""
        if not self._slots.acquire(blocking=False):
            self.overrun(len(frames))
            return False
        chunk = Chunk(frames, time, self._pending_overrun, self._pending_lost)
        self._pending_overrun, self._pending_lost = False, 0
        return self._deliver(chunk)

    def fail(self, error: BaseException) -> None:
        """Make the reader raise *error*."""
        self._deliver(error)

    def end(self) -> None:
        """Make the reader see the end of the stream."""
        self._deliver(_End())

    def _deliver(self, item: Chunk | BaseException | _End) -> bool:
        try:
            self._loop.call_soon_threadsafe(self._queue.put_nowait, item)
        except RuntimeError:
            # The loop is closed: nobody is left to read.
            return False
        return True

    # -- reader side (event loop) ----------------------------------------------------------

    async def get(self) -> Chunk | None:
        """The next chunk, or None at the end of the stream.

        Raises:
            BaseException: whatever the producer passed to :meth:`fail`.
        """
        item = await self._queue.get()
        if isinstance(item, Chunk):
            self._slots.release()
            return item
        if isinstance(item, _End):
            self._queue.put_nowait(item)  # later reads see the end too
            return None
        raise item
