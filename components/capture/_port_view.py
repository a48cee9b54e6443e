"""The ``Port`` data of one publication, materialised only when someone reads it.

Publishing a full copy of the window for every 50 ms chunk costs a copy of the
whole port (1.4 MB for 80 chunks) even when nobody reads it.  A :class:`PortView`
holds the window's frozen state of its publication (references to read-only
chunks) and builds the port struct only when read, so a read always returns the
chunks of the publication it names, however late it comes.  It also answers
incremental reads (``since``), which makes the port
:class:`~aiogenomix.components.core.Incremental` for the gateway's ``since=``
reads and ``watch`` streams, and :class:`~aiogenomix.components.core.Chunked`:
the gateway reads its chunks as they are (no copy of the window) and writes
their bytes or their JSON texts, made once per chunk.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import numpy as np

from ..core import ChunkedArray
from ._types import PortData, Timestamp
from ..audio import ChunkWindow, WindowRead, WindowState

__all__ = ["PortView"]


class PortView:
    """The port data of a window as it was when published.

    Every member of the port struct is an attribute; the whole window is copied
    out once, on the first access to the samples.

    Args:
        window: The capture's chunk window (None before the first capture: an empty port).
        transfer_rate: The sample rate.
        start: The capture start (POSIX seconds) the port's ``ts`` reports.
        make: The port's struct type (``PortData``, or the merged component's).
    """

    def __init__(self, window: ChunkWindow | None, transfer_rate: int = 0, start: float = 0.0,
                 make: Callable[..., PortData] = PortData) -> None:
        self._state: WindowState | None = window.state if window is not None else None
        self._make = make
        self.transfer_rate = transfer_rate
        self.ts = Timestamp.from_seconds(start)
        #: The newest chunk (published chunks are numbered from 1).
        self.index = self._state.last_index if self._state is not None else 0

    def _data(self, read: WindowRead) -> PortData:
        extra: dict[str, Any] = {} if read.positions is None else {"positions": read.positions}
        return self._make(transfer_rate=self.transfer_rate, nbframes=read.left.size, index=read.last_index,
                          ts=self.ts, left=read.left.reshape(-1), right=read.right.reshape(-1), **extra)

    @functools.cached_property
    def data(self) -> PortData:
        """The whole window as the port struct (zeros before the first chunks)."""
        if self._state is None:
            return self._make()
        return self._data(self._state.snapshot())

    def __getattr__(self, name: str) -> Any:
        # Members other than the few kept above come from the materialised struct.
        if name.startswith("_"):
            raise AttributeError(name)
        return getattr(self.data, name)

    def chunked(self, since: int | None = None) -> tuple[PortData, int]:
        """The port struct with ``left`` and ``right`` as chunked arrays of the publication's chunks.

        Args:
            since: None for the whole window; else the chunks after this index.

        Returns:
            The struct (its arrays are :class:`~aiogenomix.components.core.ChunkedArray`,
            not copies) and the chunks lost.
        """
        if self._state is None:
            return self._make(), 0
        state = self._state
        left, right, lost = state.chunks_since(since)
        positions = state.positions_since(since)
        extra: dict[str, Any] = {} if positions is None else {"positions": positions}
        left_array = ChunkedArray(left, np.int32)
        return self._make(transfer_rate=self.transfer_rate, nbframes=left_array.size, index=state.last_index,
                          ts=self.ts, left=left_array, right=ChunkedArray(right, np.int32), **extra), lost

    def since(self, index: int) -> tuple[PortData, int]:
        """The chunks after *index* as a port struct, and how many of those the window no longer held."""
        if self._state is None:
            return self._make(), 0
        read = self._state.since(index)
        return self._data(read), read.lost
