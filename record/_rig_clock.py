"""The gateway's clock as a recorder on another machine estimates it: the time for data that carries none.

Most ports carry their capture time on the rig's clock (a capture's ``ts``, the head's
``timestamp``, a header's stamp); ``bass``'s audio and the cameras' pictures do not.  The
recorder in the rig stamps those with the rig's clock when it reads them; a recorder over HTTP
must do the same, or its recording mixes two clocks (a rig whose clock runs faster than real
time, ``--time-scale``, would put the audio minutes away from the head's azimuths).

The gateway's ``/`` tells its clock's time and rate.  A reading is taken as made halfway
through its request; between readings the clock runs on at its rate from this machine's
monotonic clock, and it is read again every few seconds.  A simulated clock that moves with its
simulation, not with real time, is read again whenever the time is asked.
"""

from __future__ import annotations

import asyncio
import math
import time

from ..clients import AsyncClient

__all__ = ["RigClock"]

#: Real seconds between two readings of a clock that runs at a rate.
READ_AGAIN = 2.0


class RigClock:
    """The clock of the gateway *client* talks to, read at its ``/``.

    Args:
        client: The recorder's client of the gateway.
    """

    def __init__(self, client: AsyncClient) -> None:
        self._client = client
        self._lock = asyncio.Lock()
        self._wall = 0.0
        self._scale = math.inf
        self._at = -math.inf  # this machine's monotonic time of the last reading
        #: How the clock was read: the gateway clock's kind, or why this machine's clock stands in.
        self.kind = "not read yet"
        self._told = True

    async def now(self) -> float:
        """The gateway clock's POSIX time now (this machine's when the gateway tells no clock)."""
        async with self._lock:
            if not self._told:
                return time.time()
            if math.isinf(self._scale) or time.monotonic() - self._at >= READ_AGAIN:
                await self._read()
            if not self._told:
                return time.time()
            if math.isinf(self._scale):
                return self._wall  # moves only with its simulation: as just read
            return self._wall + self._scale * (time.monotonic() - self._at)

    async def _read(self) -> None:
        before = time.monotonic()
        reading = await self._client.clock()
        after = time.monotonic()
        if reading is None:
            self._told, self.kind = False, "this machine's (the gateway tells no clock)"
            return
        self._wall, self._scale, self._at = reading.wall, reading.scale, (before + after) / 2
        self.kind = f"the gateway's ({reading.kind}" + ("" if math.isinf(reading.scale) else
                                                        f" x{reading.scale:g}") + ")"
