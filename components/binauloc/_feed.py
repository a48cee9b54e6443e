"""Reading an audio port without loss: bass's frames or a capture's chunks, with the head azimuth of each sample.

Both ports are incremental (:class:`~aiogenomix.components.core.Incremental`): the
reader holds the index of the last item it has (a frame of ``bass/Audio``, a chunk
of ``capture/Port`` and ``kemarcapture/Port``) and asks for what came after it, so
nothing is read twice and whatever the port no longer held is counted as lost. A
port in another process (its mirror in this gateway) answers the same way, as
encoded data that the in port's type decodes.

The head azimuth of every sample comes from the positions ``kemarcapture`` publishes
with each chunk (the head's azimuth as the chunk arrived, at its end), or else from
the head's position read as the frames arrive; it moves linearly in between, as the
head moved while the frames were captured.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Awaitable, Callable, Mapping
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from ..core import Incremental, InPortRuntime
from ..recording import frames_per_chunk

__all__ = ["AudioBlock", "PortFeed", "NotStreaming"]

#: Full scale of the ports' int32 samples.
_FULL_SCALE = 2.0**31


class NotStreaming(Exception):
    """The in port is not connected."""


@dataclasses.dataclass(frozen=True)
class AudioBlock:
    """Consecutive samples read from the port.

    Attributes:
        samples: ``(n, 2)`` floats, full scale 1, left then right.
        first: The number of the first sample's frame as the port numbers them (from 1).
        rate: The port's sample rate in Hz.
        heads: The head's room azimuth at each sample, degrees, or None when unknown.
        lost: Frames the port no longer held between the previous block and this one.
        restarted: The port started a new acquisition since the previous block.
    """

    samples: npt.NDArray[np.float64]
    first: int
    rate: int
    heads: npt.NDArray[np.float64] | None
    lost: int
    restarted: bool


class PortFeed:
    """The new audio of one connected in port, block after block.

    Args:
        port: The in port (connected to ``bass/Audio``, ``capture/Port`` or ``kemarcapture/Port``).
        items: What the port numbers: ``frames`` (bass) or ``chunks`` (capture, kemarcapture).
        head_position: Reads the head's azimuth now (degrees; NaN when the head does not answer), for
            a port that carries no positions; None: the heads are unknown.

    The first block starts with what the port publishes after the feed is made: it listens live.
    """

    def __init__(self, port: InPortRuntime[Any], items: Literal["frames", "chunks"],
                 head_position: Callable[[], Awaitable[float]] | None = None) -> None:
        self.port = port
        self.items = items
        self.head_position = head_position
        self._index: int | None = None
        self._last_head: float | None = None

    async def next(self) -> AudioBlock:
        """Wait for new audio and return it.

        Raises:
            NotStreaming: when the in port is not connected.
        """
        while True:
            remote = self.port.remote
            if remote is None:
                raise NotStreaming(self.port.name)
            version = remote.version
            value = remote.read(self.port.element)
            newest = value.index if isinstance(value, Incremental) else 0
            if self._index is None and newest:
                self._index = newest            # listen live: from the next publication on
            elif self._index is not None and newest < self._index:
                return await self._block(value, 0, restarted=True)   # a new acquisition from its start
            elif self._index is not None and newest > self._index:
                return await self._block(value, self._index, restarted=False)
            await remote.wait_published(version)

    async def _block(self, value: Incremental, since: int, *, restarted: bool) -> AudioBlock:
        data, lost = value.since(since)
        if isinstance(data, Mapping):            # a mirrored port of another process: encoded data
            data = self.port.type.decode(data, self.port.name)
        newest = int(value.index)
        self._index = newest
        left = np.asarray(data.left, dtype=np.float64)
        right = np.asarray(data.right, dtype=np.float64)
        samples = np.stack([left, right], axis=1) / _FULL_SCALE
        if self.items == "frames":
            rate, lost_frames, first = int(data.sampleRate), lost, newest - len(left) + 1
            positions = None
        else:
            chunks = max(1, newest - since - lost)
            size = frames_per_chunk(len(left), chunks)
            rate, lost_frames, first = int(data.transfer_rate), lost * size, (newest - chunks) * size + 1
            positions = getattr(data, "positions", None)
            positions = np.asarray(positions, dtype=np.float64)[-chunks:] if positions is not None else None
            if positions is not None and len(positions) != chunks:
                positions = None
        if restarted or lost_frames:
            self._last_head = None               # the head's path before the gap is not this block's
        heads = await self._heads(len(samples), positions)
        return AudioBlock(samples, first, rate, heads, lost_frames, restarted)

    async def _heads(self, count: int, positions: npt.NDArray[np.float64] | None) -> npt.NDArray[np.float64] | None:
        """The head azimuth of each of *count* samples: along the chunks' end positions, else read now."""
        if count == 0:
            return None
        if positions is not None and len(positions) and np.all(np.isfinite(positions)):
            ends = positions
        elif self.head_position is not None:
            now = await self.head_position()
            if not math.isfinite(now):
                self._last_head = None
                return None
            ends = np.array([now])
        else:
            self._last_head = None
            return None
        start = self._last_head if self._last_head is not None else float(ends[0])
        self._last_head = float(ends[-1])
        # Each piece (a chunk, or the whole block) goes linearly from the previous end to its own end.
        pieces = len(ends)
        size = count // pieces
        starts = np.concatenate([[start], ends[:-1]])
        ramp = np.arange(1, size + 1) / size
        heads = (starts[:, np.newaxis] + (ends - starts)[:, np.newaxis] * ramp).reshape(-1)
        if len(heads) < count:
            heads = np.concatenate([heads, np.full(count - len(heads), ends[-1])])
        return heads[:count]
