"""Typed keys of the gateway's application state."""

from __future__ import annotations

import asyncio
import weakref
from typing import Any

from aiohttp import web

from ..components.core import ComponentHost, OutPortRuntime
from ._config import GatewayConfig
from ._door import Door
from ._foxglove import FoxgloveView
from ._info_bodies import InfoBodies
from ._read_bodies import ReadBodies
from ._sessions import SessionStore
from ._unloads import Unloads
from ._watch_wakes import WatchWakes

__all__ = ["CONFIG", "DOOR", "FOXGLOVE", "HOST", "INFO_BODIES", "READ_BODIES", "SESSIONS", "SHUTDOWN", "UNLOADS",
           "WATCH_FRAMES", "WATCH_WAKES", "Shutdown", "WatchFrames"]

CONFIG = web.AppKey("config", GatewayConfig)
HOST = web.AppKey("host", ComponentHost)
SESSIONS = web.AppKey("sessions", SessionStore)
UNLOADS = web.AppKey("unloads", Unloads)
#: The live view in Foxglove (set only with ``--foxglove``).
FOXGLOVE = web.AppKey("foxglove", FoxgloveView)
#: Whether the gateway answers a request: the one decision of the guard and of the fast reads.
DOOR = web.AppKey("door", Door)


class Shutdown:
    """Done when the gateway shuts down, so that endless streams end (one future for all of them)."""

    def __init__(self) -> None:
        self._future: asyncio.Future[None] | None = None

    @property
    def future(self) -> asyncio.Future[None]:
        """The shared future (created in the running loop on first use)."""
        if self._future is None:
            self._future = asyncio.get_running_loop().create_future()
        return self._future

    def is_set(self) -> bool:
        """Whether the gateway is shutting down."""
        return self._future is not None and self._future.done()

    def set(self) -> None:
        """Announce the shutdown."""
        if not self.future.done():
            self.future.set_result(None)


SHUTDOWN = web.AppKey("shutdown", Shutdown)


class WatchFrames(weakref.WeakKeyDictionary[OutPortRuntime[Any],
                                            tuple[tuple[Any, ...], tuple[bytes | memoryview, ...], int | None]]):
    """The last ``port`` event frame of each watched port, with its key and the reader's new index.

    Watchers in step with each other share one encoding.  Held by the app (not
    by a module): two gateways in one process never share frames.  The frame of
    a port is let go when its last watcher leaves (:meth:`left`): a frame of the
    whole audio window holds 150 MB of text.
    """

    def __init__(self) -> None:
        super().__init__()
        self._watchers: weakref.WeakKeyDictionary[OutPortRuntime[Any], int] = weakref.WeakKeyDictionary()

    def joined(self, port: OutPortRuntime[Any]) -> None:
        """A watcher of *port* began."""
        self._watchers[port] = self._watchers.get(port, 0) + 1

    def left(self, port: OutPortRuntime[Any]) -> None:
        """A watcher of *port* ended: the last one takes the port's frame with it."""
        remaining = self._watchers.get(port, 0) - 1
        if remaining > 0:
            self._watchers[port] = remaining
            return
        self._watchers.pop(port, None)
        self.pop(port, None)


WATCH_FRAMES = web.AppKey("watch_frames", WatchFrames)
#: What wakes the watchers of each port, together.
WATCH_WAKES = web.AppKey("watch_wakes", WatchWakes)


#: The bodies of whole reads of chunked ports, made once per publication and form.
READ_BODIES = web.AppKey("read_bodies", ReadBodies)
#: Each loaded instance's ``/info`` body, encoded once.
INFO_BODIES = web.AppKey("info_bodies", InfoBodies)
