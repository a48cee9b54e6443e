"""A component host's presence on Zenoh: its id and facts, its heartbeat, its offers, its dead-man switch.

Gateways read the facts (``/`` shows where each instance runs), hear the heartbeat (a port of a
host not heard from within the gateway's bound is not served as current), and follow the offers.
The heartbeat is as frequent as the processes that hear it ask in their hear tokens (four beats within
the shortest stale bound), not more: its cost in the router and the gateway grows with the hosts.
The host follows the gateways' liveliness tokens: when a gateway vanishes (its process died, or
its link stayed cut past Zenoh's lease), the motions it started stop, as with a dead-man switch.
"""

from __future__ import annotations

import asyncio
import contextlib
import importlib.metadata
import logging
from typing import Any

import orjson
import zenoh

from ..components.core import Component, ComponentHost
from ._exporter import ComponentExporter
from ._session import alive, on_zenoh_thread
from ._wire import (
    BEAT_PERIOD, GATEWAYS, HEARERS, PROTOCOL, beat_key, facts_key, gateway_token, ok_reply, parse_hear,
)

__all__ = ["HostNode"]

log = logging.getLogger(__name__)


class HostNode:
    """Offers the instances of one component host on a Zenoh session until :meth:`close`.

    Args:
        session: The open Zenoh session (left open: its owner closes it).
        host: The component host whose instances are offered.
        host_id: The name gateways know this host by (``demo@<host_id>``).
        endpoints: The Zenoh endpoints this host listens on, else those it connects to (for ``/``).
    """

    def __init__(self, session: zenoh.Session, host: ComponentHost, host_id: str, endpoints: list[str]) -> None:
        self.session = session
        self.host = host
        self.host_id = host_id
        self.endpoints = endpoints
        self.zid = str(session.zid())
        self.loop = asyncio.get_running_loop()
        self.exporters: dict[str, ComponentExporter] = {}
        self._gateways: set[str] = set()
        #: The seconds between two beats each process that hears them asked (by session id).
        self._hearers: dict[str, float] = {}
        #: Set when the beat period may have shortened: the beat that waits is sent at once.
        self._hurry = asyncio.Event()
        self._checking: set[str] = set()
        self._tasks: set[asyncio.Task[Any]] = set()
        self._facts = ok_reply(self.facts())
        # Answered on Zenoh's thread from the facts made on the loop (replacing a reference is atomic).
        self._facts_queryable = session.declare_queryable(facts_key(self.zid), on_zenoh_thread(self._on_facts))
        self._beat = session.declare_publisher(beat_key(self.zid), express=True,
                                               congestion_control=zenoh.CongestionControl.DROP)
        self._spawn(self._beating(), "zenoh heartbeat")
        # With history: the gateways already there come first, then every change.
        self._watch = session.liveliness().declare_subscriber(GATEWAYS, on_zenoh_thread(self._on_gateway),
                                                              history=True)
        self._hear_watch = session.liveliness().declare_subscriber(HEARERS, on_zenoh_thread(self._on_hearer),
                                                                   history=True)

    # -- offers ------------------------------------------------------------------------------

    def offer(self, component: Component) -> ComponentExporter:
        """Offer *component* to gateways."""
        exporter = self.exporters[component.instance] = ComponentExporter(self, component)
        self._facts = ok_reply(self.facts())
        return exporter

    def withdraw(self, instance: str) -> ComponentExporter | None:
        """Stop listing *instance* (killed or unloaded) at once; return its exporter, for the caller to close.

        The offer itself goes when the exporter is closed (``await exporter.close()``).
        """
        exporter = self.exporters.pop(instance, None)
        self._facts = ok_reply(self.facts())
        return exporter

    def facts(self) -> dict[str, Any]:
        """What gateways show of this host: id, session, protocol, versions, endpoints, instances, sockets."""
        settings = self.host.settings
        return {
            "host": self.host_id, "zid": self.zid, "protocol": PROTOCOL,
            "aiogenomix": importlib.metadata.version("aiogenomix"), "endpoints": self.endpoints,
            "instances": {name: {"component": exporter.component.genom_name, "version": exporter.component.version}
                          for name, exporter in self.exporters.items()},
            # Where a dedicated audio socket of this host listens once opened (DedicatedSocket).
            "audio_socket": {"host": settings.audio_socket_host, "port": settings.audio_socket_port},
        }

    def _on_facts(self, query: zenoh.Query) -> None:
        with contextlib.suppress(zenoh.ZError):
            query.reply(query.key_expr, self._facts, express=True)
        query.drop()  # type: ignore[no-untyped-call]

    def beat_period(self) -> float:
        """Seconds between two heartbeats: the shortest any process that hears them asks.

        A gateway of before the hear tokens asks nothing and gets :data:`BEAT_PERIOD`, as does
        everyone when nobody asks (a process that reads this host and says nothing may be listening).
        """
        asked = [*self._hearers.values(), *(BEAT_PERIOD for gateway in self._gateways if gateway not in self._hearers)]
        return min(asked, default=BEAT_PERIOD)

    async def _beating(self) -> None:
        beat = 0
        while True:
            beat += 1
            with contextlib.suppress(zenoh.ZError):
                self._beat.put(orjson.dumps(beat))
            self._hurry.clear()
            # A hearer that asks for more frequent beats gets the next one at once, not after the old period.
            # asyncio.timeout, not wait_for: on Python 3.11 wait_for loses a cancellation that comes in
            # the turn the hurry wakes it (a gateway going as the host closes), and close waited for ever.
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(self.beat_period()):
                    await self._hurry.wait()

    def _on_hearer(self, sample: zenoh.Sample) -> None:
        hearer = parse_hear(str(sample.key_expr))
        if hearer is not None:
            self.loop.call_soon_threadsafe(self._hearer_changed, *hearer, sample.kind != zenoh.SampleKind.DELETE)

    def _hearer_changed(self, hearer: str, period: float, present: bool) -> None:
        before = self.beat_period()
        if present:
            self._hearers[hearer] = period
        elif self._hearers.get(hearer) == period:
            del self._hearers[hearer]
        if self.beat_period() < before:
            self._hurry.set()

    # -- the dead-man switch -----------------------------------------------------------------

    def _on_gateway(self, sample: zenoh.Sample) -> None:
        gateway = str(sample.key_expr).rsplit("/", 1)[-1]
        self.loop.call_soon_threadsafe(self._gateway_changed, gateway, sample.kind != zenoh.SampleKind.DELETE)

    def _gateway_changed(self, gateway: str, present: bool) -> None:
        if present:
            before = self.beat_period()
            self._gateways.add(gateway)
            if self.beat_period() < before:
                self._hurry.set()
            return
        self._gateways.discard(gateway)
        log.info("gateway %s is gone", gateway)
        self._spawn(self._gateway_gone(gateway), f"dead-man {gateway}")

    async def _gateway_gone(self, gateway: str) -> None:
        # Every instance's motions stop at once, not one instance after another's stop paths.
        exporters = list(self.exporters.values())
        outcomes = await asyncio.gather(*(exporter.orphan(gateway) for exporter in exporters),
                                        return_exceptions=True)
        for exporter, outcome in zip(exporters, outcomes, strict=True):
            if isinstance(outcome, BaseException):
                log.error("%s: the motions of gateway %s could not all be stopped", exporter.instance, gateway,
                          exc_info=outcome)
            exporter.forget_gateway(gateway)

    def expect_gateway(self, gateway: str) -> None:
        """A motion of *gateway* started: make sure the gateway is there, else stop it at once.

        The gateway declares its token before it sends anything, but the host may hear of the
        send first, and a gateway that died before its token arrived would never be seen leaving.
        """
        if gateway in self._gateways or gateway in self._checking:
            return
        self._checking.add(gateway)
        self._spawn(self._confirm(gateway), f"confirm gateway {gateway}")

    async def _confirm(self, gateway: str) -> None:
        try:
            present = bool(await alive(self.session, gateway_token(gateway)))
        finally:
            self._checking.discard(gateway)
        if not present and gateway not in self._gateways:
            log.warning("gateway %s sent a motion but holds no liveliness token", gateway)
            await self._gateway_gone(gateway)

    # -- lifetime ----------------------------------------------------------------------------

    def _spawn(self, work: Any, name: str) -> None:
        task = self.loop.create_task(work, name=name)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def close(self) -> None:
        """Withdraw every offer, then stop the heartbeat and the dead-man switch."""
        for instance in list(self.exporters):
            exporter = self.withdraw(instance)
            if exporter is not None:
                await exporter.close()
        for task in list(self._tasks):
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        for declared in (self._watch, self._hear_watch, self._beat, self._facts_queryable):
            with contextlib.suppress(zenoh.ZError):
                declared.undeclare()  # type: ignore[no-untyped-call]
