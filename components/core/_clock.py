"""Runtime clocks: real time, sped-up time, and simulated time that a test or a simulation controls.

Every component, simulated drive and simulated sound scene reads time from one
:class:`Clock` owned by the component host, so a whole simulated rig can be run
faster than real time, stepped by hand (:class:`ManualClock`) or run as a
discrete-event simulation (:class:`VirtualClock`) without changing its code.
"""

from __future__ import annotations

import abc
import asyncio
import contextlib
import heapq
import itertools
import math
import threading
import time
from collections.abc import Awaitable, Iterator
from typing import Any, TypeVar

__all__ = ["Clock", "RealClock", "ScaledClock", "ManualClock", "VirtualClock"]

T = TypeVar("T")


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

    @contextlib.contextmanager
    def holding(self) -> Iterator[None]:
        """Keep simulated time still while the body waits for something outside the event loop.

        A request to a simulated device served by a thread (the KEMAR drive on its CAN bus)
        takes real time to be answered; on a clock that moves when the simulation is idle
        (:class:`ManualClock`, :class:`VirtualClock`) the answer then belongs to the instant it
        was asked at, however busy the machine.  Real and scaled clocks ignore it.
        """
        yield

    async def aclose(self) -> None:  # noqa: B027 -- a hook: most clocks run nothing by themselves
        """Stop whatever the clock runs by itself (its host calls this when it closes)."""

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
    """A clock that only moves when a test calls :meth:`advance` (or :meth:`run_until`).

    Sleepers wake in deadline order as time is advanced, and the event loop runs
    between two wake-ups, so the code under test sees every intermediate time.
    While something holds the clock (:meth:`Clock.holding`: a request to a drive
    served by a thread), time waits for it.

    Args:
        start: The initial runtime time.
    """

    scale = float("inf")

    #: Loop turns given to woken coroutines to run up to their next wait on the clock (a few
    #: hops each: a task wakes, publishes, sends a frame, sleeps again).
    SETTLE_TURNS = 10

    def __init__(self, start: float = 0.0) -> None:
        self._now = float(start)
        self._lock = threading.Lock()
        self._sleepers: list[tuple[float, int, asyncio.Future[None]]] = []
        self._order = itertools.count()
        self._holds = 0
        #: Resolved when a sleeper arrives or the last hold ends: what a waiting driver of time waits for.
        self._changed: asyncio.Future[None] | None = None
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
        self._signal()
        await future

    @contextlib.contextmanager
    def holding(self) -> Iterator[None]:
        self._holds += 1
        try:
            yield
        finally:
            self._holds -= 1
            if not self._holds:
                self._signal()

    async def advance(self, delta: float) -> None:
        """Move time forward by *delta*, waking sleepers in order on the way."""
        target = self.now() + delta
        await self._settle()
        while (deadline := self._next_deadline()) is not None and deadline <= target:
            self._wake_next()
            await self._settle()
        with self._lock:
            self._now = max(self._now, target)
        await self._settle()

    async def run_until(self, awaitable: Awaitable[T], *, limit: float = 3600.0) -> T:
        """Run simulated time, deadline after deadline, until *awaitable* is done; return its result.

        Time jumps to the next sleeper's deadline each time the loop has settled and nothing
        holds the clock: the outcome does not depend on how fast the machine is.

        Raises:
            TimeoutError: when *awaitable* is not done after *limit* seconds of clock time.
        """
        task = asyncio.ensure_future(awaitable)
        end = self.now() + limit
        try:
            while not task.done():
                await self._settle()
                if task.done():
                    break
                deadline = self._next_deadline()
                if deadline is None:
                    # Nothing waits on the clock: the awaited work waits on something else.
                    waiting: list[asyncio.Future[Any]] = [task, self._change()]
                    await asyncio.wait(waiting, return_when=asyncio.FIRST_COMPLETED)
                    continue
                if deadline > end:
                    raise TimeoutError(f"not done after {limit} s of clock time")
                self._wake_next()
            return task.result()
        finally:
            if not task.done():
                task.cancel()
                await asyncio.wait({task})

    # -- the machinery shared with VirtualClock ------------------------------------------------

    def _next_deadline(self) -> float | None:
        """The earliest deadline of a sleeper still waiting (forgetting those cancelled meanwhile)."""
        while self._sleepers and self._sleepers[0][2].done():
            heapq.heappop(self._sleepers)
        return self._sleepers[0][0] if self._sleepers else None

    def _wake_next(self) -> None:
        deadline, _, future = heapq.heappop(self._sleepers)
        with self._lock:
            self._now = max(self._now, deadline)
        if not future.done():
            future.set_result(None)

    def _change(self) -> asyncio.Future[None]:
        if self._changed is None or self._changed.done():
            self._changed = asyncio.get_running_loop().create_future()
        return self._changed

    def _signal(self) -> None:
        if self._changed is not None and not self._changed.done():
            self._changed.set_result(None)

    async def _settle(self) -> None:
        """Let woken coroutines run up to their next wait, and any held request end."""
        while True:
            for _ in range(self.SETTLE_TURNS):
                await asyncio.sleep(0)
            if not self._holds:
                return
            await self._change()  # resolved when the last hold ends


