"""Camera frames in memory shared with the render process, published without a copy and never changed.

The render process writes a frame into a free *slot* of an anonymous shared file; the world
publishes a read-only array over that slot, and the slot is free again only when the last array
or view over it is gone (a reader, a reply being written, a user's list of frames).  So a
publication never changes under its readers, and the gateway process copies no frame.  A user who
keeps more frames than the pool holds makes the world render into a spare slot and publish a copy.
"""

from __future__ import annotations

import collections
import mmap
import os
import tempfile
import weakref

import numpy as np

__all__ = ["FramePool"]


def _anonymous_file(size: int) -> int:
    """A file descriptor of *size* zeroed octets in memory, with no name (nothing to unlink or leak)."""
    if hasattr(os, "memfd_create"):
        fd = os.memfd_create("aiogenomix-world-frames", os.MFD_CLOEXEC)
    else:  # not Linux: an unlinked temporary file serves the same
        with tempfile.TemporaryFile() as file:
            fd = os.dup(file.fileno())
    os.ftruncate(fd, size)
    return fd


class FramePool:
    """*slots* frames of *frame_bytes* octets, and *spares* more, in an anonymous shared file.

    The pool hands out free slots (:meth:`take`) for the render process to draw into, and turns a
    drawn slot into a published array (:meth:`publish`).  Spare slots are drawn into when no slot
    is free: their frames are published as copies, and the spare is reused at once.

    Args:
        frame_bytes: Octets of one frame.
        slots: Frames that can be published in place.
        spares: Frames that can be drawn when every slot is held by readers.
    """

    def __init__(self, frame_bytes: int, slots: int, spares: int) -> None:
        self.frame_bytes = frame_bytes
        self.slots, self.spares = slots, spares
        self._fd: int | None = _anonymous_file(frame_bytes * (slots + spares))
        self._memory = mmap.mmap(self._fd, frame_bytes * (slots + spares))
        # Read-only from here: a published frame cannot be made writable again by its readers.
        self._view = memoryview(self._memory).toreadonly()
        # Appended from the finalizers of published arrays, on whichever thread drops the last
        # reference: deque's append and popleft are atomic.
        self._free = collections.deque(range(slots))
        #: Frames published as copies, because every slot was held (a reader keeping many frames).
        self.copies = 0

    def fileno(self) -> int:
        """The shared file, for the render process to map (valid until :meth:`forget_file`)."""
        if self._fd is None:
            raise ValueError("the frame pool's file was already handed over")
        return self._fd

    def forget_file(self) -> None:
        """Close the descriptor once the render process has it: the mappings keep the memory."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    def take(self, spare: int) -> int:
        """A free slot, or spare slot number *spare* (``0 <= spare < spares``) if none is free."""
        try:
            return self._free.popleft()
        except IndexError:
            return self.slots + spare

    def give_back(self, slot: int) -> None:
        """Return a slot taken but not published (its frame was not drawn, or not wanted)."""
        if slot < self.slots:
            self._free.append(slot)

    def publish(self, slot: int) -> np.ndarray:
        """The frame drawn into *slot* as a read-only 1-D array of octets.

        A slot's array holds the slot until it and every view of it are gone; a spare's frame is
        copied, and the spare is free at once.
        """
        start = slot * self.frame_bytes
        frame = np.frombuffer(self._view[start:start + self.frame_bytes], np.uint8)
        if slot >= self.slots:
            self.copies += 1
            copy = frame.copy()
            copy.flags.writeable = False
            return copy
        weakref.finalize(frame, self._free.append, slot).atexit = False
        return frame

    @property
    def free(self) -> int:
        """How many slots are free now."""
        return len(self._free)

    def close(self) -> None:
        """Let the memory go when the last published frame is gone (frames still read stay valid)."""
        self.forget_file()
        self._view.release()
