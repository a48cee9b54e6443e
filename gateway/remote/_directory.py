"""Finding components of other processes on Zenoh, and noticing when they go.

A :class:`ZenohDirectory` is a host's :class:`~aiogenomix.components.core.RemoteFinder`: ``load``
asks it for a component before looking among the local ones.  It follows the liveliness tokens of
every component host: a token that disappears (the process died, or the network was cut long
enough for Zenoh to give up on it) makes the proxy of that instance end its requests and unload.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import zenoh

from ...components.core import Component, ComponentHost, LoadError
from ._proxy import RemoteComponent, RemoteTimeouts, describe_remote
from ._session import ZenohEndpoints, alive, on_zenoh_thread, open_session
from ._wire import alive_key

__all__ = ["ZenohDirectory"]

log = logging.getLogger(__name__)


class ZenohDirectory:
    """Finds remote components for a host and follows their liveliness.

    Use :meth:`open` to create one; :meth:`aclose` closes its session.

    Args:
        session: An open Zenoh session (owned by the directory from now on).
        timeouts: How long queries to component hosts may take.
    """

    def __init__(self, session: zenoh.Session, timeouts: RemoteTimeouts | None = None) -> None:
        self.session = session
        self.timeouts = timeouts or RemoteTimeouts()
        self._loop = asyncio.get_running_loop()
        self._proxies: dict[str, RemoteComponent] = {}
        self._offered: set[str] = set()
        # With history: the tokens already declared come first, then every change.
        self._watch = session.liveliness().declare_subscriber(alive_key("*"), on_zenoh_thread(self._on_liveliness),
                                                              history=True)

    @classmethod
    async def open(cls, endpoints: ZenohEndpoints, timeouts: RemoteTimeouts | None = None) -> ZenohDirectory:
        """Open a Zenoh session on *endpoints* and a directory on it."""
        session = await asyncio.to_thread(open_session, endpoints)
        return cls(session, timeouts)

    async def find(self, host: ComponentHost, name: str, argv: list[str]) -> Component | None:
        """A started proxy of *name* when a component host offers it now, else None.

        Raises:
            LoadError: for load options (a remote instance is configured where it runs).
            RemoteUnreachable: when its host offers it but does not describe it in time.
        """
        if not await alive(self.session, alive_key(name), timeout=self.timeouts.control):
            return None
        if argv:
            raise LoadError(f"{name} runs in another process: its options are given to aiogenomix-component there")
        description = await describe_remote(self.session, name, self.timeouts.control)
        proxy = RemoteComponent(host, name, self.session, description, self.timeouts)
        await proxy.start()
        self._proxies[name] = proxy
        host.add_unload_listener(lambda instance: self._forget(instance, proxy))
        return proxy

    def _forget(self, instance: str, proxy: RemoteComponent) -> None:
        if self._proxies.get(instance) is proxy:
            del self._proxies[instance]

    def offered(self) -> list[str]:
        """The instances whose liveliness token this directory sees now."""
        return sorted(self._offered)

    def _on_liveliness(self, sample: zenoh.Sample) -> None:
        instance = str(sample.key_expr).rsplit("/", 1)[-1]
        if sample.kind == zenoh.SampleKind.DELETE:
            self._loop.call_soon_threadsafe(self._gone, instance)
        else:
            self._loop.call_soon_threadsafe(self._offered.add, instance)

    def _gone(self, instance: str) -> None:
        self._offered.discard(instance)
        proxy = self._proxies.pop(instance, None)
        if proxy is not None:
            log.warning("%s is gone: its component host stopped or cannot be reached", instance)
            proxy.lost(f"the process of {instance} stopped or cannot be reached")

    async def aclose(self) -> None:
        """Close the session (the proxies were unloaded by the host first)."""
        with contextlib.suppress(zenoh.ZError):
            self._watch.undeclare()  # type: ignore[no-untyped-call]
        await asyncio.to_thread(self.session.close)
