"""Reading an audio port without loss, read after read: the one reader of the recorder, the live view and the localiser.

An audio port (any port whose type carries :class:`~aiogenomix.components.core.AudioStream`:
``capture``'s chunks, ``bass``'s frames, another package's audio) is incremental: the reader holds
the index of the last item it has and asks for what came after it, so nothing is read twice and
whatever the port no longer held is counted as lost.  A port of another process (its mirror in
this process) answers the same way, with data that is JSON-ready already.  What a read holds, the
port's kind says (:meth:`AudioStream.read`): frames, the chunks they belong to, their capture
times and the head's azimuth at the end of each chunk.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

from ..core import AudioRead, AudioStream, Incremental, OutPortRuntime

__all__ = ["AudioReader", "NotAudio"]


class NotAudio(TypeError):
    """The port's type carries no audio (its declaration gives it no :class:`AudioStream` kind)."""


class AudioReader:
    """The new audio of one out port, read after read.

    Args:
        port: The port (an out port of this process, or the mirror of another process's).
        element: The element of a multiple port (None for a simple one).

    Raises:
        NotAudio: when the port's type carries no audio.

    Where the reading starts is the caller's choice: :meth:`start_live` (from the next
    publication), :meth:`start_at` (after an item), :meth:`start_with_last_publication` (the
    items the newest publication added); until one is called, the first read starts live.
    """

    def __init__(self, port: OutPortRuntime[Any], element: str | None = None) -> None:
        kind = port.type.carries
        if not isinstance(kind, AudioStream):
            raise NotAudio(f"{port.name} carries no audio (its type, {port.type.name}, declares no AudioStream)")
        self.port, self.kind, self.element = port, kind, element
        #: The last item read (None: not started).
        self.since: int | None = None
        #: Frames per chunk, once a read has said it (a read of chunks is cut by it).
        self.chunk_frames = 0

    def _current(self) -> Incremental | None:
        value = self.port.read(self.element)
        return value if isinstance(value, Incremental) else None

    def start_at(self, index: int) -> None:
        """Read the items after *index*."""
        self.since = max(0, int(index))

    def start_live(self) -> None:
        """Read what the port publishes from now on.

        Raises:
            PortUnavailable: when its component withdrew the data (a sensor down).
        """
        current = self._current()
        self.since = current.index if current is not None else 0

    def start_with_last_publication(self) -> None:
        """Read from the items the newest publication added (a viewer gets the newest chunk at once).

        Raises:
            PortUnavailable: when its component withdrew the data.
        """
        current = self._current()
        if current is None:
            self.since = 0
        else:
            added = int(getattr(current, "items_per_publication", 1))
            self.since = max(0, current.index - added)

    def read(self, now: float) -> AudioRead | None:
        """The audio published after the last item read (None: nothing new yet).

        A port whose index went back holds a new capture: it is read from its first item, and the
        read says ``restarted``.

        Args:
            now: The rig's time now (the time of audio whose port carries none).

        Raises:
            PortUnavailable: when its component withdrew the data (a sensor down).
            ValueError: when a read of chunks does not hold whole chunks.
        """
        current = self._current()
        if current is None:
            return None
        newest = current.index
        if self.since is None:
            self.since = newest  # not started: from the next publication on
            return None
        restarted = newest < self.since
        if restarted:
            self.since, self.chunk_frames = 0, 0  # a new capture may have another chunk size
        if newest <= self.since:
            return None
        data, lost = current.since(self.since)
        read = self.kind.read(self.port.type.encode(data), since=self.since, lost=lost, now=now,
                              chunk_frames=self.chunk_frames)
        self.since = max(self.since, read.newest)
        self.chunk_frames = read.chunk_frames or self.chunk_frames
        return dataclasses.replace(read, restarted=True) if restarted else read

    async def next(self, now: Callable[[], float]) -> AudioRead:
        """Wait for new audio and return it (*now* gives the rig's time of the read).

        Raises:
            PortUnavailable: when its component withdrew the data (a sensor down).
        """
        while True:
            version = self.port.version
            read = self.read(now())
            if read is not None:
                return read
            # Nothing is awaited between the read above and this wait: no publication slips between them.
            await self.port.wait_published(version)