class VirtualClock(ManualClock):
    """Discrete-event time: it jumps to the next deadline as soon as the simulation has nothing else to do.

    Nothing waits in real time for simulated time to pass, and a loaded machine slows the
    simulation down instead of making it late: a head stops where its controller told it,
    whatever the load.  With a *scale*, time runs no faster than *scale* times real time
    (for a person watching); the default runs as fast as the machine can.  Requests to
    devices served by threads hold the clock while they are answered (:meth:`Clock.holding`).

    The clock drives itself from a task of the running event loop, started when the first
    sleeper arrives and ended when none is left (or by :meth:`aclose`, which its host calls).

    Args:
        scale: At most this many runtime seconds per real second (``inf``: no pacing).
        start: The initial runtime time.
    """

    def __init__(self, scale: float = math.inf, start: float = 0.0) -> None:
        if not scale > 0:
            raise ValueError(f"clock scale must be positive, not {scale!r}")
        super().__init__(start)
        self.scale = float(scale)
        self._real_origin = time.monotonic() - self._now / self.scale
        self._driver: asyncio.Task[None] | None = None

    def to_real(self, delay: float) -> float:
        return delay / self.scale

    async def sleep_until(self, deadline: float) -> None:
        if deadline > self.now() and (self._driver is None or self._driver.done()):
            self._driver = asyncio.get_running_loop().create_task(self._drive(), name="virtual clock")
        await super().sleep_until(deadline)

    async def _drive(self) -> None:
        """Wake the sleepers in deadline order, each once the loop has settled."""
        while True:
            await self._settle()
            deadline = self._next_deadline()
            if deadline is None:
                return  # a new sleeper starts another driver
            if math.isfinite(self.scale):
                ahead = self._real_origin + deadline / self.scale - time.monotonic()
                if ahead > 0:
                    # Pacing for a person watching; a sleeper with an earlier deadline may arrive meanwhile.
                    # (asyncio.timeout: wait_for on Python 3.11 loses a cancellation racing the change.)
                    with contextlib.suppress(TimeoutError):
                        async with asyncio.timeout(ahead):
                            await asyncio.shield(self._change())
                    continue
                # Behind real time (a busy machine): the simulation goes on from here, slower, never
                # rushing later to catch up.
                self._real_origin = time.monotonic() - deadline / self.scale
            self._wake_next()

    async def aclose(self) -> None:
        """Stop driving time (a later sleeper starts again)."""
        driver, self._driver = self._driver, None
        if driver is not None and not driver.done():
            driver.cancel()
            await asyncio.wait({driver})
