"""Runtime clocks: real time, sped-up time, and a manually stepped clock for tests.

Every component, simulated drive and simulated sound scene reads time from one
:class:`Clock` owned by the component host, so a whole simulated rig can be run
faster than real time (or stepped by hand) without changing its code.
"""

from __future__ import annotations

import abc
import asyncio
import heapq
import itertools
import threading
import time

__all__ = ["Clock", "RealClock", "ScaledClock", "ManualClock"]


class Clock(abc.ABC):
    """Where the runtime reads the time and waits.

    ``now()`` is a monotonic runtime time in seconds; ``wall()`` is the matching
    POSIX time, used for timestamps published on ports.  ``now()`` and ``wall()``
    may be called from any thread; ``sleep`` and ``sleep_until`` are for the
    event loop.
    """

    #: How many runtime seconds pass per real second (1 for real time).
    scale: float = 1.0

    @abc.abstractmethod
    def now(self) -> float:
        """Return the runtime time in seconds (monotonic)."""

    def wall(self) -> float:
        """Return the POSIX time (seconds since the epoch) matching :meth:`now`."""
        return self._wall_origin + self.now()

    @abc.abstractmethod
    async def sleep_until(self, deadline: float) -> None:
        """Wait until :meth:`now` reaches *deadline* (returns at once if it has)."""

    async def sleep(self, delay: float) -> None:
        """Wait *delay* runtime seconds."""
        await self.sleep_until(self.now() + max(0.0, delay))

    def to_real(self, delay: float) -> float:
        """Convert a runtime duration into the real duration it takes."""
        return delay / self.scale

    def __init__(self) -> None:
        # Chosen so that wall() == time.time() at construction.
        self._wall_origin = 0.0
        self._wall_origin = time.time() - self.now()


class RealClock(Clock):
    """The clock of a real rig: runtime time is ``time.monotonic()``."""

    def now(self) -> float:
        return time.monotonic()

    async def sleep_until(self, deadline: float) -> None:
        delay = deadline - self.now()
        if delay > 0:
            await asyncio.sleep(delay)
        else:
            await asyncio.sleep(0)


class ScaledClock(Clock):
    """Runtime time that runs *scale* times faster than real time.

    Used by the simulated rig and by the tests: with ``scale=50`` a five-second
    head move takes a tenth of a second of real time, yet every component sees
    consistent speeds, accelerations and sample rates.

    Args:
        scale: Runtime seconds per real second (must be positive).
    """

    def __init__(self, scale: float = 1.0) -> None:
        if not scale > 0:
            raise ValueError(f"clock scale must be positive, not {scale!r}")
        self.scale = float(scale)
        self._real_origin = time.monotonic()
        super().__init__()

    def now(self) -> float:
        return (time.monotonic() - self._real_origin) * self.scale

    async def sleep_until(self, deadline: float) -> None:
        delay = (deadline - self.now()) / self.scale
        await asyncio.sleep(delay if delay > 0 else 0)


class ManualClock(Clock):
    """A clock that only moves when a test calls :meth:`advance`.

    Sleepers wake in deadline order as time is advanced, and the event loop runs
    between two wake-ups, so the code under test sees every intermediate time.

    Args:
        start: The initial runtime time.
    """

    scale = float("inf")

    def __init__(self, start: float = 0.0) -> None:
        self._now = float(start)
        self._lock = threading.Lock()
        self._sleepers: list[tuple[float, int, asyncio.Future[None]]] = []
        self._order = itertools.count()
        super().__init__()

    def now(self) -> float:
        with self._lock:
            return self._now

    def to_real(self, delay: float) -> float:
        return 0.0

    async def sleep_until(self, deadline: float) -> None:
        if deadline <= self.now():
            await asyncio.sleep(0)
            return
        future: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        heapq.heappush(self._sleepers, (deadline, next(self._order), future))
        await future

    async def advance(self, delta: float) -> None:
        """Move time forward by *delta*, waking sleepers in order on the way."""
        target = self.now() + delta
        await self._settle()
        while self._sleepers and self._sleepers[0][0] <= target:
            deadline, _, future = heapq.heappop(self._sleepers)
            with self._lock:
                self._now = max(self._now, deadline)
            if not future.done():
                future.set_result(None)
            await self._settle()
        with self._lock:
            self._now = target
        await self._settle()

    @staticmethod
    async def _settle() -> None:
        # A few loop turns let woken coroutines run up to their next await.
        for _ in range(5):
            await asyncio.sleep(0)
