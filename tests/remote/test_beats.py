"""A component host beats as often as those who hear it ask: four beats within the shortest stale bound.

A gateway says in its hear token how often it needs a beat (``--zenoh-stale`` ÷ 4); a gateway of before
the hear tokens, which says nothing, gets the old period (0.25 s).  The beats are counted by a Zenoh
session of this test, connected to a real host process, over windows of a few seconds (a measurement,
not a synchronisation: the counts asserted are far apart).
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import AsyncIterator

import pytest
import zenoh

from aiogenomix.remote import ZenohSettings
from aiogenomix.remote._session import open_session
from aiogenomix.remote._wire import BEAT_PERIOD, BEATS, gateway_token, hear_token

from ._processes import Process, free_port, start_component_host, start_gateway

#: Seconds over which beats are counted.
WINDOW = 3.0


class BeatCounter:
    """The beats this test's session hears (it declares no hear token of its own unless told to)."""

    def __init__(self, session: zenoh.Session) -> None:
        self.session = session
        self._count = 0
        self._lock = threading.Lock()
        self._subscriber = session.declare_subscriber(BEATS, self._on_beat)

    def _on_beat(self, _sample: zenoh.Sample) -> None:
        with self._lock:  # on Zenoh's thread
            self._count += 1

    async def per_second(self) -> float:
        """Beats heard per second over :data:`WINDOW`."""
        with self._lock:
            before = self._count
        await asyncio.sleep(WINDOW)  # the measurement's window
        with self._lock:
            return (self._count - before) / WINDOW


@pytest.fixture
async def host(started: list[Process]) -> AsyncIterator[str]:
    """A component host running ``demo``, listening on loopback; yields its endpoint."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    started.append(await start_component_host(["demo"], listen=endpoint))
    yield endpoint


@pytest.fixture
async def counter(host: str) -> AsyncIterator[BeatCounter]:
    session, _ = await asyncio.to_thread(open_session, ZenohSettings(connect=[host]))
    try:
        yield BeatCounter(session)
    finally:
        await asyncio.to_thread(session.close)


async def test_a_host_beats_as_often_as_its_gateways_ask(host: str, counter: BeatCounter,
                                                         started: list[Process]) -> None:
    # Nobody says how often: the old period, for whoever may be listening.
    assert await counter.per_second() > 0.5 / BEAT_PERIOD
    gateway, _ = await start_gateway([host], extra=["--zenoh-stale", "4"])
    started.append(gateway)
    # A gateway whose stale bound is 4 s needs a beat every second: four times fewer beats than before.
    assert await counter.per_second() < 0.5 / BEAT_PERIOD
    # A process that needs a beat every 0.1 s (a stale bound of 0.4 s) gets them, at once...
    token = counter.session.liveliness().declare_token(hear_token(str(counter.session.zid()), 0.4))
    assert await counter.per_second() > 5
    # ... and only while it is there.
    token.undeclare()
    assert await counter.per_second() < 0.5 / BEAT_PERIOD
    # A gateway of before the hear tokens says nothing of its needs: it gets the old period.
    old = counter.session.liveliness().declare_token(gateway_token(str(counter.session.zid())))
    assert await counter.per_second() > 0.5 / BEAT_PERIOD
    old.undeclare()
