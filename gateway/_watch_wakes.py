"""When the watchers of a port wake: its next publication, its instance's end, the gateway's shutdown, or a ping.

A hundred ``watch`` streams of one port each waited with ``asyncio.wait`` on
the port's next publication, the instance's end and the gateway's shutdown,
with the ping interval as timeout: three callbacks added and removed, a timer
armed and cancelled, per stream and per publication.  Profiled under the
fan-out benchmark, that was about a third of the gateway's time.  Here the
watchers of a port share them: each waits on a future of its own (so that a
watcher that is cancelled cancels nobody else's wait), and one callback per
publication, and one timer per round of waits, end them all.
"""

from __future__ import annotations

import asyncio
import weakref
from collections.abc import Callable
from typing import Any

from ..components.core import OutPortRuntime
from ._unloads import Unloads

__all__ = ["WatchWakes"]


class _PortWaiters:
    """The watchers of one port waiting now, and what wakes them."""

    __slots__ = ("futures", "armed", "ping", "ended")

    def __init__(self) -> None:
        self.futures: list[asyncio.Future[None]] = []
        # A round of waits is armed: the next publication and a ping timer will end it.
        self.armed = False
        self.ping: asyncio.TimerHandle | None = None
        # The instance is gone or the gateway stops: no wait lasts any more.
        self.ended = False

    def wake(self, _: object = None) -> None:
        """End the round: every waiting watcher wakes."""
        self.armed = False
        if self.ping is not None:
            self.ping.cancel()
            self.ping = None
        futures, self.futures = self.futures, []
        for future in futures:
            if not future.done():
                future.set_result(None)

    def end(self, _: object = None) -> None:
        """The instance or the gateway ended: wake everyone, now and from now on."""
        self.ended = True
        self.wake()


class WatchWakes:
    """Wakes the watchers of each port together (see the module's description).

    Held by the application, as the watch frames are.

    Args:
        unloads: The end of each instance.
        stopping: A future done when the gateway shuts down.
        ping_interval: Seconds after which waiting watchers wake with nothing new (to send a ping).
    """

    def __init__(self, unloads: Unloads, stopping: Callable[[], asyncio.Future[None]], ping_interval: float) -> None:
        self._unloads = unloads
        self._stopping = stopping
        self.ping_interval = ping_interval
        self._ports: weakref.WeakKeyDictionary[OutPortRuntime[Any], _PortWaiters] = weakref.WeakKeyDictionary()

    async def wait(self, port: OutPortRuntime[Any]) -> None:
        """Wait until *port* publishes, its instance ends, the gateway stops, or a ping is due."""
        waiters = self._ports.get(port)
        if waiters is None:
            waiters = self._ports[port] = _PortWaiters()
            # Once per port: both are done once, for good (the callbacks hold the waiters, not the port).
            for ended in (self._unloads.of(port.owner), self._stopping()):
                ended.add_done_callback(waiters.end)
        if waiters.ended:
            return
        loop = asyncio.get_running_loop()
        mine = loop.create_future()
        waiters.futures.append(mine)
        if not waiters.armed:
            # The first watcher of a round arms what ends it, for all.
            waiters.armed = True
            port.next_publication().add_done_callback(waiters.wake)
            waiters.ping = loop.call_later(self.ping_interval, waiters.wake)
        await mine
