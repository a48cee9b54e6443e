"""A watch stream lives as long as its instance: unload and kill end it; after kill, requests get 404."""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator
from typing import Any

import aiohttp

from tests.conftest import RawEventStream


async def _events(reply: aiohttp.ClientResponse) -> AsyncIterator[tuple[str, Any]]:
    """The events of a stream, as ``(name, data)``, until the stream ends."""
    name = ""
    async for raw in reply.content:
        line = raw.decode().rstrip("\n")
        if line.startswith("event: "):
            name = line[7:]
        elif line.startswith("data: "):
            yield name, json.loads(line[6:])


async def _rest(events: AsyncIterator[tuple[str, Any]]) -> list[tuple[str, Any]]:
    """Every event left, once the stream has ended (bounded: a stream that never ends fails the test)."""

    async def collect() -> list[tuple[str, Any]]:
        return [event async for event in events]

    return await asyncio.wait_for(collect(), 10)


async def test_unload_ends_every_watch_of_the_instance(http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo")
    async with http.get("/module/demo/watch/Mobile") as first, http.get("/module/demo/watch/Mobile") as second:
        streams = [_events(first), _events(second)]
        for events in streams:
            assert await anext(events) == ("port", {"Mobile": {"position": 0.0, "speed": 0.0}, "lost": 0})
        async with http.get("/unload/demo") as reply:
            assert reply.status == 200
        for events in streams:
            assert await _rest(events) == [("unload", "demo")]
    # An instance loaded again under the same name is watched afresh.
    await http.get("/load/demo")
    async with http.get("/module/demo/watch/Mobile") as again:
        assert (await anext(_events(again)))[0] == "port"


async def test_kill_ends_the_watches_and_later_requests_get_404(gateway: str, http: aiohttp.ClientSession) -> None:
    await http.get("/load/demo")
    listener = await RawEventStream.open(gateway, "user")
    try:
        async with http.get("/module/demo/watch/Mobile") as watch:
            events = _events(watch)
            assert (await anext(events))[0] == "port"
            async with http.get("/module/demo/send/kill", params={"s": "user"}) as reply:
                assert reply.status == 200
            assert await _rest(events) == [("unload", "demo")]
        # The kill request is sent, ends, then every session hears of the unload.
        assert [await listener.next_event() for _ in range(3)][2] == ("unload", '"demo"')
    finally:
        listener.close()
    # As docs/protocol.md says: a killed instance is unloaded, so it is no longer there.
    async with http.get("/module/demo/send/GetSpeed") as reply:
        body = await reply.json()
    assert (reply.status, body["ex"]) == (404, "::genomix::no_such_module")
    async with http.get("/load/demo") as reply:  # and it can be loaded again
        assert reply.status == 200
