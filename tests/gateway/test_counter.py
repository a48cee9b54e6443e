"""countserver and countclient (seed appendix 9.3.2) through the gateway and in-process."""

from __future__ import annotations

import json
import logging

import aiohttp
import pytest

from aiogenomix.components.core import ComponentHost, ManualClock
from tests.conftest import RawEventStream


async def test_count_from_out_of_range_is_refused(http: aiohttp.ClientSession) -> None:
    await http.get("/load/countserver")
    async with http.get("/module/countserver/send/CountFrom", params={"input": '{"initial_value":5000}'}) as reply:
        # Refused by validate inside the component: a request that ends in error, as in genom3.
        assert reply.status == 200
        assert await reply.json() == {"id": "countserver::0", "status": "error",
                                      "exception": {"ex": "::countserver::INVALID_INITIAL_VALUE"}}


async def test_count_start_interrupts_count_from(gateway: str, http: aiohttp.ClientSession) -> None:
    await http.get("/load/countserver")
    stream = await RawEventStream.open(gateway, "c")
    try:
        async with http.get("/module/countserver/send/CountFrom",
                            params={"s": "c", "input": '{"initial_value":10}'}) as reply:
            assert await reply.json() == {"id": "countserver::0", "status": "sent"}
        assert (await stream.next_event())[0] == "request"
        async with http.get("/module/countserver/send/CountStart", params={"s": "c"}) as reply:
            assert (await reply.json())["status"] == "sent"
        ended = json.loads((await stream.next_event())[1] or "")
        assert ended == {"id": "countserver::0", "status": "error",
                         "exception": {"ex": "::genom::interrupted", "detail": {"by": "CountStart"}}}
        async with http.get("/module/countserver/send/CountStop", params={"s": "c"}) as reply:
            assert (await reply.json())["status"] == "done"
    finally:
        stream.close()


async def test_countclient_displays_every_other_value(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="aiogenomix.components.counter")
    # A manual clock: the display and count periods are then met exactly, whatever the machine's load
    # (on a sped-up real clock, a stalled process skips periods and a display shows a bigger step).
    clock = ManualClock()
    async with ComponentHost(clock=clock) as host:
        server = await host.load("countserver")
        client = await host.load("countclient")
        connect = await client.send("connect_port", {"local": "CounterPort", "remote": "countserver/CounterPort"})
        assert connect.status == "done"
        await server.send("CountFrom", {"initial_value": 0})
        shown = []
        for _ in range(6):
            await clock.advance(1.0)  # one display period
            shown.append((client.Displayed.read().displays, client.Displayed.read().counter.current))
        # The client runs at 1000 ms, the server at 500 ms: one display a second, two counts per display.
        assert [d for d, _ in shown] == [1, 2, 3, 4, 5, 6]
        assert [b - a for (_, a), (_, b) in zip(shown, shown[1:], strict=False)] == [2] * 5
    assert any("counter" in message for message in caplog.messages)


async def test_connect_port_to_an_unknown_port_fails_cleanly(http: aiohttp.ClientSession) -> None:
    await http.get("/load/countclient")
    async with http.get("/module/countclient/send/connect_port",
                        params={"input": '{"local":"CounterPort","remote":"countserver/CounterPort"}'}) as reply:
        body = await reply.json()
    assert body["status"] == "error" and body["exception"]["ex"] == "::genom::no_such_outport"
