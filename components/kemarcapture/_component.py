"""The ``kemarcapture`` component: audio capture and the KEMAR head in one (seed section 6.5, appendix 9.5.3)."""

from __future__ import annotations

import logging
import math
from typing import Any

from ..capture import Capture, HeadPositionSource, PortView
from ..core import OutPort, ThrottledLog, redeclare
from ..kemar import BUS_ERROR, Kemar, KemarError
from ._types import KemarPortData, MoveIndexes

__all__ = ["KemarCapture"]

log = logging.getLogger(__name__)
#: A bus that stops answering fails every chunk's position (20 a second): rate-limited.
_position_log = ThrottledLog(log)


class KemarCapture(Capture, Kemar, name="kemarcapture", version="1.0"):
    """Binaural capture and the motorised KEMAR head in one component, each chunk tagged with the head azimuth.

    Every service of ``capture`` and ``kemar``.  Port also carries ``positions``,
    the head azimuth (degrees, positive = left) read from the drive as each chunk
    arrives; the dedicated socket appends them as float32 to each reply.
    MoveAbsolutePosition publishes (chunk index, azimuth) on Indexes when it
    starts and when the head arrives.  With the simulated scene the sound turns
    with the simulated head.
    """

    Port = OutPort(KemarPortData, view=PortView, doc="The last Port_chunks chunks of binaural audio and the head "
                                                     "azimuth at the end of each, oldest first")
    Indexes = OutPort(MoveIndexes, doc="Chunk index and head azimuth at the start and the end of the last "
                                       "MoveAbsolutePosition")

    port_data = KemarPortData

    async def on_start(self) -> None:
        await super().on_start()
        self.Indexes.publish(MoveIndexes())
        #: Chunks published with a NaN position because the drive did not answer in time.
        self.position_failures = 0

    def head_position_source(self) -> HeadPositionSource:
        """Each chunk carries the head azimuth read from the drive as it arrives."""
        return self._read_position

    async def _read_position(self) -> float:
        """The head azimuth from the drive now, or NaN when the drive does not answer.

        A chunk is not held back by a failing head: the failure is in the data
        (NaN), counted in :attr:`position_failures`, and logged.  The driver's own
        time-out (the host's ``can_timeout``) bounds the wait.
        """
        try:
            return await self.head().read_position()
        except (KemarError, BUS_ERROR) as exc:
            self.position_failures += 1
            _position_log.warning("%s: head position unavailable (%s): published as NaN", self.instance, exc)
            return math.nan

    def _current_index(self) -> int:
        window = self.window
        return window.last_index if window is not None else 0

    @redeclare(Kemar.MoveAbsolutePosition, doc=(
        "Turn the head to an azimuth and wait until it is there; publish (chunk index, azimuth) on Indexes "
        "at the start and on arrival."))
    async def MoveAbsolutePosition(self, **inputs: Any) -> Any:
        start = MoveIndexes(startIndex=self._current_index(), startPosition=await self._read_position())
        self.Indexes.publish(start)
        outcome = await Kemar.MoveAbsolutePosition(self, **inputs)
        self.Indexes.publish(MoveIndexes(start.startIndex, start.startPosition, self._current_index(),
                                         await self._read_position(), arrived=True))
        return outcome
