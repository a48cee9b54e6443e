"""The audio of the connected in port, block after block, with the head azimuth of each sample.

The audio library's reader (:class:`~aiogenomix.components.audio.AudioReader`) reads the out port
the in port is connected to, whatever component publishes it (its type carries
:class:`~aiogenomix.components.core.AudioStream`): by index, so nothing is read twice and
whatever the port no longer held is counted as lost; a port in another process (its mirror in
this gateway) answers the same way.

The head azimuth of every sample comes from the azimuths the port carries with each chunk
(``kemarcapture``: the head's azimuth as the chunk arrived, at its end), or else from the head's
position read as the frames arrive; it moves linearly in between, as the head moved while the
frames were captured.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Awaitable, Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from ..audio import AudioReader
from ..core import FULL_SCALE, AudioRead, InPortRuntime

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
        port: The in port (connected to an audio port: ``bass/Audio``, ``capture/Port``...).
        head_position: Reads the head's azimuth now (degrees; NaN when the head does not answer), for
            a port that carries no azimuths; None: the heads are unknown.
        now: The rig's clock (the time of audio whose port carries none).

    The first block starts with what the port publishes after the feed is made: it listens live.
    """

    def __init__(self, port: InPortRuntime[Any], head_position: Callable[[], Awaitable[float]] | None = None,
                 now: Callable[[], float] = time.time) -> None:
        self.port = port
        self.head_position = head_position
        self._now = now
        self._reader: AudioReader | None = None
        self._last_head: float | None = None

    def _reader_of(self) -> AudioReader:
        remote = self.port.remote
        if remote is None:
            raise NotStreaming(self.port.name)
        if self._reader is None or self._reader.port is not remote:
            self._reader = AudioReader(remote, self.port.element)
            self._reader.start_live()
        return self._reader

    async def next(self) -> AudioBlock:
        """Wait for new audio and return it.

        Raises:
            NotStreaming: when the in port is not connected.
        """
        return await self._block(await self._reader_of().next(self._now))

    async def _block(self, read: AudioRead) -> AudioBlock:
        samples = read.frames.astype(np.float64) / FULL_SCALE
        if read.restarted or read.lost_frames:
            self._last_head = None               # the head's path before the gap is not this block's
        heads = await self._heads(len(samples), read.head_azimuths())
        return AudioBlock(samples, read.first_frame, read.rate, heads, read.lost_frames, read.restarted)

    async def _heads(self, count: int, positions: npt.NDArray[np.float64]) -> npt.NDArray[np.float64] | None:
        """The head azimuth of each of *count* samples: along the chunks' end azimuths (*positions*), else read now."""
        if count == 0:
            return None
        if len(positions) and np.all(np.isfinite(positions)):
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
