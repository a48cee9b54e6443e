"""A render process kept alive: restarted with backoff however often it dies, even while it starts.

The world's cameras and laser come from a process of their own (:mod:`._render`).  When it dies
(killed, crashed, out of memory) or hangs, :class:`RenderSupervisor` says so at once (the world
withdraws its camera and laser data, so no reader takes the last frame for a new one), then starts
a new process, and again after each failure, the first time at once and then after a delay that
doubles up to :data:`BACKOFF_MAX`: a process that cannot start is retried forever, at a cost to
the machine of one start every ten seconds.  The first frame of a new process makes the data
current again and resets the delay.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable

import numpy as np

from ..core import ThrottledLog
from ._render import RenderError, SensorRenderer

__all__ = ["RenderSupervisor", "BACKOFF_FIRST", "BACKOFF_MAX"]

log = logging.getLogger(__name__)

#: Real seconds before the second attempt to start a render process (the first is at once).
BACKOFF_FIRST = 0.25
#: The longest wait between two attempts.
BACKOFF_MAX = 10.0


class RenderSupervisor:
    """Keeps the render process of one world running.

    Args:
        make: Makes the renderer (not yet open); called once, the renderer is reopened after failures.
        name: The world's instance, for the log.
        on_down: Called with the reason when frames stop (before any restart).

    Attributes:
        starts: Render processes started so far (the first included).
        up: Whether frames come (False from a failure until the next frame).
        failures: Failures so far (a process that died, hung, or could not start).
        start_failures: Those of them of a process that had not yet started.
        last_error: What the last failure was.
    """

    def __init__(self, make: Callable[[Callable[[int], None]], SensorRenderer], name: str,
                 on_down: Callable[[str], None]) -> None:
        self.renderer = make(self._spawned)
        self.name = name
        self._on_down = on_down
        self.starts = 0
        self.up = False
        self.failures = 0
        self.start_failures = 0
        self.last_error = ""
        # Each world's faults count against a limit of their own: a world that keeps failing must not
        # hide another world's first failure.
        self._log = ThrottledLog(log)
        # Done at the next change (a start, a failure, a recovery), then replaced.
        self._change: asyncio.Future[None] | None = None

    def _spawned(self, pid: int) -> None:
        self.starts += 1
        self._notify()

    def _notify(self) -> None:
        change, self._change = self._change, None
        if change is not None and not change.done():
            change.set_result(None)

    async def wait_for(self, predicate: Callable[[RenderSupervisor], bool]) -> None:
        """Wait until *predicate* (given this supervisor) holds; checked at each start, failure and recovery."""
        while not predicate(self):
            if self._change is None:
                self._change = asyncio.get_running_loop().create_future()
            await asyncio.shield(self._change)

    async def open(self) -> None:
        """Start the first render process.

        Raises:
            RenderError: when it cannot start (the world is refused at load, rather than retried).
        """
        await self.renderer.open()

    async def render(self, qpos: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray | None]:
        """The frames and laser ranges at joint positions *qpos* (see :meth:`SensorRenderer.render`).

        Raises:
            RenderError: when the process died, hung or failed to draw: the frames are down
                (``on_down`` was called); :meth:`restart` brings them back.
        """
        try:
            frames = await self.renderer.render(qpos)
        except RenderError as exc:
            self.up, self.last_error = False, str(exc)
            self.failures += 1
            self._on_down(str(exc))
            self._notify()
            self._log.error("world %s: %s; cameras and laser are down, starting a new render process", self.name, exc)
            raise
        if not self.up:
            if self.failures:
                self._log.info("world %s: cameras and laser back after %d failures", self.name, self.failures)
            self.up = True
            self._notify()
        return frames

    async def restart(self) -> None:
        """Start render processes until one is ready: at once, then with a delay doubling up to :data:`BACKOFF_MAX`.

        Its first frame (the next :meth:`render`) makes the data current again.
        """
        delay = 0.0
        while True:
            await self.renderer.aclose()
            if delay:
                await asyncio.sleep(delay)  # real time: a process's start does not follow a simulated clock
            try:
                await self.renderer.open()
                return
            except RenderError as exc:
                self.failures += 1
                self.start_failures += 1
                self.last_error = str(exc)
                delay = min(BACKOFF_MAX, max(BACKOFF_FIRST, 2 * delay))
                self._log.error("world %s: a new render process failed (%s); next attempt in %.2g s", self.name, exc,
                           delay)
                self._notify()

    async def aclose(self) -> None:
        """End the render process (see :meth:`SensorRenderer.aclose`)."""
        await self.renderer.aclose()
